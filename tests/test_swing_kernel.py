"""W's swing law compiled (:mod:`biped.control.swing_kernel`) against references the project did
not compute: MuJoCo's inverse dynamics (``mj_inverse``: ``M qacc + b - p`` of the leg, constraints
off) for the torques and finite differences of MuJoCo's forward kinematics for the foot's
Jacobian, velocity and angular velocity, at every swing period of a stepping trial's swing; and
the old NumPy law (kept verbatim in ``tests/test_swing_period_cost.py``) to rounding."""

from __future__ import annotations

import math

import mujoco
import numpy as np
from test_sim_fused_step import _sweep_scenario
from test_swing_period_cost import reference_swing_leg_torques

from biped.control.stepping_swing import SwingPhase
from biped.control.swing import swing_leg_torques
from biped.sim import build_scene
from biped.sim.push import controller_policy, run_closed_loop

EPS = 1e-6


def _foot(m, d, qpos, b):
    """(foot body origin (3,), its rotation (3, 3)) at ``qpos`` (MuJoCo's forward kinematics)."""
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    return d.xpos[b].copy(), d.xmat[b].reshape(3, 3).copy()


def _moved(m, qpos, dv):
    """``qpos`` moved by the velocity ``dv`` for unit time (mj_integratePos: the free joint's
    quaternion on its manifold)."""
    q = qpos.copy()
    mujoco.mj_integratePos(m, q, dv, 1.0)
    return q


def reference_torques(ctl, i, pd, vd, ad):
    """The swing law from its definition (the module docstring of biped.control.swing_kernel), its
    kinematics by central differences of MuJoCo's forward kinematics and its dynamics by
    ``mj_inverse``, on a copy of the controller's data."""
    m, s = ctl.model, ctl.stepping
    d = mujoco.MjData(m)
    qpos, qvel = ctl.data.qpos.copy(), ctl.data.qvel.copy()
    b, dofs = ctl._foot[i], ctl._leg_dofs[i]
    p0, _ = _foot(m, d, qpos, b)
    J = np.zeros((3, 6))
    for k, dof in enumerate(dofs):
        e = np.zeros(m.nv)
        e[dof] = EPS
        J[:, k] = (_foot(m, d, _moved(m, qpos, e), b)[0] - _foot(m, d, _moved(m, qpos, -e), b)[0]) / (2 * EPS)
    pa, Ra = _foot(m, d, _moved(m, qpos, EPS * qvel), b)
    pb, Rb = _foot(m, d, _moved(m, qpos, -EPS * qvel), b)
    v = (pa - pb) / (2 * EPS)
    W = (Ra - Rb) / (2 * EPS) @ _foot(m, d, qpos, b)[1].T  # R' R^T = [w]x
    w = np.array([W[2, 1], W[0, 2], W[1, 0]])
    # the flat foot's ankle angles (the law's definition, from the shank's world orientation)
    R = d.xmat[ctl._shank[i]].reshape(3, 3).T
    inv = ctl._inv_sign[i] * math.atan2(R[2, 1], R[1, 1])
    dors = math.atan2(R[0, 2], R[0, 0])
    q = qpos[ctl._leg_qpos[i]]
    qd = qvel[dofs]
    qdd = np.zeros(6)
    for k, qk in ((2, 0.0), (4, inv), (5, dors)):
        qdd[k] = s.kp_rot * (qk - q[k]) - s.kv_rot * qd[k]
    a = ad + s.kp_pos * (pd - p0) + s.kv_pos * (vd - v) - J[:, [2, 4, 5]] @ qdd[[2, 4, 5]]
    J3 = J[:, [0, 1, 3]]
    qdd[[0, 1, 3]] = J3.T @ np.linalg.solve(J3 @ J3.T + 1e-4 * np.eye(3), a)
    # M qacc + bias - passive on the leg's rows (qacc zero elsewhere), by MuJoCo's inverse dynamics
    d.qpos[:], d.qvel[:] = qpos, qvel
    d.qacc[:] = 0.0
    d.qacc[dofs] = qdd
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    try:
        mujoco.mj_inverse(m, d)
    finally:
        m.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    tau = d.qfrc_inverse[dofs].copy()
    d.qacc[:] = 0.0
    bias = np.zeros(m.nv)
    mujoco.mj_rne(m, d, 0, bias)  # gravity and Coriolis alone
    tau[4] = s.ankle_kp * (inv - q[4]) - s.ankle_kv * ctl._inv_sign[i] * w[0] + bias[dofs[4]]
    tau[5] = s.ankle_kp * (dors - q[5]) - s.ankle_kv * w[1] + bias[dofs[5]]
    return np.clip(tau, -s.swing_torque_max_n_m, s.swing_torque_max_n_m)


def test_swing_law_against_mujoco_inverse_dynamics(monkeypatch):
    """Every swing period of a sideways step (14 m/s from the side, the sweep's stepping trial):
    the compiled law's torques equal its definition with MuJoCo's inverse dynamics and
    finite-difference kinematics to 1e-5 N m + 1e-6 relative (central differences, step 1e-6),
    and the old NumPy law to rounding (1e-12 relative)."""
    seen = []
    real = SwingPhase._swing_torques

    def torques(self, i, pd, vd, ad):
        assert self.body.swing is swing_leg_torques
        new = real(self, i, pd, vd, ad)
        ref = reference_torques(self, i, pd, vd, ad)
        old = reference_swing_leg_torques(self, i, pd, vd, ad)
        np.testing.assert_allclose(new, ref, rtol=1e-6, atol=1e-5)
        np.testing.assert_allclose(new, old, rtol=1e-12, atol=1e-12 * np.max(np.abs(old)))
        seen.append(float(np.max(np.abs(new))))
        return new

    monkeypatch.setattr(SwingPhase, "_swing_torques", torques)
    sc = _sweep_scenario(14, 90, "qp", duration_s=1.2)
    scene = build_scene(sc)
    r = run_closed_loop(sc, scene, controller_policy(sc, scene), compiled=False)
    assert r.extra["steps"], "the push must step"
    assert len(seen) >= 40 and max(seen) > 5.0, (len(seen), max(seen))


def test_reference_sees_a_wrong_law(monkeypatch):
    """The reference is not blind: the law with its knee torque off by 1 % fails it."""
    sc = _sweep_scenario(14, 90, "qp", duration_s=0.8)
    scene = build_scene(sc)
    found = []

    def torques(self, i, pd, vd, ad):
        new = swing_leg_torques(self, i, pd, vd, ad)
        if not found and abs(new[3]) > 1.0:
            bad = new.copy()
            bad[3] *= 1.01
            found.append(np.allclose(bad, reference_torques(self, i, pd, vd, ad), rtol=1e-6, atol=1e-5))
        return new

    monkeypatch.setattr(SwingPhase, "_swing_torques", torques)
    run_closed_loop(sc, scene, controller_policy(sc, scene), compiled=False)
    assert found == [False]
