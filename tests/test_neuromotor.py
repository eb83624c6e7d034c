"""The neuromotor keys (delay, activation lag, rate limit, presets, ankle_only) and the delay margin.

References the project did not compute: python-control's Pade approximation of the delay, the
closed form of a first-order lag's step response, MuJoCo's own state (the run without the push).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from biped.control import neuromotor as nm
from biped.errors import ScenarioError
from biped.planar import delay
from biped.sim import Scenario
from biped.sim.push import controller_policy, run_closed_loop
from biped.sim.scene import build_scene

# the block far away and still: the same run without the push (it falls freely, touching nothing
# until ~0.47 s)
NO_PUSH = {"block_position_m": (3.0, 0.0, 1.2), "block_velocity_m_s": (0.0, 0.0, 0.0)}
HOLD = {"target_com_m": (0.0, 0.0, 1.035), "target_tilt_deg": 5.0}  # W's initial pose as set point


def _run(scenario: Scenario, compiled: bool | None = None):
    scene = build_scene(scenario)
    return run_closed_loop(scenario, scene, controller_policy(scenario, scene), compiled=compiled)


def _first_response_row(scenario: Scenario) -> tuple[int, int]:
    """(row of the block's first contact, first row whose torques differ from the run without it)."""
    pushed = _run(scenario)
    quiet = _run(scenario.with_overrides(**NO_PUSH))
    hit = round(pushed.block_contact_time_s * scenario.control_rate_hz)
    n = min(len(pushed.torques), len(quiet.torques))
    diff = np.abs(pushed.torques[:n] - quiet.torques[:n]).max(axis=1) > 1e-9
    return hit, int(np.argmax(diff))


@pytest.mark.parametrize("delay_s", [0.0, 0.02, 0.1])
def test_the_first_torque_response_comes_feedback_delay_s_after_the_push(delay_s):
    s = Scenario(duration_s=0.25, feedback_delay_s=delay_s, **HOLD)
    hit, first = _first_response_row(s)
    # the hit is seen at the first row after the contact began (one control period)
    assert 0 <= first - hit - s.delay_steps <= 1, (hit, first, s.delay_steps)


def test_the_young_preset_responds_a_delay_after_the_push_too():
    s = Scenario(duration_s=0.25, neuromotor="young", **HOLD)
    hit, first = _first_response_row(s)
    assert s.delay_steps == 50
    assert 0 <= first - hit - 50 <= 1


def test_no_torque_step_exceeds_the_rate_limit_and_the_limit_binds():
    rate = 400.0  # N m/s: 0.8 N m a 2 ms period
    limited = _run(Scenario(duration_s=0.3, torque_rate_limit_n_m_s=rate))
    free = _run(Scenario(duration_s=0.3))
    step = np.abs(np.diff(limited.torques, axis=0))
    assert step.max() <= rate / 500.0 * (1 + 1e-12)
    assert np.abs(np.diff(free.torques, axis=0)).max() > 5 * rate / 500.0  # W's steps are larger
    assert np.isclose(step.max(), rate / 500.0)  # and the limit is reached


def test_the_activation_lag_is_the_exact_first_order_step_response():
    tau_a, period = 0.06, 0.002
    alpha = -math.expm1(-period / tau_a)
    act = np.zeros(3)
    u0, u1 = np.array([1.0, -2.0, 0.5]), np.array([11.0, 3.0, -4.5])
    cmd = u0.copy()
    nm.neural_filter(cmd, act, alpha, np.full(3, np.inf), True)
    assert np.array_equal(cmd, u0)  # the first period holds the first command
    for k in range(1, 101):
        cmd = u1.copy()
        nm.neural_filter(cmd, act, alpha, np.full(3, np.inf), False)
        expected = u1 + (u0 - u1) * math.exp(-k * period / tau_a)
        np.testing.assert_allclose(cmd, expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(
    "extra", [{}, {"distribution": "qp"}, {"controller": "joint-pd", "feedback_delay_s": 0.01}]
)
def test_the_compiled_loop_equals_the_python_loop_bit_for_bit(extra):
    s = Scenario(duration_s=0.3, neuromotor="young", **extra)
    a = _run(s, compiled=False)
    b = _run(s, compiled=True)
    assert np.array_equal(a.torques, b.torques)
    assert np.array_equal(a.qpos, b.qpos)
    assert a.events == b.events


def test_ideal_is_w_and_leaves_the_loop_untouched():
    from biped.control.setpoint import Gains
    from biped.sim.neuro import neuro_loop

    w = Scenario()
    assert w == Scenario(neuromotor="ideal")
    assert (w.kp_com, w.kv_com, w.kp_rot, w.kv_rot) == (
        Gains().kp_com,
        Gains().kv_com,
        Gains().kp_rot,
        Gains().kv_rot,
    )
    assert w.torque_limits == "none" and w.feedback_delay_s == 0 and w.activation_time_s == 0
    assert neuro_loop(w, build_scene(w)) is None  # the loop runs exactly as before these keys
    young = w.with_overrides(neuromotor="young")
    assert young.feedback_delay_s == nm.YOUNG_DELAY_S and young.torque_limits == "human"
    # an explicit key wins over the preset, in either order
    assert w.with_overrides(neuromotor="young", feedback_delay_s=0.05).feedback_delay_s == 0.05
    assert young.with_overrides(neuromotor="ideal") == w


def test_the_delayed_feet_agree_with_the_contact_monitor():
    from biped.sim import contact, fused_kernel, neuro

    assert neuro.STANDING is fused_kernel.STANDING is contact.STANDING  # one definition
    assert contact.STANDING == contact._SOLE_MASK  # both soles down
    assert contact.feet_of_bits(neuro.STANDING) == (True, True)


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("feedback_delay_s", 0.0011),  # not a whole number of 2 ms periods
        ("feedback_delay_s", -0.1),
        ("feedback_delay_s", 2.0),
        ("activation_time_s", -0.01),
        ("torque_rate_limit_n_m_s", 0.0),
        ("torque_rate_limit_n_m_s", [1.0, 2.0]),
        ("torque_rate_limit_n_m_s", "fast"),
        ("neuromotor", "elderly"),
        ("ankle_only", "yes"),
        ("torque_limits", "older"),
    ],
)
def test_bad_neuromotor_values_are_one_line_errors(key, value):
    with pytest.raises(ScenarioError, match=key) as info:
        Scenario.from_dict({key: value})
    assert "\n" not in str(info.value)


def test_human_rate_limits_follow_the_cited_knee_value_and_strength_ratios():
    rates = dict(zip(nm.JOINT_NAMES, nm.human_rate_limits(), strict=True))
    assert rates["left_knee"] == pytest.approx(881.7)
    assert rates["left_ankle_dorsiflexion"] == pytest.approx(881.7 * 2.2 / 3.2)
    older = nm.human_rate_limits(factor=nm.OLDER_RATE_FACTOR)
    assert older[3] == pytest.approx(577.5)


# ------------------------------------------------------------------------------- delay margin


def _pade_stable(a, kp, kv, tau_a, d) -> bool:
    """Closed-loop stability with python-control's 12th-order Pade approximation of the delay."""
    control = pytest.importorskip("control")
    num, den = control.pade(d, 12)
    plant = np.polymul([1.0, 0.0, -a], [tau_a, 1.0])  # (s^2 - a)(tau_a s + 1)
    char = np.polyadd(np.polymul(plant, den), np.polymul([kv, a + kp], num))
    return bool(np.max(np.roots(char).real) < 0)


@pytest.mark.parametrize(
    ("a", "kp", "kv", "tau_a"),
    [
        (0.0, 1.0, 2.0, 0.0),
        (0.0, 9.0, 6.0, 0.06),
        (6.868, 1.3735, 2.4037, 0.06),
        (20.96, 2.2387, 6.7502, 0.06),
    ],
)
def test_delay_margin_matches_a_pade_approximation(a, kp, kv, tau_a):
    m = delay.delay_margin(a, kp, kv, tau_a)
    assert 0 < m < 1
    assert _pade_stable(a, kp, kv, tau_a, 0.97 * m)
    assert not _pade_stable(a, kp, kv, tau_a, 1.03 * m)


def test_delay_margin_of_a_delayed_p_on_a_double_integrator_is_zero_and_of_an_unstable_loop_zero():
    assert delay.delay_margin(0.0, 1.0, 0.0) == 0.0  # s^2 + e^(-sd): no damping, never stable
    assert delay.delay_margin(10.0, -1.0, 5.0) == 0.0  # less stiffness than gravity


def test_the_presets_gains_keep_their_stated_margins():
    required = 1.5 * nm.OLDER_DELAY_S
    kp, kv = nm.peterka_com_gains()
    a = 9.81 * nm.BODY_COM_HEIGHT_M / nm.CONTROLLED_HEIGHT_M**2
    assert (a + kp) / a == pytest.approx(nm.PETERKA_STIFFNESS_MGH)  # Peterka's K / (m g h)
    assert kv / a == pytest.approx(nm.PETERKA_DAMPING_MGH_S)
    assert delay.delay_margin(a, kp, kv, nm.ACTIVATION_TIME_S) > required
    for a_t, kp_t, kv_t in (
        (19.90, *[nm.TRUNK_KP[0], nm.TRUNK_KV[0]]),
        (20.96, nm.TRUNK_KP[1], nm.TRUNK_KV[1]),
    ):
        assert delay.delay_margin(a_t, kp_t, kv_t, nm.ACTIVATION_TIME_S) >= required * 0.999
    assert delay.delay_margin(0.0, nm.VERTICAL_KP, nm.VERTICAL_KV, nm.ACTIVATION_TIME_S) >= required * 0.999
    # W's own gains do not survive the young delay: why the presets replace them
    assert delay.delay_margin(0.0, 50.0, 7.07, nm.ACTIVATION_TIME_S) < nm.YOUNG_DELAY_S


# ------------------------------------------------------------------------------- ankle_only


def test_ankle_only_holds_hips_and_knees_within_a_degree_in_a_small_push():
    s = Scenario(
        duration_s=1.5, neuromotor="young", ankle_only=True, block_velocity_m_s=(-2.0, 0.0, 0.2), **HOLD
    )
    r = _run(s)
    assert r.block_contact_time_s is not None and not r.fell
    moved = np.degrees(np.abs(r.joint_angles - r.joint_angles[0]))
    hips_knees = [i for i, n in enumerate(r.joint_names) if "ankle" not in n]
    ankles = [i for i, n in enumerate(r.joint_names) if "ankle_dorsiflexion" in n]
    assert moved[:, hips_knees].max() < 1.0
    assert moved[:, ankles].max() > 2 * moved[:, hips_knees].max()  # the ankles do the balancing
    free = _run(s.with_overrides(ankle_only=False))
    assert np.degrees(np.abs(free.joint_angles - free.joint_angles[0]))[:, hips_knees].max() > 1.0


def test_ankle_only_lean_release_moves_no_hip_or_knee_by_a_degree():
    s = Scenario(
        perturbation="release",
        release_lean_deg=2.0,
        release_time_s=0.1,
        duration_s=1.5,
        friction=0.8,
        neuromotor="young",
        ankle_only=True,
    )
    r = _run(s)
    assert not r.fell and r.extra["perturbation"]["released_at_s"] == pytest.approx(0.1)
    hips_knees = [i for i, n in enumerate(r.joint_names) if "ankle" not in n]
    ankles = [i for i, n in enumerate(r.joint_names) if "ankle_dorsiflexion" in n]
    moved = np.degrees(np.abs(r.joint_angles - r.joint_angles[0]))
    assert moved[:, hips_knees].max() < 1.0
    assert moved[:, ankles].max() > 5 * moved[:, hips_knees].max()  # the lean is caught at the ankles


def test_a_replay_of_a_young_run_reproduces_it():
    """The recorded torques are what the joints got (delayed, lagged, rate-limited): replayed open
    loop, MuJoCo retraces the run exactly (the replay does not filter them again)."""
    from biped.sim.push import replay_torques

    run = _run(Scenario(duration_s=0.3, neuromotor="young"))
    again = replay_torques(run)
    assert np.array_equal(run.qpos, again.qpos)


def test_a_sweep_file_of_before_the_nervous_system_is_the_same_experiment():
    """A block sweep written without the neuromotor keys (main's) is extended, not refused, while
    the keys sit at W's ideal values; a young sweep is another experiment."""
    from biped.sim.sweep import SweepSpec
    from biped.sim.sweep.store import spec_difference

    spec = SweepSpec(axes={"speed_m_s": (2.0,), "direction_deg": (0.0,)})
    old = spec.to_dict()
    for k in ("neuromotor", "feedback_delay_s", "torque_rate_limit_n_m_s", "activation_time_s", "ankle_only"):
        old["scenario"].pop(k)
    assert spec_difference(old, spec.model_sha256, spec) is None
    young = SweepSpec(axes={"speed_m_s": (2.0,), "direction_deg": (0.0,)}, base=Scenario(neuromotor="young"))
    assert "neuromotor" in (spec_difference(old, spec.model_sha256, young) or "")
