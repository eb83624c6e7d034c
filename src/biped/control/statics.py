"""W Alg. 5 and Alg. 6, compiled: the minimum-norm split of the desired wrench between the feet
(with the print's reading beside the corrected one) and the joint torques by the legs' Jacobian
transposes. Split out of :mod:`biped.control.recursions`, which calls them from its kernel and
re-exports them; conventions as there (twists ``[v; w]``, wrenches ``[f; tau]``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from biped.spatial import (
    adjoint_into,
    adjoint_mul,
    adjoint_T_mul,
    cholesky6_solve,
)


@njit(cache=True)
def alg5_wrench_distribution(
    g: np.ndarray,
    feet: np.ndarray,
    contact: np.ndarray,
    Fd: np.ndarray,
    vecs: np.ndarray,
    mats: np.ndarray,
    R_foot: np.ndarray,
    Fl: np.ndarray,
    Fr: np.ndarray,
    Fl_tilde: np.ndarray,
    Fr_tilde: np.ndarray,
    printed: bool = False,
) -> bool:
    """W Alg. 5 (desired wrench distribution, eq. 3.11-3.14): ``F_1^bd = G [F_l; F_r]`` with
    ``G = [Ad^T_{g_{7,1}}  Ad^T_{g_{13,1}}]`` (each foot's wrench moved to the central body),
    ``[F_l; F_r] = G^T (G G^T)^-1 F_1^bd`` (minimum norm), ``F~_2 = Ad^T_{g_{7,1}} F_l``,
    ``F~_8 = Ad^T_{g_{13,1}} F_r``. ``F_l``, ``F_r`` are the ground's wrenches on the feet in the
    feet's COM frames. W prints ``Ad^T_{g_{1,7}}``, following its eq. 3.8 whose subscripts are
    swapped with respect to its own eq. 3.6 and Alg. 6 (power balance gives
    ``F_k = Ad^T_{g_{l,k}} F_l``); taken literally, the print moves the wrench the wrong way and the
    split carries internal moments through the legs.

    Only feet with ``contact[f] != 0`` take a share (W: both): ``G`` keeps their blocks, so one
    foot in contact takes all of ``F_1^bd`` and with none no wrench is distributed (all zero).

    ``printed=True`` uses W's print literally (``g_{1,7}``, ``g_{1,13}`` in place of ``g_{7,1}``,
    ``g_{13,1}``): the shares still sum to ``F_1^bd`` but are not the feet's wrenches moved by statics.

    Scratch: ``vecs`` (>= 3, 6) holds ``y = (G G^T)^-1 F_1^bd`` and the two feet's ``p``;
    ``mats`` (>= 2, 6, 6) holds ``G G^T`` and one foot's ``Ad``; ``R_foot`` (2, 3, 3) the feet's ``R``
    (``(R_foot[f], p_foot[f]) = g_{foot,1}``, or ``g_{1,foot}`` printed).

    Returns False when ``G G^T`` (a sum of two positive-definite matrices) is not positive
    definite to working precision: non-finite poses or feet absurdly far from the body.
    """
    y, p_foot = vecs[0], vecs[1:3, :3]
    GG, Afoot = mats[0], mats[1]
    GG[:, :] = 0.0
    R0 = g[0, :3, :3]
    if contact[0] == 0 and contact[1] == 0:
        for i in range(6):
            Fl[i] = 0.0
            Fr[i] = 0.0
            Fl_tilde[i] = 0.0
            Fr_tilde[i] = 0.0
        return True
    for f in range(2):
        k = feet[f]
        R, pp = R_foot[f], p_foot[f]
        if printed:  # W's print: g_{1,foot} = g_{0,1}^-1 g_{0,foot}
            for i in range(3):
                for j in range(3):
                    R[i, j] = R0[0, i] * g[k, 0, j] + R0[1, i] * g[k, 1, j] + R0[2, i] * g[k, 2, j]
                pp[i] = (
                    R0[0, i] * (g[k, 0, 3] - g[0, 0, 3])
                    + R0[1, i] * (g[k, 1, 3] - g[0, 1, 3])
                    + R0[2, i] * (g[k, 2, 3] - g[0, 2, 3])
                )
        else:  # g_{foot,1} = g_{0,foot}^-1 g_{0,1}: R = R_f^T R_0, p = R_f^T (p_0 - p_f)
            for i in range(3):
                for j in range(3):
                    R[i, j] = g[k, 0, i] * R0[0, j] + g[k, 1, i] * R0[1, j] + g[k, 2, i] * R0[2, j]
                pp[i] = (
                    g[k, 0, i] * (g[0, 0, 3] - g[k, 0, 3])
                    + g[k, 1, i] * (g[0, 1, 3] - g[k, 1, 3])
                    + g[k, 2, i] * (g[0, 2, 3] - g[k, 2, 3])
                )
        if contact[f] == 0:
            continue
        adjoint_into(R, pp, Afoot)  # G G^T += Ad^T Ad, this foot's block of G (eq. 3.11)
        for i in range(6):
            for j in range(i, 6):
                s = 0.0
                for m in range(6):
                    s += Afoot[m, i] * Afoot[m, j]
                GG[i, j] += s
                if j != i:
                    GG[j, i] += s
    if not cholesky6_solve(GG, Fd, y):  # y = (G G^T)^-1 F_1^bd (eq. 3.12)
        return False
    # F_foot = Ad_{g_{foot,1}} y (the foot's rows of G^T y); F~ = Ad^T_{g_{foot,1}} F_foot (eq. 3.13)
    adjoint_mul(R_foot[0], p_foot[0], y, Fl)
    adjoint_T_mul(R_foot[0], p_foot[0], Fl, Fl_tilde)
    adjoint_mul(R_foot[1], p_foot[1], y, Fr)
    adjoint_T_mul(R_foot[1], p_foot[1], Fr, Fr_tilde)
    for i in range(6):
        if contact[0] == 0:
            Fl[i] = 0.0
            Fl_tilde[i] = 0.0
        if contact[1] == 0:
            Fr[i] = 0.0
            Fr_tilde[i] = 0.0
    return True


@njit(cache=True)
def alg6_torques(
    parent: np.ndarray,
    H: np.ndarray,
    leg: np.ndarray,
    beyond: np.ndarray,
    gl: np.ndarray,
    Fl_tilde: np.ndarray,
    Fr_tilde: np.ndarray,
    F: np.ndarray,
    tau: np.ndarray,
) -> None:
    """W Alg. 6 (torque calculation, outboard): ``F_k = -Ad^{-T}_{g_{k.o,k.i}} F~_k`` (equal and
    opposite wrenches across joint k), ``tau_k = H_k^T F_k``, ``F~_{k+1} = -F_k`` (link k.o in
    equilibrium). Equivalent to ``tau = J^T F~`` with J the leg's body Jacobian, foot fixed.

    ``gl[k] = g_{k.i,k.o}(theta_k)`` from Alg. 2. ``F[k]`` holds ``F_k`` in link k's frame. Joints
    off the two leg paths get zero torque.
    """
    n = parent.shape[0]
    for k in range(1, n):
        if leg[k] < 0 or beyond[k]:
            tau[k - 1] = 0.0
            continue
        p = parent[k]
        if p == 0:
            Ft = Fl_tilde if leg[k] == 0 else Fr_tilde
        else:
            Ft = F[p]
        sign = 1.0 if p == 0 else -1.0  # F~_k = -F_{k.i} inside a leg
        # F_k = -Ad^T_{g_{p,k}} F~_k  (Ad^{-T}_{g_{k,p}} = Ad^T_{g_{p,k}})
        adjoint_T_mul(gl[k, :3, :3], gl[k, :3, 3], Ft, F[k])
        s = 0.0
        for i in range(6):
            F[k, i] *= -sign
            s += H[k, i] * F[k, i]
        tau[k - 1] = s
