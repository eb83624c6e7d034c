"""The stance foot's contact wrench in single support, predicted from the whole biped's dynamics:
the stepping controller's stance model (:mod:`biped.control.stepping`, ``stance_contact_model``;
issue #23, "the swing leg in the stance model").

The single-support QP plans the wrench ``w`` the stance leg passes to the central body, moved to
the sole as if the legs were massless (:mod:`biped.control.distribution`); its friction rows hold
``w``. The floor's wrench on the stance foot is not ``w``: the driven swing leg (a foot moved
0.5-0.8 m in 0.2 s) pushes the body, whose motion the stance leg's own inertia follows, and the
legs' weight and velocity products load the foot too. With the stance foot held on the floor
(MuJoCo's equations of motion ``M qdd + h = S tau + p + J^T lam`` and the foot's 6-D constraint
``J qdd + J' q' = 0``, J the stance sole centre's Jacobian [jacp; jacr] of the controller's model)
the floor's wrench on the foot is ``lam = Lam (-J' q' - J M^-1 (S tau - h + p))``,
``Lam = (J M^-1 J^T)^-1``, an affine function of the joint torques. The stance leg's torques are
the QP's, ``tau_st = -J_st^T B w`` (W Alg. 6: the massless leg's statics; J_st the leg's columns
of J, ``B = blockdiag(R_s, R_s)`` the sole frame's axes), the swing leg's the swing law's: so

    lam_sole = K w + r,   K = B^T Lam J M^-1 S_st J_st^T B,
                          r = B^T Lam (-J' q' - J M^-1 (S_sw tau_sw - h + p)),

and :func:`set_stance_map` puts the stance foot's normal-force and friction rows on
``K w + r`` (:func:`biped.control.cones.map_contact_rows`): the QP then plans the friction the
floor really gives, the swing leg's reaction included. ``r`` carries the legs' weight too (the QP's
``leg_weight`` must be 0, the stepping QP's). tests/test_stance_dynamics.py checks the prediction
against MuJoCo's contact forces during a swing.
"""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["stance_contact_map", "set_stance_map"]


def stance_contact_map(ctl, st: int, tau_swing: np.ndarray, qp) -> tuple[np.ndarray, np.ndarray]:
    """``(K (6, 6), r (6,))`` of the stance foot ``st`` of the stepping controller ``ctl`` (its
    model and data at the current state, ``mj_forward`` done): the floor's wrench on the foot in
    the QP's sole frame at the sole centre is ``K w + r`` for the QP's wrench ``w`` of that foot
    and the swing leg's torques ``tau_swing`` (its 6 joints, the leg's dof order), the stance foot
    held on the floor (the module's docstring). ``qp``: the single support's ContactQP (its sole
    frames)."""
    m, d = ctl.model, ctl.data
    fb = ctl._foot[st]
    gfs = qp._soles[st]
    Ri = d.ximat[fb].reshape(3, 3)
    Rs = Ri @ gfs[:3, :3]  # the kernel's link frame is MuJoCo's inertial frame
    ps = d.xipos[fb] + Ri @ gfs[:3, 3]
    nv = m.nv
    jp, jr = np.zeros((3, nv)), np.zeros((3, nv))
    mujoco.mj_jac(m, d, jp, jr, ps, fb)
    J = np.vstack([jp, jr])
    mujoco.mj_jacDot(m, d, jp, jr, ps, fb)
    Jd_qd = np.concatenate([jp @ d.qvel, jr @ d.qvel])
    M = np.zeros((nv, nv))
    mujoco.mj_fullM(m, d, M)
    MiJt = np.linalg.solve(M, J.T)  # M^-1 J^T (M symmetric)
    Lam = np.linalg.inv(J @ MiJt)
    B = np.zeros((6, 6))
    B[:3, :3] = Rs
    B[3:, 3:] = Rs
    dofs_st, dofs_sw = ctl._leg_dofs[st], ctl._leg_dofs[1 - st]
    # K = B^T Lam (J M^-1)[:, st] J_st^T B, J M^-1 = (M^-1 J^T)^T
    K = B.T @ Lam @ MiJt[dofs_st].T @ J[:, dofs_st].T @ B
    gen = d.qfrc_passive - d.qfrc_bias
    gen[dofs_sw] += tau_swing
    r = B.T @ Lam @ (-Jd_qd - MiJt.T @ gen)
    return K, r


def set_stance_map(ctl, i: int, tau_swing: np.ndarray, flags) -> None:
    """Before the single support's QP call (foot ``i`` swinging, contact ``flags``): the stance
    foot's contact map on its QP, or none while the stance foot is out of the QP (airborne)."""
    qp = ctl._ctrl_swing.qp
    qp.cmap[:, 0] = 0.0  # no map (the rows hold the QP's wrenches)
    st = 1 - i
    if flags[st]:
        K, r = stance_contact_map(ctl, st, tau_swing, qp)
        qp.cmap[st, 1:37] = K.reshape(36)
        qp.cmap[st, 37:43] = r
        qp.cmap[st, 0] = float(ctl.stepping.stance_contact_rows)  # which rows (cones.map_contact_rows)
