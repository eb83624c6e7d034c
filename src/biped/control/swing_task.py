"""The swing leg of a capture-point step on a leg whose hinges are in any order (a robot's): the
foot's full pose by task-space computed torque on the leg's 6 joints.

W's swing law (:func:`biped.control.swing.swing_leg_torques`) finds the hip rotation and the two
ankle hinges by their place in W's leg (abduction, flexion, rotation, knee, inversion,
dorsiflexion). Robots order their hinges otherwise (G1, T1: hip pitch, roll, yaw; Berkeley
Humanoid: hip yaw first; Apollo's ankle: inversion before plantarflexion), so here the foot's
position and orientation are one 6-dof task:

    qdd = J^T (J J^T + lambda I)^-1 [a_d + Kp e_p + Kv (v_d - v);  Kp_R e_R - Kv_R w]
    tau = M_ll qdd + b_l - p_l

J the (6, 6) Jacobian of the foot body's origin and rotation on the leg's joints (MuJoCo
``mj_jacBody``), e_R the rotation vector of ``R_d R^T`` (R_d the foot's standing orientation:
flat, the standing yaw), M_ll the leg block of MuJoCo's mass matrix (the joints' armature in it),
b_l the leg's bias forces, p_l its passive forces; the base's acceleration and J' q' are
neglected, as in W's law; damped least squares near the knee singularity (lambda 1e-4, W's).
The gains are the stepping parameters' (kp_pos, kv_pos, kp_rot, kv_rot).
"""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["rotation_vector", "swing_pose_torques"]


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """The rotation vector (3,) [rad] of the rotation matrix ``R`` (axis times angle)."""
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).reshape(-1))
    if q[0] < 0:
        q = -q
    s = float(np.linalg.norm(q[1:]))
    if s < 1e-12:
        return 2.0 * q[1:]
    return 2.0 * np.arctan2(s, q[0]) * q[1:] / s


def swing_pose_torques(ctl, i, pd, vd, ad):
    """Swing-leg torques (6,) [N m] of :class:`~biped.control.stepping.SteppingController` ``ctl``
    (its model and data at the current state, its body's leg indices and the foot's standing
    orientation) for foot ``i``: the foot body's origin follows (pd, vd, ad) and its orientation
    the standing one (the module's law)."""
    m, d, s = ctl.model, ctl.data, ctl.stepping
    b = ctl._foot[i]
    dofs = ctl._leg_dofs[i]
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    mujoco.mj_jacBody(m, d, jp, jr, b)
    J = np.vstack([jp[:, dofs], jr[:, dofs]])
    v, w = jp @ d.qvel, jr @ d.qvel  # the foot's velocity in the world, the base's motion in it
    R = d.xmat[b].reshape(3, 3)
    e_r = rotation_vector(ctl._foot_rot[i] @ R.T)
    a = np.concatenate(
        [
            ad + s.kp_pos * (pd - d.xpos[b]) + s.kv_pos * (vd - v),
            s.kp_rot * e_r - s.kv_rot * w,
        ]
    )
    qdd = J.T @ np.linalg.solve(J @ J.T + 1e-4 * np.eye(6), a)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    tau = M[np.ix_(dofs, dofs)] @ qdd + d.qfrc_bias[dofs] - d.qfrc_passive[dofs]
    return np.clip(tau, -s.swing_torque_max_n_m, s.swing_torque_max_n_m)
