"""``SteppingConfig.rest_damping_compensation`` (issue #23, coming to rest after a step): after a
step, once settled, each joint's torque adds the hinge damping W's controller does not model.
Checked against MuJoCo's own passive force (``qfrc_passive``) at a random joint velocity: the
added torques cancel it dof by dof, and nothing is added before the first step or the settling."""

from __future__ import annotations

import mujoco
import numpy as np


def _controller(**params):
    from biped.control.policy import PolicyConfig
    from biped.control.stepping import SteppingController
    from biped.control.stepping_config import SteppingConfig

    return SteppingController(PolicyConfig(distribution="qp"), SteppingConfig.for_trigger("qp", **params))


def test_the_added_torques_cancel_mujocos_passive_damping_after_a_step():
    on, off = _controller(rest_damping_compensation=True), _controller()
    m, d = on.model, on.data
    assert float(np.max(m.dof_damping[6:])) > 0  # the MJCF's hinges are damped (1.0 N m s/rad)
    mujoco.mj_resetData(m, d)
    q = d.qpos.copy()
    v = np.random.default_rng(3).normal(0.0, 0.5, m.nv)
    v[:6] = 0.0
    feet = (True, True)
    # before any step: the controller's torques exactly
    np.testing.assert_array_equal(on(0.0, q, v, feet), off(0.0, q, v, feet))
    for ctl in (on, off):  # a (recorded) step, not yet settled: still the controller's torques
        ctl.steps.append({"foot": "right", "closing": None})
        ctl._last_td = 0.4  # 0.1 s ago: before settle_after_s (0.3 s)
    np.testing.assert_array_equal(on(0.5, q, v, feet), off(0.5, q, v, feet))
    # settled after it: the difference is MuJoCo's passive force, negated
    for ctl in (on, off):
        ctl._settled = True
    diff = on(0.5, q, v, feet) - off(0.5, q, v, feet)
    d.qpos[:], d.qvel[:] = q, v
    mujoco.mj_forward(m, d)
    dofs = [m.jnt_dofadr[m.joint(n).id] for n in on.joint_names]
    np.testing.assert_allclose(diff, -d.qfrc_passive[dofs], rtol=1e-9, atol=1e-12)
    assert np.abs(diff).max() > 0.1


def test_rest_damping_joints_compensates_only_the_named_hinges():
    """``rest_damping_joints=("hip_rotation",)``: MuJoCo's passive force cancelled on the two hip
    rotation hinges, nothing added on the other ten."""
    on = _controller(rest_damping_compensation=True, rest_damping_joints=("hip_rotation",))
    off = _controller()
    m, d = on.model, on.data
    mujoco.mj_resetData(m, d)
    q = d.qpos.copy()
    v = np.random.default_rng(5).normal(0.0, 0.5, m.nv)
    v[:6] = 0.0
    for ctl in (on, off):
        ctl.steps.append({"foot": "right", "closing": None})
        ctl._settled = True
    diff = on(0.5, q, v, (True, True)) - off(0.5, q, v, (True, True))
    d.qpos[:], d.qvel[:] = q, v
    mujoco.mj_forward(m, d)
    dofs = [m.jnt_dofadr[m.joint(n).id] for n in on.joint_names]
    hip = np.array([n.endswith("hip_rotation") for n in on.joint_names])
    assert hip.sum() == 2
    np.testing.assert_allclose(diff[hip], -d.qfrc_passive[dofs][hip], rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(diff[~hip], 0.0)
    assert np.abs(diff[hip]).max() > 0.05
