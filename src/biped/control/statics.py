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


@njit(cache=True)
def sole_torque_map(g, H, leg, beyond, feet, soles, T):
    """The torque map ``T`` (n_joints, 12) of the QP's torque-limit rows, ``tau = T x`` for the
    feet's wrenches ``x = [w_l; w_r]`` (each in its sole frame at the sole centre): W Alg. 6 of the
    legs' shares ``F~_f = Ad^T_{g_{sole_f,1}} w_f`` in closed form. Alg. 6 gives
    ``tau_k = -H_k^T Ad^T_{g_{1,k}} F~`` (the chain of its ``F_k = -Ad^T_{g_{k.i,k.o}} F~_k``), so
    ``tau_k = -(Ad_{g_{sole,k}} H_k)^T w_f``: minus the joint's twist in the sole frame, the column
    of the sole's body Jacobian relative to the central body (one 6-vector per joint from the
    kernel's world poses ``g`` instead of six Alg. 6 passes). ``soles[f] = g_{foot,sole}``; joints
    off the legs or beyond a foot get zero rows."""
    nj = T.shape[0]
    for j in range(nj):
        for i in range(12):
            T[j, i] = 0.0
    for f in range(2):
        gf, gfs = g[feet[f]], soles[f]
        # the sole's world pose (Rs, ps) = g_{0,foot} g_{foot,sole}
        r00 = gf[0, 0] * gfs[0, 0] + gf[0, 1] * gfs[1, 0] + gf[0, 2] * gfs[2, 0]
        r01 = gf[0, 0] * gfs[0, 1] + gf[0, 1] * gfs[1, 1] + gf[0, 2] * gfs[2, 1]
        r02 = gf[0, 0] * gfs[0, 2] + gf[0, 1] * gfs[1, 2] + gf[0, 2] * gfs[2, 2]
        r10 = gf[1, 0] * gfs[0, 0] + gf[1, 1] * gfs[1, 0] + gf[1, 2] * gfs[2, 0]
        r11 = gf[1, 0] * gfs[0, 1] + gf[1, 1] * gfs[1, 1] + gf[1, 2] * gfs[2, 1]
        r12 = gf[1, 0] * gfs[0, 2] + gf[1, 1] * gfs[1, 2] + gf[1, 2] * gfs[2, 2]
        r20 = gf[2, 0] * gfs[0, 0] + gf[2, 1] * gfs[1, 0] + gf[2, 2] * gfs[2, 0]
        r21 = gf[2, 0] * gfs[0, 1] + gf[2, 1] * gfs[1, 1] + gf[2, 2] * gfs[2, 1]
        r22 = gf[2, 0] * gfs[0, 2] + gf[2, 1] * gfs[1, 2] + gf[2, 2] * gfs[2, 2]
        p0 = gf[0, 3] + gf[0, 0] * gfs[0, 3] + gf[0, 1] * gfs[1, 3] + gf[0, 2] * gfs[2, 3]
        p1 = gf[1, 3] + gf[1, 0] * gfs[0, 3] + gf[1, 1] * gfs[1, 3] + gf[1, 2] * gfs[2, 3]
        p2 = gf[2, 3] + gf[2, 0] * gfs[0, 3] + gf[2, 1] * gfs[1, 3] + gf[2, 2] * gfs[2, 3]
        o = 6 * f
        for k in range(1, leg.shape[0]):
            if leg[k] != f or beyond[k]:
                continue
            R, h = g[k], H[k]
            # the joint's twist in the world at the sole's origin: w = R h_w, v = R h_v + (p_k - ps) x w
            w0 = R[0, 0] * h[3] + R[0, 1] * h[4] + R[0, 2] * h[5]
            w1 = R[1, 0] * h[3] + R[1, 1] * h[4] + R[1, 2] * h[5]
            w2 = R[2, 0] * h[3] + R[2, 1] * h[4] + R[2, 2] * h[5]
            d0, d1, d2 = R[0, 3] - p0, R[1, 3] - p1, R[2, 3] - p2
            v0 = R[0, 0] * h[0] + R[0, 1] * h[1] + R[0, 2] * h[2] + d1 * w2 - d2 * w1
            v1 = R[1, 0] * h[0] + R[1, 1] * h[1] + R[1, 2] * h[2] + d2 * w0 - d0 * w2
            v2 = R[2, 0] * h[0] + R[2, 1] * h[1] + R[2, 2] * h[2] + d0 * w1 - d1 * w0
            row = T[k - 1]  # minus the twist in the sole frame: Rs^T v, Rs^T w
            row[o + 0] = -(r00 * v0 + r10 * v1 + r20 * v2)
            row[o + 1] = -(r01 * v0 + r11 * v1 + r21 * v2)
            row[o + 2] = -(r02 * v0 + r12 * v1 + r22 * v2)
            row[o + 3] = -(r00 * w0 + r10 * w1 + r20 * w2)
            row[o + 4] = -(r01 * w0 + r11 * w1 + r21 * w2)
            row[o + 5] = -(r02 * w0 + r12 * w1 + r22 * w2)
