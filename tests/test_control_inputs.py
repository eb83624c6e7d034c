"""WorkspaceController.compute on any state: random, NaN, huge, zero or denormal quaternions,
wrong lengths, any contact flags, targets and gains. Every call ends in finite outputs that satisfy
W Alg. 5 (the feet's shares sum to the desired wrench) or in a one-line BipedError naming what is
wrong; never another exception, never non-finite torques. Hypothesis draws the inputs."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from biped.control import Gains, Target, WorkspaceController
from biped.errors import BipedError, ScenarioError, StateError


@pytest.fixture(scope="module")
def setup(wendlandt_path):
    ctrl = WorkspaceController.from_mjcf(wendlandt_path)
    model = mujoco.MjModel.from_xml_path(str(wendlandt_path))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    return ctrl, data.qpos.copy(), data.qvel.copy()


_ODD = st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, 1e160, 1e-320, 0.0, -0.0])
_SCALE = st.sampled_from([1.0, 1e-300, 1e-160, 1e-20, 1e20, 1e160, 1e300, 0.0, -1.0])


@st.composite
def _state(draw, q0, v0):
    q = q0.copy()
    v = v0.copy()
    q[0:3] += draw(st.lists(st.floats(-2, 2), min_size=3, max_size=3))
    q[7:] += draw(st.lists(st.floats(-1, 1), min_size=len(q) - 7, max_size=len(q) - 7))
    v[:] = draw(st.lists(st.floats(-50, 50), min_size=len(v), max_size=len(v)))
    quat = np.array(draw(st.lists(st.floats(-1, 1), min_size=4, max_size=4)))
    q[3:7] = quat * draw(_SCALE)
    kind = draw(st.sampled_from(["plain", "plain", "odd_q", "odd_v", "huge_v", "length"]))
    if kind == "odd_q":
        q[draw(st.integers(0, len(q) - 1))] = draw(_ODD)
    elif kind == "odd_v":
        v[draw(st.integers(0, len(v) - 1))] = draw(_ODD)
    elif kind == "huge_v":
        v *= draw(st.sampled_from([1e10, 1e100, 1e200]))
    elif kind == "length":
        q = q[: draw(st.integers(0, len(q) - 1))] if draw(st.booleans()) else np.append(q, 0.0)
    return q, v


_VEC3 = st.lists(st.floats(-2, 2), min_size=3, max_size=3)


def _spoil(draw, values: dict) -> dict:
    """One time in four, one entry of one vector made non-finite, huge or zero."""
    if draw(st.integers(0, 3)) == 0:
        key = draw(st.sampled_from(sorted(values)))
        vec = list(values[key])
        vec[draw(st.integers(0, len(vec) - 1))] = draw(_ODD)
        values[key] = vec
    return {k: tuple(v) for k, v in values.items()}


@st.composite
def _target(draw):
    if draw(st.booleans()):
        return None
    quat = draw(st.lists(st.floats(-1, 1), min_size=4, max_size=4))
    n = math.sqrt(sum(x * x for x in quat))
    if n > 1e-3 and draw(st.integers(0, 3)):
        quat = [x / n for x in quat]  # a unit quaternion, usually accepted
    return _spoil(draw, {"com": draw(_VEC3), "com_vel": draw(_VEC3), "quat": quat})


@st.composite
def _gains(draw):
    if draw(st.booleans()):
        return None
    g = st.lists(st.floats(0, 1e4), min_size=3, max_size=3)
    return _spoil(draw, {"kp_com": draw(g), "kv_com": draw(g), "kp_rot": draw(g), "kv_rot": draw(g)})


def test_compute_on_any_input_is_finite_or_a_one_line_error(setup):
    ctrl, q0, v0 = setup

    @settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(_state(q0, v0), _target(), _gains(), st.one_of(st.none(), st.tuples(st.booleans(), st.booleans())))
    def check(state, target, gains, feet):
        qpos, qvel = state
        try:
            t = None if target is None else Target(**target)
            g = None if gains is None else Gains(**gains)
            out = ctrl.compute(qpos, qvel, target=t, gains=g, feet_in_contact=feet)
        except BipedError as exc:
            assert "\n" not in str(exc) and str(exc), repr(exc)
            event(f"error: {type(exc).__name__}")
            return
        event("computed")
        arrays = (out.torques, out.P1, out.z1, out.wrench_desired, out.wrench_left, out.wrench_right)
        assert all(np.isfinite(a).all() for a in arrays)
        assert out.torques.shape == (len(ctrl.joint_names),)
        both_down = feet is None or all(feet)
        if both_down:  # W Alg. 5: the two shares sum to F_1^bd
            scale = max(1.0, float(np.abs(out.wrench_desired).max()))
            assert np.allclose(
                out.wrench_left + out.wrench_right, out.wrench_desired, rtol=1e-9, atol=1e-9 * scale
            )
        elif feet == (False, False):  # no foot down: nothing is distributed
            assert not out.wrench_left.any() and not out.wrench_right.any()

    check()


def test_non_finite_and_scaled_quaternions_are_named(setup):
    ctrl, q0, v0 = setup
    q = q0.copy()
    q[3:7] *= 1e160  # the reported ZeroDivisionError: normalized, same result as the unit one
    assert np.allclose(ctrl.compute(q, v0).torques, ctrl.compute(q0, v0).torques, rtol=1e-9)
    q[3:7] = 0.0
    with pytest.raises(BipedError, match=r"qpos\[3:7\]"):
        ctrl.compute(q, v0)
    q = q0.copy()
    q[9] = math.nan
    with pytest.raises(BipedError, match=r"qpos\[9\]"):
        ctrl.compute(q, v0)


# ---------------------------------------------------------------------------------------------
# the reported model inputs

_THIRD_LEG = (
    '<body name="t1" pos="0.1 0 -0.2"><joint name="tj1" axis="0 1 0"/>'
    '<inertial pos="0 0 -0.2" mass="2" diaginertia="0.03 0.03 0.006"/></body>'
)


def test_a_root_foot_a_third_leg_and_an_empty_source_are_model_errors(tmp_path, wendlandt_path):
    from conftest import ASYM_XML

    from biped.errors import ModelError

    with pytest.raises(ModelError, match="floating root"):
        WorkspaceController.from_mjcf(wendlandt_path, feet=("central_body", "right_foot"))
    three = tmp_path / "three.xml"
    three.write_text(ASYM_XML.replace("</body></worldbody>", _THIRD_LEG + "</body></worldbody>"))
    mujoco.MjModel.from_xml_path(str(three))  # a valid MJCF that MuJoCo simulates...
    with pytest.raises(ModelError, match="no torque"):  # ...but the controller cannot drive
        WorkspaceController.from_mjcf(three, feet=("lfoot", "rfoot"))
    with pytest.raises(ModelError, match="empty model source"):
        WorkspaceController.from_mjcf("")


def test_a_nan_state_is_one_short_line_with_the_count_and_the_first_entries(setup):
    """Every entry NaN: the message counts them and names only the first few (it used to list all
    62 on one line)."""
    ctrl, q0, v0 = setup
    q, v = np.full_like(q0, math.nan), np.full_like(v0, math.nan)
    with pytest.raises(StateError) as info:
        ctrl.compute(q, v)
    msg = str(info.value)
    n = q.size + v.size
    assert msg == (
        f"qpos and qvel must be finite; {n} non-finite entries (NaN or infinite): "
        f"qpos[0], qpos[1], qpos[2] and {n - 3} more"
    )
    q = q0.copy()
    q[9] = math.inf
    with pytest.raises(StateError, match=r"; 1 non-finite entry \(NaN or infinite\): qpos\[9\]$"):
        ctrl.compute(q, v0)


@pytest.mark.parametrize(
    ("quat", "norm"),
    [
        ((1e308, 0, 0, 0), "1e+308"),
        ((1e308, 1e308, 0, 0), "1.41421356e+308"),
        ((1.7e308, 1.7e308, 0, 0), "inf"),
    ],
)
def test_a_huge_target_quaternion_is_a_clean_error_without_numpy_warnings(quat, norm):
    """The norm of a 1e308 quaternion overflowed in numpy (a RuntimeWarning printed before the
    error); math.hypot scales, so the message states the norm and nothing else is printed."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any warning fails the test
        with pytest.raises(ScenarioError) as info:
            Target(quat=quat)
    assert str(info.value) == f"target quat must be a unit quaternion (w, x, y, z); its norm is {norm}"


def test_a_huge_target_tilt_on_the_command_line_is_one_line(tmp_path, capsys):
    """The command line sets the target by axis and tilt, never by quaternion: a 1e308 tilt is
    refused by the scenario's range, in one line and with no warning."""
    import warnings

    from biped.cli import main

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rc = main(["push", "--set", "target_tilt_deg=1e308", "--out", str(tmp_path / "r"), "--quiet"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1, err
    assert err.startswith("biped push: error: target_tilt_deg must be in [-90, 90]")
