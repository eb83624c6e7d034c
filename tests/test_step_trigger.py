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


def _sole_centres(m, d) -> np.ndarray:
    """Each foot's sole centre (world, (2, 3)): the centre of the rectangle bounding its box geoms'
    bottom faces in the foot body's frame (docs/controller.md's sole), from MuJoCo's model and
    ``d``'s poses."""
    out = []
    for side in ("left", "right"):
        b = m.body(f"{side}_foot").id
        boxes = [
            g for g in range(m.ngeom) if m.geom_bodyid[g] == b and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
        ]
        lo = np.min([m.geom_pos[g][:2] - m.geom_size[g][:2] for g in boxes], axis=0)
        hi = np.max([m.geom_pos[g][:2] + m.geom_size[g][:2] for g in boxes], axis=0)
        z = min(m.geom_pos[g][2] - m.geom_size[g][2] for g in boxes)
        c = np.array([*(0.5 * (lo + hi)), z])
        out.append(d.xpos[b] + d.xmat[b].reshape(3, 3) @ c)
    return np.array(out)


@pytest.mark.parametrize("closing", [True, False])
def test_closing_check_is_pending_after_settling_and_starts_where_the_stance_is_not_comfortable(closing):
    """The closing step's check (``closing_step``, docs/controller.md "The closing step"): after a
    step, the settling switch (COM 8 cm/s, under ``settle_speed_m_s``) makes it pending
    (``I_CLOSE`` for the compiled double support) only with ``closing_step`` on; at 8 cm/s (over
    ``closing_speed_m_s``) the compiled period runs and nothing starts; at rest the compiled code
    hands the period back and the Python controller starts the closing step exactly where the
    feet, by MuJoCo's sole centres, are not comfortable: crossed (the right foot no longer on +y of
    the left), or their lateral distance more than 5 cm from the start's (W's 16.8 cm), or one more
    than 5 cm ahead. Random leg postures (the trigger off: ``arm_time_s``) give both outcomes."""
    from _helpers import qp_stepping

    sc = Scenario(stepping=True, physics="fast", distribution="qp", step_trigger="qp")
    policy = qp_stepping(sc, build_scene(sc), closing_step=closing)
    s = policy.stepping
    assert s.closing_speed_m_s < 0.08 < s.settle_speed_m_s and s.closing_band_m == 0.05
    m = policy.model
    d = mujoco.MjData(m)
    q0 = m.key_qpos[m.key("wendlandt_initial").id].copy()
    d.qpos[:] = q0
    mujoco.mj_kinematics(m, d)
    w0 = np.diff(_sole_centres(m, d)[:, :2], axis=0)[0]  # the right sole centre from the left one
    assert w0[1] == pytest.approx(0.168, abs=5e-4) and abs(w0[0]) < 1e-9  # W's stance (the docs)
    period = 1.0 / sc.control_rate_hz
    prm, ints = np.zeros(st.NQ), np.zeros(st.NI, dtype=np.int64)
    contact = np.zeros(2, dtype=np.int64)
    rng = np.random.default_rng(11)
    started = {True: 0, False: 0}
    crossed = 0
    for _ in range(24):
        policy.reset()
        policy(0.0, q0, np.zeros(m.nv), (True, True))  # the starting stance
        policy.steps, policy._last_td, policy.arm_time_s = [{"foot": "left"}], 0.5, np.inf
        q = q0.copy()
        for leg in (7, 13):  # each hip's abduction, flexion and rotation
            q[leg : leg + 3] += rng.uniform(-1.0, 1.0, 3) * (0.25, 0.06, 0.2)
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        w = np.diff(_sole_centres(m, d)[:, :2], axis=0)[0]
        edges = (w[1], abs(w[1]) - w0[1] - 0.05, abs(w[1]) - w0[1] + 0.05, w[0] - 0.05, w[0] + 0.05)
        if min(abs(e) for e in edges) < 1e-6:
            continue  # too close to the rule's edge to tell
        comfortable = w[1] > 0.0 and abs(abs(w[1]) - w0[1]) <= 0.05 and abs(w[0]) <= 0.05
        crossed += w[1] <= 0.0
        codes = []
        for k, speed in enumerate((0.08, 0.08, 0.0)):  # the settling switch, moving, at rest
            t = 1.0 + k * period
            v = np.zeros(m.nv)
            v[0] = speed  # the whole body translating: the COM's speed
            st.params(policy, prm, ints, period)
            assert ints[st.I_CLOSE] == (closing and k > 0)
            d.qpos[:], d.qvel[:] = q, v
            for f in (mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_comVel, mujoco.mj_subtreeVel):
                f(m, d)
            codes.append(
                st.double_support(
                    t,
                    True,
                    True,
                    d.subtree_com[0],
                    d.subtree_linvel[0],
                    d.xpos,
                    d.xmat,
                    _state(policy),
                    np.zeros(st.NS),
                    prm,
                    ints,
                    contact,
                )  # fmt: skip
            )
            policy(t, q, v, (True, True))
            if k < 2:
                assert policy.phase == "double" and not policy._closed
        assert codes[0] == st.HAND_BACK and codes[1] == st.GO  # the settling switch; over 5 cm/s
        assert codes[2] == (st.HAND_BACK if closing else st.GO)
        assert policy._closed == (closing and not comfortable), (w, w0)
        assert (policy.phase != "double") == policy._closed
        started[policy._closed] += 1
    assert started[False] >= 6 and (started[True] >= 6 if closing else started[True] == 0), started
    assert crossed >= 2  # (9 comfortable, 4 crossed of 24)
