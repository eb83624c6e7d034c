"""Wendlandt's recursive workspace balancing controller (W, Alg. 1-6), compiled with numba.

One call of :func:`compute_kernel` runs Alg. 1 to Alg. 6 on preallocated buffers and allocates
nothing. Conventions (W section 3.1, Murray-Li-Sastry): twists ``[v; w]``, wrenches ``[f; tau]``,
``Ad_g = [[R, p^ R], [0, R]]``; link frames are the links' COM principal-axis frames (MuJoCo's
inertial frames). Every 6-vector of link ``k`` is expressed in link ``k``'s frame; the outputs
(P1, z1, F_1^bd, F~_2^bd, F~_8^bd) are in the central body's frame, SI units.

Where the transcribed paper is ambiguous the code follows the derivation, as SEED-NOTES records:
- Alg. 2: ``a_k = ad_{V_{k.o}} H_k thetadot_k`` (the velocity-product acceleration, Featherstone's
  ``c_k``; the print's ``A V_{k.i}`` has units of velocity). ``H_k`` is constant in link k.o.
- Alg. 3: the inboard quantities accumulate, ``P_{k.i} += L^T P_{k.o} L``,
  ``z_{k.i} += L^T (P_{k.o} a_k + z_{k.o})`` (link 1 receives both legs).
- Alg. 4: ``X_c^b = R^T (X_c^s - w^s x pdot^s)`` (the print has ``p`` for ``pdot``: the body-frame
  derivative of ``v^b = R^T pdot`` is ``R^T (pddot - w^s x pdot)``).
- eq. 3.9: ``Omega = blockdiag(w^, w^)``, the hat of the body angular velocity.
- Alg. 5: ``G = [Ad^T_{g_{7,1}}  Ad^T_{g_{13,1}}]`` moves each foot's wrench to the central body
  (the print's ``Ad^T_{g_{1,7}}`` follows W eq. 3.8, whose subscripts are swapped with respect to
  W eq. 3.6 and Alg. 6; see :func:`alg5_wrench_distribution`).

Buffers are flat float64 arrays whose layout :func:`layout` defines; ``biped.control`` wraps them.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from biped.spatial import adjoint_into, quat_mul_into, quat_to_rot_into

# status codes returned by compute_kernel
OK = 0
NONFINITE_STATE = 1
NONFINITE_RESULT = 2
SINGULAR_DISTRIBUTION = 3
ZERO_QUATERNION = 4

# mi[3], the distribution mode: 0 W Alg. 5 (statics), 1 W's printed Alg. 5, 2 stop after Alg. 4
STOP_AFTER_ALG4 = 2


def layout(n: int) -> dict[str, tuple[int, tuple[int, ...]]]:
    """Offsets and shapes of the model, work and output buffers for ``n`` links."""
    def pack(fields):
        out, off = {}, 0
        for name, shape in fields:
            out[name] = (off, shape)
            off += int(np.prod(shape))
        out["_size"] = (off, ())
        return out

    return {
        "model": pack([("H", (n, 6)), ("G0", (n, 4, 4)), ("mass", (n,)), ("inertia", (n, 3)),
                       ("qref", (n,)), ("gravity", (3,)), ("root_qbi", (4,)), ("big_base", (1,))]),
        "work": pack([("g", (n, 4, 4)), ("gl", (n, 4, 4)), ("V", (n, 6)), ("a", (n, 6)),
                      ("b", (n, 6)), ("P", (n, 6, 6)), ("z", (n, 6)), ("F", (n, 6)),
                      ("tmp6", (4, 6)), ("tmp66", (3, 6, 6)), ("quat", (3, 4)), ("R3", (2, 3, 3))]),
        "out": pack([("tau", (n - 1,)), ("P1", (6, 6)), ("z1", (6,)), ("Fd", (6,)), ("Fl_tilde", (6,)),
                     ("Fr_tilde", (6,)), ("Fl", (6,)), ("Fr", (6,)), ("X", (6,)), ("qe", (4,))]),
    }


# ----------------------------------------------------------------------------- small helpers


@njit(cache=True, inline="always")
def _ad_mul(R, p, x, out):
    """out = Ad_(R,p) x = [R xv + p x (R xw); R xw]."""
    w0 = R[0, 0] * x[3] + R[0, 1] * x[4] + R[0, 2] * x[5]
    w1 = R[1, 0] * x[3] + R[1, 1] * x[4] + R[1, 2] * x[5]
    w2 = R[2, 0] * x[3] + R[2, 1] * x[4] + R[2, 2] * x[5]
    v0 = R[0, 0] * x[0] + R[0, 1] * x[1] + R[0, 2] * x[2]
    v1 = R[1, 0] * x[0] + R[1, 1] * x[1] + R[1, 2] * x[2]
    v2 = R[2, 0] * x[0] + R[2, 1] * x[1] + R[2, 2] * x[2]
    out[0] = v0 + p[1] * w2 - p[2] * w1
    out[1] = v1 + p[2] * w0 - p[0] * w2
    out[2] = v2 + p[0] * w1 - p[1] * w0
    out[3] = w0
    out[4] = w1
    out[5] = w2


@njit(cache=True, inline="always")
def _adT_mul(R, p, F, out):
    """out = Ad_(R,p)^T F = [R^T f; R^T (tau - p x f)] (W eq. 3.8)."""
    t0 = F[3] - (p[1] * F[2] - p[2] * F[1])
    t1 = F[4] - (p[2] * F[0] - p[0] * F[2])
    t2 = F[5] - (p[0] * F[1] - p[1] * F[0])
    f0, f1, f2 = F[0], F[1], F[2]
    out[0] = R[0, 0] * f0 + R[1, 0] * f1 + R[2, 0] * f2
    out[1] = R[0, 1] * f0 + R[1, 1] * f1 + R[2, 1] * f2
    out[2] = R[0, 2] * f0 + R[1, 2] * f1 + R[2, 2] * f2
    out[3] = R[0, 0] * t0 + R[1, 0] * t1 + R[2, 0] * t2
    out[4] = R[0, 1] * t0 + R[1, 1] * t1 + R[2, 1] * t2
    out[5] = R[0, 2] * t0 + R[1, 2] * t1 + R[2, 2] * t2


@njit(cache=True)
def _bias(m, I, R0k, gvec, V, b):
    """b = -F^be + Omega M V: gravity and gyroscopic wrench of one link (W Alg. 1, eq. 3.9)."""
    v0, v1, v2, w0, w1, w2 = V[0], V[1], V[2], V[3], V[4], V[5]
    # gravity in the link frame: R^T g m
    for i in range(3):
        b[i] = -m * (R0k[0, i] * gvec[0] + R0k[1, i] * gvec[1] + R0k[2, i] * gvec[2])
    b[0] += m * (w1 * v2 - w2 * v1)
    b[1] += m * (w2 * v0 - w0 * v2)
    b[2] += m * (w0 * v1 - w1 * v0)
    h0, h1, h2 = I[0] * w0, I[1] * w1, I[2] * w2
    b[3] = w1 * h2 - w2 * h1
    b[4] = w2 * h0 - w0 * h2
    b[5] = w0 * h1 - w1 * h0


@njit(cache=True)
def _revolute_exp(H, theta, g):
    """g = exp(H^ theta) for a unit-axis twist H = [v; w] (Murray-Li-Sastry eq. 2.36)."""
    w0, w1, w2 = H[3], H[4], H[5]
    s, c = np.sin(theta), np.cos(theta)
    C = 1.0 - c
    R = g[:3, :3]
    R[0, 0] = c + w0 * w0 * C
    R[0, 1] = w0 * w1 * C - w2 * s
    R[0, 2] = w0 * w2 * C + w1 * s
    R[1, 0] = w1 * w0 * C + w2 * s
    R[1, 1] = c + w1 * w1 * C
    R[1, 2] = w1 * w2 * C - w0 * s
    R[2, 0] = w2 * w0 * C - w1 * s
    R[2, 1] = w2 * w1 * C + w0 * s
    R[2, 2] = c + w2 * w2 * C
    # p = (I - R)(w x v) + w w^T v theta
    x0 = w1 * H[2] - w2 * H[1]
    x1 = w2 * H[0] - w0 * H[2]
    x2 = w0 * H[1] - w1 * H[0]
    wv = w0 * H[0] + w1 * H[1] + w2 * H[2]
    for i in range(3):
        g[i, 3] = (x0 if i == 0 else (x1 if i == 1 else x2)) - (R[i, 0] * x0 + R[i, 1] * x1 + R[i, 2] * x2) \
            + H[3 + i] * wv * theta
        g[3, i] = 0.0
    g[3, 3] = 1.0


@njit(cache=True)
def _mat4_mul(A, B, C):
    """C = A B for 4x4 rigid transforms (C must not alias A or B). Operands are read into locals
    first: the compiler cannot prove that C does not alias them."""
    b00, b01, b02, b03 = B[0, 0], B[0, 1], B[0, 2], B[0, 3]
    b10, b11, b12, b13 = B[1, 0], B[1, 1], B[1, 2], B[1, 3]
    b20, b21, b22, b23 = B[2, 0], B[2, 1], B[2, 2], B[2, 3]
    for i in range(3):
        a0, a1, a2, a3 = A[i, 0], A[i, 1], A[i, 2], A[i, 3]
        C[i, 0] = a0 * b00 + a1 * b10 + a2 * b20
        C[i, 1] = a0 * b01 + a1 * b11 + a2 * b21
        C[i, 2] = a0 * b02 + a1 * b12 + a2 * b22
        C[i, 3] = a0 * b03 + a1 * b13 + a2 * b23 + a3
    C[3, 0] = 0.0
    C[3, 1] = 0.0
    C[3, 2] = 0.0
    C[3, 3] = 1.0


# ----------------------------------------------------------------------------- W Alg. 1 - 6


@njit(cache=True)
def alg1_initialize(qpos, qvel, root_qadr, root_dadr, G0root, root_qbi, mass, inertia, gravity,
                    g, V, a, b, quat):
    """W Alg. 1 (controller initialization): pose ``g_{0,1}``, body velocity ``V_1^b``,
    ``a_1 = 0`` and ``b_1 = -F_1^be + Omega_1 M_1 V_1`` of the central body.

    MuJoCo's free joint gives the body-frame origin's position and world linear velocity and the
    body-frame angular velocity; they are moved to the central body's COM principal frame. The
    root quaternion is normalized (as MuJoCo does); the caller rejects a zero one.
    """
    q = quat[0]
    nrm = 0.0
    for i in range(4):
        q[i] = qpos[root_qadr + 3 + i]
        nrm += q[i] * q[i]
    nrm = np.sqrt(nrm)  # MuJoCo normalizes qpos quaternions; so does the controller
    for i in range(4):
        q[i] /= nrm
    quat_mul_into(q, root_qbi, quat[1])  # orientation of the inertial frame
    Rb = g[0, :3, :3]
    quat_to_rot_into(q, Rb)  # body-frame rotation, temporarily
    # world velocity of the COM: v_origin + R_b (w_b x ipos)
    ip0, ip1, ip2 = G0root[0, 3], G0root[1, 3], G0root[2, 3]
    wb0, wb1, wb2 = qvel[root_dadr + 3], qvel[root_dadr + 4], qvel[root_dadr + 5]
    c0 = wb1 * ip2 - wb2 * ip1
    c1 = wb2 * ip0 - wb0 * ip2
    c2 = wb0 * ip1 - wb1 * ip0
    vs0 = qvel[root_dadr + 0] + Rb[0, 0] * c0 + Rb[0, 1] * c1 + Rb[0, 2] * c2
    vs1 = qvel[root_dadr + 1] + Rb[1, 0] * c0 + Rb[1, 1] * c1 + Rb[1, 2] * c2
    vs2 = qvel[root_dadr + 2] + Rb[2, 0] * c0 + Rb[2, 1] * c1 + Rb[2, 2] * c2
    px = qpos[root_qadr + 0] + Rb[0, 0] * ip0 + Rb[0, 1] * ip1 + Rb[0, 2] * ip2
    py = qpos[root_qadr + 1] + Rb[1, 0] * ip0 + Rb[1, 1] * ip1 + Rb[1, 2] * ip2
    pz = qpos[root_qadr + 2] + Rb[2, 0] * ip0 + Rb[2, 1] * ip1 + Rb[2, 2] * ip2
    Ri = g[0, :3, :3]
    quat_to_rot_into(quat[1], Ri)
    g[0, 0, 3] = px
    g[0, 1, 3] = py
    g[0, 2, 3] = pz
    g[0, 3, 0] = 0.0
    g[0, 3, 1] = 0.0
    g[0, 3, 2] = 0.0
    g[0, 3, 3] = 1.0
    # angular velocity in the inertial frame: R_bi^T w_b
    Rbi = G0root[:3, :3]
    for i in range(3):
        V[0, 3 + i] = Rbi[0, i] * wb0 + Rbi[1, i] * wb1 + Rbi[2, i] * wb2
        V[0, i] = Ri[0, i] * vs0 + Ri[1, i] * vs1 + Ri[2, i] * vs2
        a[0, i] = 0.0
        a[0, 3 + i] = 0.0
    _bias(mass[0], inertia[0], Ri, gravity, V[0], b[0])


@njit(cache=True)
def alg2_velocity_propagation(qpos, qvel, parent, qadr, dadr, H, G0, qref, mass, inertia,
                              gravity, g, gl, V, a, b, tmp44):
    """W Alg. 2 (forward kinematics, outboard): for each joint k = link k's joint,
    ``g_{k.o,0}``, ``A = Ad_{g_{k.o,k.i}}``, ``V_{k.o} = A V_{k.i} + H_k thetadot_k``,
    ``a_k = ad_{V_{k.o}} H_k thetadot_k``, ``b_{k.o} = -F^be + Omega M V``.

    ``g[k]`` holds ``g_{0,k}`` (world pose of link k's frame) and ``gl[k]`` the joint transform
    ``g_{k.i,k.o}(theta_k)``, from which Alg. 3 and Alg. 6 apply ``A = Ad_{gl[k]}^-1`` without
    forming the 6x6 matrix.
    """
    n = parent.shape[0]
    for k in range(1, n):
        p = parent[k]
        theta = qpos[qadr[k]] - qref[k]
        thd = qvel[dadr[k]]
        E = tmp44[0]
        gpk = gl[k]
        _revolute_exp(H[k], theta, E)
        _mat4_mul(G0[k], E, gpk)  # g_{p,k}(theta)
        _mat4_mul(g[p], gpk, g[k])  # g_{0,k}
        # g_{k,p} = inverse(g_{p,k}): R^T, -R^T p
        Rkp = tmp44[2, :3, :3]
        pkp = tmp44[2, :3, 3]
        for i in range(3):
            for j in range(3):
                Rkp[i, j] = gpk[j, i]
        for i in range(3):
            pkp[i] = -(gpk[0, i] * gpk[0, 3] + gpk[1, i] * gpk[1, 3] + gpk[2, i] * gpk[2, 3])
        _ad_mul(Rkp, pkp, V[p], V[k])
        for i in range(6):
            V[k, i] += H[k, i] * thd
        # a_k = ad_{V_k} H_k thd = [w x hv + v x hw; w x hw] thd
        v0, v1, v2, w0, w1, w2 = V[k, 0], V[k, 1], V[k, 2], V[k, 3], V[k, 4], V[k, 5]
        h0, h1, h2, u0, u1, u2 = H[k, 0], H[k, 1], H[k, 2], H[k, 3], H[k, 4], H[k, 5]
        a[k, 0] = (w1 * h2 - w2 * h1 + v1 * u2 - v2 * u1) * thd
        a[k, 1] = (w2 * h0 - w0 * h2 + v2 * u0 - v0 * u2) * thd
        a[k, 2] = (w0 * h1 - w1 * h0 + v0 * u1 - v1 * u0) * thd
        a[k, 3] = (w1 * u2 - w2 * u1) * thd
        a[k, 4] = (w2 * u0 - w0 * u2) * thd
        a[k, 5] = (w0 * u1 - w1 * u0) * thd
        _bias(mass[k], inertia[k], g[k, :3, :3], gravity, V[k], b[k])


@njit(cache=True)
def alg3_workspace_dynamics(parent, H, mass, inertia, feet, contact, beyond, big_base, gl, a, b, P, z,
                            tmp6, tmp66):
    """W Alg. 3 (workspace dynamics, inboard): articulated-body inertias ``P_k`` and biases
    ``z_k`` from the feet to the central body with the big-base approximation
    ``P_foot = big_base * M_1``, ``z_foot = 0``. Result: ``P[0] = P_1``, ``z[0] = z_1`` with
    ``F_1 = P_1 Vdot_1^b + z_1`` for a wrench ``F_1`` on the central body (feet fixed).

    Per joint: ``D = H^T P H``, ``K = H D^-1 H^T``, ``L = (I - K P) A``,
    ``P_{k.i} += L^T P L = A^T (P - P H H^T P / D) A``, ``z_{k.i} += L^T (P a + z)``
    (accumulated: link 1 receives both legs). Only the feet with ``contact[f] != 0`` are big bases
    (W: both, always); a foot off the ground keeps its own inertia and bias, so its leg enters
    ``P_1``, ``z_1`` as a passive articulated branch. With ``A = Ad_{g_{k.o,k.i}}`` and
    ``gl[k] = g_{k.i,k.o} = (R, p)``, ``A^T = [[I, 0], [p^, I]] blockdiag(R, R)``: the 6x6 products
    are a block rotation followed by a shift, W eq. 3.7 written out.
    """
    n = parent.shape[0]
    for k in range(n):
        for i in range(6):
            z[k, i] = b[k, i]
            for j in range(6):
                P[k, i, j] = 0.0
        for i in range(3):
            P[k, i, i] = mass[k]
            P[k, 3 + i, 3 + i] = inertia[k, i]
    for f in range(feet.shape[0]):
        if contact[f] == 0:
            continue
        k = feet[f]
        for i in range(6):
            z[k, i] = 0.0
        for i in range(3):
            P[k, i, i] = big_base * mass[0]
            P[k, 3 + i, 3 + i] = big_base * inertia[0, i]
    PH = tmp6[0]
    c = tmp6[1]
    Pa = tmp66[0]
    Q = tmp66[1]
    W = tmp66[2]  # 3x3 scratch in the corner
    for k in range(n - 1, 0, -1):
        if beyond[k]:
            continue
        p = parent[k]
        Pk = P[k]
        Hk = H[k]
        for i in range(6):
            s = 0.0
            for j in range(6):
                s += Pk[i, j] * Hk[j]
            PH[i] = s
        D = 0.0
        for i in range(6):
            D += Hk[i] * PH[i]
        Dinv = 1.0 / D
        # c = P a + z ; c <- c - PH (H.c) / D ; Pa = P - PH PH^T / D
        hc = 0.0
        for i in range(6):
            s = z[k, i]
            for j in range(6):
                s += Pk[i, j] * a[k, j]
            c[i] = s
        for i in range(6):
            hc += Hk[i] * c[i]
        for i in range(6):
            u = PH[i] * Dinv
            c[i] -= u * hc
            for j in range(6):
                Pa[i, j] = Pk[i, j] - u * PH[j]
        gm = gl[k]
        px, py, pz = gm[0, 3], gm[1, 3], gm[2, 3]
        r00, r01, r02 = gm[0, 0], gm[0, 1], gm[0, 2]
        r10, r11, r12 = gm[1, 0], gm[1, 1], gm[1, 2]
        r20, r21, r22 = gm[2, 0], gm[2, 1], gm[2, 2]
        # z_p += A^T c: f' = R f, tau' = R tau + p x f'
        f0 = r00 * c[0] + r01 * c[1] + r02 * c[2]
        f1 = r10 * c[0] + r11 * c[1] + r12 * c[2]
        f2 = r20 * c[0] + r21 * c[1] + r22 * c[2]
        z[p, 0] += f0
        z[p, 1] += f1
        z[p, 2] += f2
        z[p, 3] += r00 * c[3] + r01 * c[4] + r02 * c[5] + py * f2 - pz * f1
        z[p, 4] += r10 * c[3] + r11 * c[4] + r12 * c[5] + pz * f0 - px * f2
        z[p, 5] += r20 * c[3] + r21 * c[4] + r22 * c[5] + px * f1 - py * f0
        # Q = blockdiag(R, R) Pa blockdiag(R, R)^T, blocks 11, 12, 22: W = Pa_blk R^T, Q = R W
        for blk in range(3):
            bi = 0 if blk < 2 else 3
            bj = 0 if blk == 0 else 3
            for i in range(3):
                m0, m1, m2 = Pa[bi + i, bj], Pa[bi + i, bj + 1], Pa[bi + i, bj + 2]
                W[i, 0] = m0 * r00 + m1 * r01 + m2 * r02
                W[i, 1] = m0 * r10 + m1 * r11 + m2 * r12
                W[i, 2] = m0 * r20 + m1 * r21 + m2 * r22
            for j in range(3):
                w0, w1, w2 = W[0, j], W[1, j], W[2, j]
                Q[bi, bj + j] = r00 * w0 + r01 * w1 + r02 * w2
                Q[bi + 1, bj + j] = r10 * w0 + r11 * w1 + r12 * w2
                Q[bi + 2, bj + j] = r20 * w0 + r21 * w1 + r22 * w2
        # S = B12 = Q12 - Q11 p^ (into W)
        for i in range(3):
            W[i, 0] = Q[i, 3] - (Q[i, 1] * pz - Q[i, 2] * py)
            W[i, 1] = Q[i, 4] - (Q[i, 2] * px - Q[i, 0] * pz)
            W[i, 2] = Q[i, 5] - (Q[i, 0] * py - Q[i, 1] * px)
        # B22 = Q22 + p^ Q12 - S^T p^
        for j in range(3):
            h0 = py * Q[2, 3 + j] - pz * Q[1, 3 + j]
            h1 = pz * Q[0, 3 + j] - px * Q[2, 3 + j]
            h2 = px * Q[1, 3 + j] - py * Q[0, 3 + j]
            if j == 0:
                s0, s1, s2 = W[1, 0] * pz - W[2, 0] * py, W[1, 1] * pz - W[2, 1] * py, W[1, 2] * pz - W[2, 2] * py
            elif j == 1:
                s0, s1, s2 = W[2, 0] * px - W[0, 0] * pz, W[2, 1] * px - W[0, 1] * pz, W[2, 2] * px - W[0, 2] * pz
            else:
                s0, s1, s2 = W[0, 0] * py - W[1, 0] * px, W[0, 1] * py - W[1, 1] * px, W[0, 2] * py - W[1, 2] * px
            P[p, 3, 3 + j] += Q[3, 3 + j] + h0 - s0
            P[p, 4, 3 + j] += Q[4, 3 + j] + h1 - s1
            P[p, 5, 3 + j] += Q[5, 3 + j] + h2 - s2
        for i in range(3):
            for j in range(3):
                P[p, i, j] += Q[i, j]
                P[p, i, 3 + j] += W[i, j]
                P[p, 3 + j, i] += W[i, j]


@njit(cache=True)
def alg4_desired_wrench(g, V, P, z, target, gains, quat, R3, X, qe, Fd):
    """W Alg. 4 (desired wrench): PD on the central body's COM position (space frame) and on the
    unit-quaternion orientation error ``q_et = q_{0,1} * conj(q_{0,d})`` with the sign chosen so that
    its scalar part is >= 0; ``F_1^bd = P_1 X^b + z_1``.

    ``target`` (19,) = [p_d (3), pdot_d (3), pddot_d (3), q_d (4, w x y z), w_d^s (3), wdot_d^s (3)];
    ``gains`` (12,) = diagonals of [K_c^p, K_c^v, K_R^p, K_R^v].
    """
    R = g[0, :3, :3]
    # world COM velocity and angular velocity
    pd0 = R[0, 0] * V[0, 0] + R[0, 1] * V[0, 1] + R[0, 2] * V[0, 2]
    pd1 = R[1, 0] * V[0, 0] + R[1, 1] * V[0, 1] + R[1, 2] * V[0, 2]
    pd2 = R[2, 0] * V[0, 0] + R[2, 1] * V[0, 1] + R[2, 2] * V[0, 2]
    ws0 = R[0, 0] * V[0, 3] + R[0, 1] * V[0, 4] + R[0, 2] * V[0, 5]
    ws1 = R[1, 0] * V[0, 3] + R[1, 1] * V[0, 4] + R[1, 2] * V[0, 5]
    ws2 = R[2, 0] * V[0, 3] + R[2, 1] * V[0, 4] + R[2, 2] * V[0, 5]
    pdot = (pd0, pd1, pd2)
    ws = (ws0, ws1, ws2)
    Xc0 = target[6] - gains[3] * (pd0 - target[3]) - gains[0] * (g[0, 0, 3] - target[0])
    Xc1 = target[7] - gains[4] * (pd1 - target[4]) - gains[1] * (g[0, 1, 3] - target[1])
    Xc2 = target[8] - gains[5] * (pd2 - target[5]) - gains[2] * (g[0, 2, 3] - target[2])
    # subtract w^s x pdot^s
    Xc0 -= ws1 * pdot[2] - ws2 * pdot[1]
    Xc1 -= ws2 * pdot[0] - ws0 * pdot[2]
    Xc2 -= ws0 * pdot[1] - ws1 * pdot[0]
    for i in range(3):
        X[i] = R[0, i] * Xc0 + R[1, i] * Xc1 + R[2, i] * Xc2
    # quaternion error q_et = q_{0,1} * conj(q_d)
    qd = quat[2]
    qd[0] = target[9]
    qd[1] = -target[10]
    qd[2] = -target[11]
    qd[3] = -target[12]
    quat_mul_into(quat[1], qd, qe)
    if qe[0] < 0.0:
        for i in range(4):
            qe[i] = -qe[i]
    Re = R3[0]
    quat_to_rot_into(qe, Re)
    # R_e w_d and R_e wdot_d
    rw0 = Re[0, 0] * target[13] + Re[0, 1] * target[14] + Re[0, 2] * target[15]
    rw1 = Re[1, 0] * target[13] + Re[1, 1] * target[14] + Re[1, 2] * target[15]
    rw2 = Re[2, 0] * target[13] + Re[2, 1] * target[14] + Re[2, 2] * target[15]
    ra0 = Re[0, 0] * target[16] + Re[0, 1] * target[17] + Re[0, 2] * target[18]
    ra1 = Re[1, 0] * target[16] + Re[1, 1] * target[17] + Re[1, 2] * target[18]
    ra2 = Re[2, 0] * target[16] + Re[2, 1] * target[17] + Re[2, 2] * target[18]
    we0, we1, we2 = ws[0] - rw0, ws[1] - rw1, ws[2] - rw2
    XR0 = ra0 + (ws1 * rw2 - ws2 * rw1) - gains[9] * we0 - gains[6] * qe[1]
    XR1 = ra1 + (ws2 * rw0 - ws0 * rw2) - gains[10] * we1 - gains[7] * qe[2]
    XR2 = ra2 + (ws0 * rw1 - ws1 * rw0) - gains[11] * we2 - gains[8] * qe[3]
    for i in range(3):
        X[3 + i] = R[0, i] * XR0 + R[1, i] * XR1 + R[2, i] * XR2
    for i in range(6):
        s = z[0, i]
        for j in range(6):
            s += P[0, i, j] * X[j]
        Fd[i] = s


@njit(cache=True)
def alg5_wrench_distribution(g, feet, contact, Fd, tmp6, tmp66, R3, Fl, Fr, Fl_tilde, Fr_tilde,
                             printed=False):
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

    Returns False when ``G G^T`` (a sum of two positive-definite matrices) is not positive
    definite to working precision: non-finite poses or feet absurdly far from the body.
    """
    GG = tmp66[0]
    Afoot = tmp66[1]
    for i in range(6):
        for j in range(6):
            GG[i, j] = 0.0
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
        R = R3[f]
        pp = tmp6[2 + f]
        if printed:  # W's print: g_{1,foot} = g_{0,1}^-1 g_{0,foot}
            for i in range(3):
                for j in range(3):
                    R[i, j] = R0[0, i] * g[k, 0, j] + R0[1, i] * g[k, 1, j] + R0[2, i] * g[k, 2, j]
                pp[i] = (R0[0, i] * (g[k, 0, 3] - g[0, 0, 3]) + R0[1, i] * (g[k, 1, 3] - g[0, 1, 3])
                         + R0[2, i] * (g[k, 2, 3] - g[0, 2, 3]))
        else:  # g_{foot,1} = g_{0,foot}^-1 g_{0,1}: R = R_f^T R_0, p = R_f^T (p_0 - p_f)
            for i in range(3):
                for j in range(3):
                    R[i, j] = g[k, 0, i] * R0[0, j] + g[k, 1, i] * R0[1, j] + g[k, 2, i] * R0[2, j]
                pp[i] = (g[k, 0, i] * (g[0, 0, 3] - g[k, 0, 3]) + g[k, 1, i] * (g[0, 1, 3] - g[k, 1, 3])
                         + g[k, 2, i] * (g[0, 2, 3] - g[k, 2, 3]))
        if contact[f] == 0:
            continue
        adjoint_into(R, pp[:3], Afoot)
        for i in range(6):
            for j in range(i, 6):
                s = 0.0
                for m in range(6):
                    s += Afoot[m, i] * Afoot[m, j]
                GG[i, j] += s
                if j != i:
                    GG[j, i] += s
    # Cholesky of GG (in place, lower), then y = GG^-1 Fd into tmp6[0]
    L = GG
    for j in range(6):
        s = L[j, j]
        for m in range(j):
            s -= L[j, m] * L[j, m]
        if not (s > 1e-12 * (1.0 + abs(GG[j, j]))):
            return False
        L[j, j] = np.sqrt(s)
        for i in range(j + 1, 6):
            s = L[i, j]
            for m in range(j):
                s -= L[i, m] * L[j, m]
            L[i, j] = s / L[j, j]
    y = tmp6[0]
    for i in range(6):
        s = Fd[i]
        for m in range(i):
            s -= L[i, m] * y[m]
        y[i] = s / L[i, i]
    for i in range(5, -1, -1):
        s = y[i]
        for m in range(i + 1, 6):
            s -= L[m, i] * y[m]
        y[i] = s / L[i, i]
    # F_foot = Ad_{g_{foot,1}} y ; F~ = Ad^T_{g_{foot,1}} F_foot
    _ad_mul(R3[0], tmp6[2, :3], y, Fl)
    _adT_mul(R3[0], tmp6[2, :3], Fl, Fl_tilde)
    _ad_mul(R3[1], tmp6[3, :3], y, Fr)
    _adT_mul(R3[1], tmp6[3, :3], Fr, Fr_tilde)
    for i in range(6):
        if contact[0] == 0:
            Fl[i] = 0.0
            Fl_tilde[i] = 0.0
        if contact[1] == 0:
            Fr[i] = 0.0
            Fr_tilde[i] = 0.0
    return True


@njit(cache=True)
def alg6_torques(parent, H, leg, beyond, gl, Fl_tilde, Fr_tilde, F, tau):
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
        gpk = gl[k]
        _adT_mul(gpk[:3, :3], gpk[:3, 3], Ft, F[k])
        s = 0.0
        for i in range(6):
            F[k, i] *= -sign
            s += H[k, i] * F[k, i]
        tau[k - 1] = s


@njit(cache=True)
def compute_kernel(qpos, qvel, target, gains, contact, mi, mf, work, out):
    """One controller call: W Alg. 1-6 on flat buffers (see :func:`layout`); ``contact`` (2,) int
    flags the (left, right) feet taken as fixed to the ground (W: both). Returns a status code
    (0 ok, 1 non-finite state, 2 non-finite result, 3 singular wrench distribution, 4 zero root
    quaternion)."""
    for i in range(qpos.shape[0]):
        if not np.isfinite(qpos[i]):
            return NONFINITE_STATE
    for i in range(qvel.shape[0]):
        if not np.isfinite(qvel[i]):
            return NONFINITE_STATE
    r = mi[4 + mi[0]]  # qpos address of the root's free joint
    if qpos[r + 3] ** 2 + qpos[r + 4] ** 2 + qpos[r + 5] ** 2 + qpos[r + 6] ** 2 < 1e-20:
        return ZERO_QUATERNION
    n = mi[0]
    parent = mi[4:4 + n]
    qadr = mi[4 + n:4 + 2 * n]
    dadr = mi[4 + 2 * n:4 + 3 * n]
    leg = mi[4 + 3 * n:4 + 4 * n]
    beyond = mi[4 + 4 * n:4 + 5 * n]
    feet = mi[1:3]
    o = 0
    H = mf[o:o + 6 * n].reshape((n, 6)); o += 6 * n
    G0 = mf[o:o + 16 * n].reshape((n, 4, 4)); o += 16 * n
    mass = mf[o:o + n]; o += n
    inertia = mf[o:o + 3 * n].reshape((n, 3)); o += 3 * n
    qref = mf[o:o + n]; o += n
    gravity = mf[o:o + 3]; o += 3
    root_qbi = mf[o:o + 4]; o += 4
    big_base = mf[o]
    o = 0
    g = work[o:o + 16 * n].reshape((n, 4, 4)); o += 16 * n
    gl = work[o:o + 16 * n].reshape((n, 4, 4)); o += 16 * n
    V = work[o:o + 6 * n].reshape((n, 6)); o += 6 * n
    a = work[o:o + 6 * n].reshape((n, 6)); o += 6 * n
    b = work[o:o + 6 * n].reshape((n, 6)); o += 6 * n
    P = work[o:o + 36 * n].reshape((n, 6, 6)); o += 36 * n
    z = work[o:o + 6 * n].reshape((n, 6)); o += 6 * n
    F = work[o:o + 6 * n].reshape((n, 6)); o += 6 * n
    tmp6 = work[o:o + 24].reshape((4, 6)); o += 24
    tmp66 = work[o:o + 108].reshape((3, 6, 6)); o += 108
    quat = work[o:o + 12].reshape((3, 4)); o += 12
    R3 = work[o:o + 18].reshape((2, 3, 3)); o += 18
    o = 0
    tau = out[o:o + n - 1]; o += n - 1
    P1 = out[o:o + 36].reshape((6, 6)); o += 36
    z1 = out[o:o + 6]; o += 6
    Fd = out[o:o + 6]; o += 6
    Fl_tilde = out[o:o + 6]; o += 6
    Fr_tilde = out[o:o + 6]; o += 6
    Fl = out[o:o + 6]; o += 6
    Fr = out[o:o + 6]; o += 6
    X = out[o:o + 6]; o += 6
    qe = out[o:o + 4]; o += 4
    tmp44 = tmp66.reshape((108,))[:48].reshape((3, 4, 4))

    alg1_initialize(qpos, qvel, qadr[0], dadr[0], G0[0], root_qbi, mass, inertia, gravity, g, V, a,
                    b, quat)
    alg2_velocity_propagation(qpos, qvel, parent, qadr, dadr, H, G0, qref, mass, inertia, gravity,
                              g, gl, V, a, b, tmp44)
    alg3_workspace_dynamics(parent, H, mass, inertia, feet, contact, beyond, big_base, gl, a, b, P, z,
                            tmp6, tmp66)
    for i in range(6):
        z1[i] = z[0, i]
        for j in range(6):
            P1[i, j] = P[0, i, j]
    alg4_desired_wrench(g, V, P, z, target, gains, quat, R3, X, qe, Fd)
    if mi[3] != STOP_AFTER_ALG4:  # else the caller distributes F_1^bd (biped.control.distribution)
        if not alg5_wrench_distribution(g, feet, contact, Fd, tmp6, tmp66, R3, Fl, Fr, Fl_tilde,
                                        Fr_tilde, mi[3] == 1):
            return SINGULAR_DISTRIBUTION
        alg6_torques(parent, H, leg, beyond, gl, Fl_tilde, Fr_tilde, F, tau)
    for i in range(out.shape[0]):
        if not np.isfinite(out[i]):
            return NONFINITE_RESULT
    return OK
