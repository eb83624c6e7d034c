"""The compiled double support of the stepping controller (biped.control.step_trigger) against
the Python controller it stands in for: driven with the same random states (the feet on and off
the floor, around the polygon's 2 cm and the QP's 10 cm heights, the capture point in and out of
the support polygon), every period the compiled code lets run must leave the Python controller's
state (capture point, rate, trigger count and armed flag, dwell start, settled) bit for bit, pass
W's controller the same contact flags, and not be one where Python starts a step or settles."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from biped.control import step_trigger as st
from biped.sim import Scenario, build_scene
from biped.sim.push import controller_policy


def _recording(policy):
    """Wrap the double-support controllers' ``torques`` to record (controller, flags)."""
    seen = []
    for name in ("_ctrl_before", "ctrl", "_ctrl_settle"):
        ctrl = getattr(policy, name)
        if "torques" in ctrl.__dict__:
            continue
        real = ctrl.torques

        def torques(q, v, target=None, gains=None, feet_in_contact=None, ctrl=ctrl, real=real):
            seen.append((ctrl, None if feet_in_contact is None else tuple(bool(f) for f in feet_in_contact)))
            return real(q, v, target=target, gains=gains, feet_in_contact=feet_in_contact)

        ctrl.torques = torques
    return seen


def _state(policy):
    s = np.zeros(st.NS)
    st.load(policy, s)
    return s


CASES = [
    ({"step_trigger": "capture", "distribution": "qp"}, 0),
    ({"step_trigger": "capture", "distribution": "qp"}, 1),
    ({"step_trigger": "capture", "distribution": "statics"}, 0),
    ({"step_trigger": "capture", "support": "sensed"}, 1),
    ({"step_trigger": "qp", "distribution": "qp"}, 0),
    ({"step_trigger": "qp", "distribution": "qp"}, 1),
]


@pytest.mark.parametrize(("keys", "steps"), CASES)
def test_compiled_double_support_is_the_python_one(keys, steps):
    sc = Scenario(stepping=True, physics="fast", **keys)
    scene = build_scene(sc)
    policy = controller_policy(sc, scene)
    m = policy.model
    d = mujoco.MjData(m)  # the compiled side's forward pass (as biped.sim.fused_step's)
    rng = np.random.default_rng(len(keys) * 7 + steps)
    q0 = m.key_qpos[m.key("wendlandt_initial").id].copy()
    seen = _recording(policy)
    d.qpos[:] = q0
    mujoco.mj_kinematics(m, d)
    z0 = d.xpos[policy._foot[0], 2] + (d.xmat[policy._foot[0]].reshape(3, 3) @ policy._sole[0][0])[2]
    period = 1.0 / sc.control_rate_hz
    prm, ints = np.zeros(st.NQ), np.zeros(st.NI, dtype=np.int64)
    contact = np.zeros(2, dtype=np.int64)
    counts = {"go": 0, "back": 0, "fired": 0, "flags": set()}
    for run in range(16):
        policy.reset()
        if steps:  # after a touchdown before the run: W's controller over the feet, the settling rule
            policy.steps = [{"foot": "left"}]
            policy._last_td = -0.12 if run % 2 else -0.2
        q, v = q0.copy(), np.zeros(m.nv)
        lift = rng.uniform(-0.005, 0.13)  # both soles this high (around 2 and 10 cm)
        drift = rng.normal(0.0, 1.0, 2) * (0.15, 0.02, 0.6, 0.15)[run % 4]  # horizontal velocity
        for k in range(80):
            t = k * period
            q[2] = q0[2] + lift + rng.normal(0.0, 0.004)
            v[:2] = drift + rng.normal(0.0, 0.05, 2)
            if k < 3 and run % 3 == 0:  # near the polygon's 2 cm line or the QP's 10 cm
                q[2] = q0[2] - z0 + (st.POLYGON_Z_M if run % 2 else 0.1) + rng.normal(0.0, 1e-10)
            q[:2] = q0[:2] + 0.02 * k * drift * period * 5
            v[2:] = rng.normal(0.0, 0.05, m.nv - 2)
            p_on = 0.7 if run % 4 == 3 else 0.97
            feet = (bool(rng.random() < p_on), bool(rng.random() < p_on))
            before = _state(policy)
            st.params(policy, prm, ints, period)
            d.qpos[:], d.qvel[:] = q, v
            for f in (mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_comVel, mujoco.mj_subtreeVel):
                f(m, d)
            pend = np.zeros(st.NS)
            code = st.double_support(
                t, feet[0], feet[1], d.subtree_com[0], d.subtree_linvel[0], d.xpos, d.xmat, before, pend,
                prm, ints, contact,
            )  # fmt: skip
            ctrl = st.double_support_controller(policy)
            seen.clear()
            policy(t, q, v, feet)
            if policy.phase != "double":
                counts["fired"] += 1
                assert code == st.HAND_BACK
                break
            if code == st.HAND_BACK:
                counts["back"] += 1
                continue
            counts["go"] += 1
            after = _state(policy)
            assert np.array_equal(after, pend, equal_nan=True), (k, after, pend)
            assert not after[st.S_SETTLED] or before[st.S_SETTLED]  # settling is Python's
            ((c, flags),) = seen
            assert c is ctrl
            want = (True, True) if flags is None else flags
            assert tuple(bool(x) for x in contact) == want
            counts["flags"].add(want)
    assert counts["go"] > 500 and counts["fired"] >= 2 and counts["back"] < counts["go"] / 5, counts
    assert len(counts["flags"]) >= 2 or keys.get("distribution") == "statics", counts
