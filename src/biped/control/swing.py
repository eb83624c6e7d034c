"""The swing leg of a capture-point step (:mod:`biped.control.stepping`): task-space computed
torque on the leg's own joints so the ankle follows the planned path and the sole stays flat."""

from __future__ import annotations

import mujoco
import numpy as np

from biped.control.swing_kernel import SwingLaw

__all__ = ["swing_leg_torques", "swing_reaction_wrench"]


def swing_leg_torques(ctl, i, pd, vd, ad):
    """Swing-leg torques of :class:`~biped.control.stepping.SteppingController` ``ctl`` (its
    model, data at the current state, leg indices and config) for foot ``i``: the ankle point
    follows (pd, vd, ad) by task-space computed torque on hip abduction, hip flexion and knee
    (3 x 3 Jacobian, MuJoCo mj_jacBody, damped least squares); hip rotation is held at 0 and the
    two ankle joints at the angles that put the sole flat with zero yaw (from the shank's world
    orientation), both by joint-space PD; torques ``M_ll qdd + b_l - p_l`` (leg block of
    MuJoCo's mass matrix, leg bias forces, minus the passive hinge damping, which the foot's
    small inertia would not overcome). The ankle's tiny inertia makes ``M_ll qdd`` a few N m
    that unmodelled coupling (the base's acceleration) swamps: a stiff joint PD on the ankle
    instead, damping the foot's own angular velocity in the world, not the joint rate (the shank
    turns fast during the swing and the flat foot must not follow it). One compiled call
    (:class:`biped.control.swing_kernel.SwingLaw`, made once per controller), the same in the
    Python loop and the compiled one."""
    law = getattr(ctl, "_swing_law", None)
    if law is None:
        law = ctl._swing_law = SwingLaw(ctl)
    return law(i, pd, vd, ad)


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
