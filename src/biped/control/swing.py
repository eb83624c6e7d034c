"""The swing leg of a capture-point step (:mod:`biped.control.stepping`): task-space computed
torque on the leg's own joints so the ankle follows the planned path and the sole stays flat."""

from __future__ import annotations

import math

import mujoco
import numpy as np

__all__ = ["swing_leg_torques", "swing_reaction_wrench"]


#: The leg joints the swing law holds by joint-space PD (hip rotation, the two ankle hinges) and
#: those that move the ankle point (hip abduction, hip flexion, knee), by their place in W's leg.
_HELD = np.array([2, 4, 5])
_TASK = np.array([0, 1, 3])


def _buffers(ctl, i):
    """(jacp (3, nv), jacr (3, nv), M (nv, nv), the leg block's index, damping 1e-4 I) for
    :func:`swing_leg_torques` of foot ``i``: made once per controller, each array written whole
    by MuJoCo at every call (the same numbers as new ones, without a period's allocations)."""
    bufs = getattr(ctl, "_swing_buffers", None)
    if bufs is None:
        nv = ctl.model.nv
        bufs = ctl._swing_buffers = [
            (np.zeros((3, nv)), np.zeros((3, nv)), np.zeros((nv, nv)), np.ix_(dofs, dofs), 1e-4 * np.eye(3))
            for dofs in ctl._leg_dofs
        ]
    return bufs[i]


def swing_leg_torques(ctl, i, pd, vd, ad):
    """Swing-leg torques of :class:`~biped.control.stepping.SteppingController` ``ctl`` (its
    model, data at the current state, leg indices and config) for foot ``i``: the ankle point
    follows (pd, vd, ad) by task-space computed torque on hip abduction, hip flexion and knee
    (3 x 3 Jacobian, MuJoCo mj_jacBody, damped least squares); hip rotation is held at 0 and the
    two ankle joints at the angles that put the sole flat with zero yaw (from the shank's world
    orientation), both by joint-space PD; torques ``M_ll qdd + b_l - p_l`` (leg block of
    MuJoCo's mass matrix, leg bias forces, minus the passive hinge damping, which the foot's
    small inertia would not overcome)."""
    m, d, s = ctl.model, ctl.data, ctl.stepping
    b = ctl._foot[i]
    dofs = ctl._leg_dofs[i]
    jp, jr, M, ix, damp = _buffers(ctl, i)
    q = d.qpos[ctl._leg_qpos[i]]
    qd = d.qvel[dofs]
    mujoco.mj_jacBody(m, d, jp, jr, b)  # (each written whole; jr is used below)
    Jl = jp[:, dofs]
    # joint-space parts: hip rotation to 0, ankle to the flat-foot angles
    R = d.xmat[ctl._shank[i]].reshape(3, 3).T  # desired foot orientation (I) in the shank frame
    inv = ctl._inv_sign[i] * math.atan2(R[2, 1], R[1, 1])
    dors = math.atan2(R[0, 2], R[0, 0])
    qdd = np.zeros(6)
    for k, qk in ((2, 0.0), (4, inv), (5, dors)):
        qdd[k] = s.kp_rot * (qk - q[k]) - s.kv_rot * qd[k]
    vl = Jl @ qd  # the leg's part of the foot's velocity (taken out and added back: as it was)
    a = ad + s.kp_pos * (pd - d.xpos[b]) + s.kv_pos * (vd - vl - jp @ d.qvel + vl)
    a = a - Jl[:, _HELD] @ qdd[_HELD]
    J3 = Jl[:, _TASK]
    qdd[_TASK] = J3.T @ np.linalg.solve(J3 @ J3.T + damp, a)
    mujoco.mj_fullM(m, d, M)  # (written whole)
    tau = M[ix] @ qdd + d.qfrc_bias[dofs] - d.qfrc_passive[dofs]
    # the ankle's tiny inertia makes M_ll qdd a few N m that unmodelled coupling (the base's
    # acceleration) swamps: a stiff joint PD on the ankle instead [N m/rad, N m s/rad]
    # (damping on the foot's own angular velocity in the world, not the joint rate: the
    # shank turns fast during the swing and the flat foot must not follow it)
    w = jr @ d.qvel
    for k, qk, wk in ((4, inv, ctl._inv_sign[i] * w[0]), (5, dors, w[1])):
        tau[k] = s.ankle_kp * (qk - q[k]) - s.ankle_kv * wk + d.qfrc_bias[dofs[k]]
    return np.clip(tau, -s.swing_torque_max_n_m, s.swing_torque_max_n_m)


def swing_reaction_wrench(ctl, i, tau_swing):
    """The driven swing leg's reaction that W's stance model misses [N, N m] (6,), a wrench on the
    central body in its COM principal frame (W's frame of ``F_1^bd``), for foot ``i`` swinging
    with joint torques ``tau_swing`` (its 6 joints, controller order = the leg's dof order).

    With a foot off the floor W Alg. 3 folds its leg into ``P_1``, ``z_1`` as a *passive*
    articulated branch (zero joint torques). Eliminating the leg's joint accelerations from
    MuJoCo's equations of motion (root rows b, leg rows s: ``M_bb a_b + M_bs qdd_s + h_b = Q_b``,
    ``M_sb a_b + M_ss qdd_s + h_s = tau_s``) gives the leg's generalized force on the root
    ``(M_bb - M_bs M_ss^-1 M_sb) a_b + h_b - M_bs M_ss^-1 h_s + M_bs M_ss^-1 tau_s``: the first
    terms are the passive branch W already has, the last one, ``M_bs M_ss^-1 tau_s``, is what the
    joint torques add (``tau_s`` the torques acting on the leg's joints: the swing torques plus
    the joints' passive damping). It is moved from the free joint's coordinates to the central
    body's COM frame by ``Q_b = J^T F`` (J: MuJoCo's COM Jacobian of the root dofs, rotated into
    the COM principal frame)."""
    m, d = ctl.model, ctl.data
    dofs = ctl._leg_dofs[i]
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    tau = np.asarray(tau_swing, dtype=float) + d.qfrc_passive[dofs]
    q_root = M[:6, dofs] @ np.linalg.solve(M[np.ix_(dofs, dofs)], tau)
    root = ctl._root
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    mujoco.mj_jacBodyCom(m, d, jp, jr, root)
    R = d.ximat[root].reshape(3, 3)
    J = np.vstack([R.T @ jp[:, :6], R.T @ jr[:, :6]])
    return np.linalg.solve(J.T, q_root)
