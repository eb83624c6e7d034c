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

Buffers are flat arrays whose fields :data:`_FIELDS` lists, :func:`layout` places and :func:`unpack`
cuts into named views; :class:`biped.control.WorkspaceController` owns them. The kernel allocates
nothing; the spatial products it repeats (adjoint actions, the congruence of Alg. 3, the 6x6 solve of
Alg. 5) are inlined helpers of :mod:`biped.spatial`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

# the buffers (fields, layout, views) live in biped.control.buffers; re-exported here
from biped.control.buffers import _FIELDS, Ints, Model, Out, Work, borrowed, layout, unpack  # noqa: F401
from biped.control.statics import alg5_wrench_distribution, alg6_torques  # noqa: F401  (re-exported)
from biped.spatial import (
    adjoint_inv_congruence_add,
    adjoint_inv_mul,
    adjoint_inv_T_mul,
    cross,
    dot6,
    mat6_mul_vec,
    mat6_mul_vec_add,
    quat_mul_into,
    quat_to_rot_into,
    rot_mul,
    rot_T_mul,
)

# status codes returned by compute_kernel
OK = 0
NONFINITE_STATE = 1
NONFINITE_RESULT = 2
SINGULAR_DISTRIBUTION = 3
ZERO_QUATERNION = 4

#: ints "mode": 0 W Alg. 5 (statics), 1 W's printed Alg. 5, 2 stop after Alg. 4 (the QP distributes)
STOP_AFTER_ALG4 = 2

# ----------------------------------------------------------------------------- small helpers


@njit(cache=True, inline="always")
def _body_inertia(scale, m, inertia, P):
    """P = scale M_k = scale blockdiag(m I3, diag(inertia)) (W eq. 3.9)."""
    for i in range(6):
        for j in range(6):
            P[i, j] = 0.0
    for i in range(3):
        P[i, i] = scale * m
        P[3 + i, 3 + i] = scale * inertia[i]


@njit(cache=True)
def _bias(m, I, R0k, gvec, V, b):
    """b = -F^be + Omega M V: gravity and gyroscopic wrench of one link (W Alg. 1, eq. 3.9)."""
    w = V[3:]
    # gravity in the link frame: R^T g m
    for i in range(3):
        b[i] = -m * (R0k[0, i] * gvec[0] + R0k[1, i] * gvec[1] + R0k[2, i] * gvec[2])
    wv = cross(w, V[:3])
    b[0] += m * wv[0]
    b[1] += m * wv[1]
    b[2] += m * wv[2]
    b[3], b[4], b[5] = cross(w, (I[0] * w[0], I[1] * w[1], I[2] * w[2]))


@njit(cache=True, inline="always")
def _velocity_product(V, H, thd, a):
    """a = ad_V H thetadot = [w x hv + v x hw; w x hw] thetadot (W Alg. 2, see the module notes)."""
    v0, v1, v2, w0, w1, w2 = V[0], V[1], V[2], V[3], V[4], V[5]
    h0, h1, h2, u0, u1, u2 = H[0], H[1], H[2], H[3], H[4], H[5]
    a[0] = (w1 * h2 - w2 * h1 + v1 * u2 - v2 * u1) * thd
    a[1] = (w2 * h0 - w0 * h2 + v2 * u0 - v0 * u2) * thd
    a[2] = (w0 * h1 - w1 * h0 + v0 * u1 - v1 * u0) * thd
    a[3] = (w1 * u2 - w2 * u1) * thd
    a[4] = (w2 * u0 - w0 * u2) * thd
    a[5] = (w0 * u1 - w1 * u0) * thd


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
        g[i, 3] = (
            (x0 if i == 0 else (x1 if i == 1 else x2))
            - (R[i, 0] * x0 + R[i, 1] * x1 + R[i, 2] * x2)
            + H[3 + i] * wv * theta
        )
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
def alg1_initialize(
    qpos: np.ndarray,
    qvel: np.ndarray,
    root_qadr: int,
    root_dadr: int,
    G0root: np.ndarray,
    root_qbi: np.ndarray,
    mass: np.ndarray,
    inertia: np.ndarray,
    gravity: np.ndarray,
    g: np.ndarray,
    V: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    q_root: np.ndarray,
    q01: np.ndarray,
) -> None:
    """W Alg. 1 (controller initialization): pose ``g_{0,1}``, body velocity ``V_1^b``,
    ``a_1 = 0`` and ``b_1 = -F_1^be + Omega_1 M_1 V_1`` of the central body.

    MuJoCo's free joint gives the body-frame origin's position and world linear velocity and the
    body-frame angular velocity; they are moved to the central body's COM principal frame. The
    root quaternion is normalized into ``q_root`` (as MuJoCo does; the caller rejects a zero one);
    ``q01`` receives ``q_{0,1}``, the orientation of the COM principal frame.
    """
    nrm = 0.0
    for i in range(4):
        q_root[i] = qpos[root_qadr + 3 + i]
        nrm += q_root[i] * q_root[i]
    nrm = np.sqrt(nrm)  # MuJoCo normalizes qpos quaternions; so does the controller
    for i in range(4):
        q_root[i] /= nrm
    quat_mul_into(q_root, root_qbi, q01)  # orientation of the inertial frame
    Rb = g[0, :3, :3]
    quat_to_rot_into(q_root, Rb)  # body-frame rotation, temporarily
    # world velocity of the COM: v_origin + R_b (w_b x ipos)
    ip0, ip1, ip2 = G0root[0, 3], G0root[1, 3], G0root[2, 3]
    wb0, wb1, wb2 = qvel[root_dadr + 3], qvel[root_dadr + 4], qvel[root_dadr + 5]
    c0, c1, c2 = cross((wb0, wb1, wb2), (ip0, ip1, ip2))
    vs0 = qvel[root_dadr + 0] + Rb[0, 0] * c0 + Rb[0, 1] * c1 + Rb[0, 2] * c2
    vs1 = qvel[root_dadr + 1] + Rb[1, 0] * c0 + Rb[1, 1] * c1 + Rb[1, 2] * c2
    vs2 = qvel[root_dadr + 2] + Rb[2, 0] * c0 + Rb[2, 1] * c1 + Rb[2, 2] * c2
    px = qpos[root_qadr + 0] + Rb[0, 0] * ip0 + Rb[0, 1] * ip1 + Rb[0, 2] * ip2
    py = qpos[root_qadr + 1] + Rb[1, 0] * ip0 + Rb[1, 1] * ip1 + Rb[1, 2] * ip2
    pz = qpos[root_qadr + 2] + Rb[2, 0] * ip0 + Rb[2, 1] * ip1 + Rb[2, 2] * ip2
    Ri = g[0, :3, :3]
    quat_to_rot_into(q01, Ri)
    g[0, 0, 3] = px
    g[0, 1, 3] = py
    g[0, 2, 3] = pz
    g[0, 3, 0] = 0.0
    g[0, 3, 1] = 0.0
    g[0, 3, 2] = 0.0
    g[0, 3, 3] = 1.0
    # angular velocity in the inertial frame: R_bi^T w_b; COM velocity R_i^T v^s
    V[0, 3], V[0, 4], V[0, 5] = rot_T_mul(G0root[:3, :3], (wb0, wb1, wb2))
    V[0, 0], V[0, 1], V[0, 2] = rot_T_mul(Ri, (vs0, vs1, vs2))
    for i in range(6):
        a[0, i] = 0.0
    _bias(mass[0], inertia[0], Ri, gravity, V[0], b[0])


@njit(cache=True)
def alg2_velocity_propagation(
    qpos: np.ndarray,
    qvel: np.ndarray,
    parent: np.ndarray,
    qadr: np.ndarray,
    dadr: np.ndarray,
    H: np.ndarray,
    G0: np.ndarray,
    qref: np.ndarray,
    mass: np.ndarray,
    inertia: np.ndarray,
    gravity: np.ndarray,
    g: np.ndarray,
    gl: np.ndarray,
    V: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    E: np.ndarray,
) -> None:
    """W Alg. 2 (forward kinematics, outboard): for each joint k = link k's joint,
    ``g_{k.o,0}``, ``A = Ad_{g_{k.o,k.i}}``, ``V_{k.o} = A V_{k.i} + H_k thetadot_k``,
    ``a_k = ad_{V_{k.o}} H_k thetadot_k``, ``b_{k.o} = -F^be + Omega M V``.

    ``g[k]`` holds ``g_{0,k}`` (world pose of link k's frame) and ``gl[k]`` the joint transform
    ``g_{k.i,k.o}(theta_k)``, from which Alg. 3 and Alg. 6 apply ``A = Ad_{gl[k]}^-1`` without
    forming the 6x6 matrix. Scratch ``E`` (4, 4).
    """
    for k in range(1, parent.shape[0]):
        i = parent[k]
        _revolute_exp(H[k], qpos[qadr[k]] - qref[k], E)  # exp(H_k^ theta_k)
        _mat4_mul(G0[k], E, gl[k])  # g_{k.i,k.o}(theta_k)
        _mat4_mul(g[i], gl[k], g[k])  # g_{0,k.o} = g_{0,k.i} g_{k.i,k.o}
        thd = qvel[dadr[k]]
        adjoint_inv_mul(gl[k, :3, :3], gl[k, :3, 3], V[i], V[k])  # A V_{k.i}
        for j in range(6):
            V[k, j] += H[k, j] * thd  # V_{k.o} = A V_{k.i} + H_k thetadot_k
        _velocity_product(V[k], H[k], thd, a[k])  # a_k
        _bias(mass[k], inertia[k], g[k, :3, :3], gravity, V[k], b[k])  # b_{k.o} (eq. 3.9)


@njit(cache=True)
def alg3_workspace_dynamics(
    parent: np.ndarray,
    H: np.ndarray,
    mass: np.ndarray,
    inertia: np.ndarray,
    feet: np.ndarray,
    contact: np.ndarray,
    beyond: np.ndarray,
    big_base: float,
    gl: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    P: np.ndarray,
    z: np.ndarray,
    PH: np.ndarray,
    c: np.ndarray,
    c_in: np.ndarray,
    Pa: np.ndarray,
    Q: np.ndarray,
    S: np.ndarray,
) -> None:
    """W Alg. 3 (workspace dynamics, inboard): articulated-body inertias ``P_k`` and biases
    ``z_k`` from the feet to the central body with the big-base approximation
    ``P_foot = big_base * M_1``, ``z_foot = 0``. Result: ``P[0] = P_1``, ``z[0] = z_1`` with
    ``F_1 = P_1 Vdot_1^b + z_1`` for a wrench ``F_1`` on the central body (feet fixed).

    Per joint: ``D = H^T P H``, ``K = H D^-1 H^T``, ``L = (I - K P) A``, so
    ``L^T P L = A^T (P - P H D^-1 H^T P) A`` and ``L^T (P a + z) = A^T (I - P H D^-1 H^T)(P a + z)``;
    the inboard quantities accumulate (link 1 receives both legs). Only the feet with
    ``contact[f] != 0`` are big bases (W: both, always); a foot off the ground keeps its own
    inertia and bias, so its leg enters ``P_1``, ``z_1`` as a passive articulated branch.
    ``A = Ad_{g_{k.o,k.i}} = Ad^-1_{gl[k]}`` is applied without forming it (biped.spatial).
    Scratch: ``PH``, ``c``, ``c_in`` (6,), ``Pa``, ``Q`` (6, 6), ``S`` (3, 3).
    """
    for k in range(parent.shape[0]):
        _body_inertia(1.0, mass[k], inertia[k], P[k])  # P_k = M_k^b (eq. 3.9)
        z[k, :] = b[k]  # z_k = b_k^b
    for f in range(feet.shape[0]):  # fixed-base approximation: P_7 = P_13 = 10^6 M_1^b, z = 0
        if contact[f] != 0:
            _body_inertia(big_base, mass[0], inertia[0], P[feet[f]])
            z[feet[f], :] = 0.0
    for k in range(parent.shape[0] - 1, 0, -1):  # k = 13 to 2
        if beyond[k]:
            continue
        R, p = gl[k, :3, :3], gl[k, :3, 3]  # A_{k.i}^{k.o} = Ad^-1_{(R, p)}
        mat6_mul_vec(P[k], H[k], PH)  # P_{k.o} H_k
        Dinv = 1.0 / dot6(H[k], PH)  # D_k^-1 = (H_k^T P_{k.o} H_k)^-1
        mat6_mul_vec_add(P[k], a[k], z[k], c)  # c = P_{k.o} a_k + z_{k.o}
        hc = dot6(H[k], c)
        for i in range(6):  # c <- (I - P K) c ; Pa = P - P K P = (I - P K) P
            u = PH[i] * Dinv
            c[i] -= u * hc
            for j in range(6):
                Pa[i, j] = P[k, i, j] - u * PH[j]
        adjoint_inv_T_mul(R, p, c, c_in)  # L_k^T (P_{k.o} a_k + z_{k.o}) = A^T c
        for i in range(6):
            z[parent[k], i] += c_in[i]  # z_{k.i} += L^T (P a + z)
        adjoint_inv_congruence_add(R, p, Pa, P[parent[k]], Q, S)  # P_{k.i} += L^T P L = A^T Pa A


@njit(cache=True)
def alg4_desired_wrench(
    g: np.ndarray,
    V: np.ndarray,
    P: np.ndarray,
    z: np.ndarray,
    target: np.ndarray,
    gains: np.ndarray,
    q01: np.ndarray,
    qd_conj: np.ndarray,
    Re: np.ndarray,
    X: np.ndarray,
    qe: np.ndarray,
    Fd: np.ndarray,
) -> None:
    """W Alg. 4 (desired wrench): PD on the central body's COM position (space frame) and on the
    unit-quaternion orientation error ``q_et = q_{0,1} * conj(q_{0,d})`` with the sign chosen so that
    its scalar part is >= 0; ``F_1^bd = P_1 X^b + z_1`` (W eq. 3.10).

    ``target`` (19,) = [p_d (3), pdot_d (3), pddot_d (3), q_d (4, w x y z), w_d^s (3), wdot_d^s (3)];
    ``gains`` (12,) = diagonals of [K_c^p, K_c^v, K_R^p, K_R^v]. ``q01`` is ``q_{0,1}`` from Alg. 1;
    scratch ``qd_conj`` (4,), ``Re`` (3, 3).
    """
    R = g[0, :3, :3]
    pd0, pd1, pd2 = pdot = rot_mul(R, V[0, :3])  # world COM velocity
    ws = rot_mul(R, V[0, 3:])  # world angular velocity
    Xc0 = target[6] - gains[3] * (pd0 - target[3]) - gains[0] * (g[0, 0, 3] - target[0])
    Xc1 = target[7] - gains[4] * (pd1 - target[4]) - gains[1] * (g[0, 1, 3] - target[1])
    Xc2 = target[8] - gains[5] * (pd2 - target[5]) - gains[2] * (g[0, 2, 3] - target[2])
    wp = cross(ws, pdot)  # X_c^b = R^T (X_c^s - w^s x pdot^s)
    X[0], X[1], X[2] = rot_T_mul(R, (Xc0 - wp[0], Xc1 - wp[1], Xc2 - wp[2]))
    # quaternion error q_et = q_{0,1} * conj(q_d)
    qd_conj[0] = target[9]
    qd_conj[1] = -target[10]
    qd_conj[2] = -target[11]
    qd_conj[3] = -target[12]
    quat_mul_into(q01, qd_conj, qe)
    if qe[0] < 0.0:
        for i in range(4):
            qe[i] = -qe[i]
    quat_to_rot_into(qe, Re)
    rw = rot_mul(Re, target[13:16])  # R_e w_d
    ra0, ra1, ra2 = rot_mul(Re, target[16:19])  # R_e wdot_d
    we0, we1, we2 = ws[0] - rw[0], ws[1] - rw[1], ws[2] - rw[2]
    wr = cross(ws, rw)
    XR0 = ra0 + wr[0] - gains[9] * we0 - gains[6] * qe[1]
    XR1 = ra1 + wr[1] - gains[10] * we1 - gains[7] * qe[2]
    XR2 = ra2 + wr[2] - gains[11] * we2 - gains[8] * qe[3]
    X[3], X[4], X[5] = rot_T_mul(R, (XR0, XR1, XR2))
    mat6_mul_vec_add(P[0], X, z[0], Fd)  # F_1^bd = P_1 X^b + z_1 (eq. 3.10)


@njit(cache=True)
def alg12_kinematics(qpos, qvel, t, m, w):  # pragma: no cover - compiled
    """W Alg. 1 and Alg. 2 on the unpacked buffers ``t, m, w`` of :func:`unpack` (poses, body
    velocities and the recursions' velocity terms into ``w``): the first part of
    :func:`compute_kernel`, and what :func:`kinematics` runs alone."""
    alg1_initialize(
        qpos,
        qvel,
        t.qadr[0],
        t.dadr[0],
        m.G0[0],
        m.root_qbi,
        m.mass,
        m.inertia,
        m.gravity,
        w.g,
        w.V,
        w.a,
        w.b,
        w.q_root,
        w.q01,
    )
    alg2_velocity_propagation(
        qpos,
        qvel,
        t.parent,
        t.qadr,
        t.dadr,
        m.H,
        m.G0,
        m.qref,
        m.mass,
        m.inertia,
        m.gravity,
        w.g,
        w.gl,
        w.V,
        w.a,
        w.b,
        w.E,
    )


@njit(cache=True)
def kinematics(qpos, qvel, mi, mf, work, out):  # pragma: no cover - compiled
    """:func:`alg12_kinematics` on the flat buffers (for the controller's checking methods)."""
    t, m, w, _ = unpack(mi, mf, work, out)
    alg12_kinematics(qpos, qvel, t, m, w)


@njit(cache=True)
def compute_kernel(
    qpos: np.ndarray,
    qvel: np.ndarray,
    target: np.ndarray,
    gains: np.ndarray,
    contact: np.ndarray,
    mi: np.ndarray,
    mf: np.ndarray,
    work: np.ndarray,
    out: np.ndarray,
) -> int:
    """One controller call: W Alg. 1-6 on flat buffers (see :func:`layout` and :func:`unpack`);
    ``contact`` (2,) int flags the (left, right) feet taken as fixed to the ground (W: both).
    Returns a status code (0 ok, 1 non-finite state, 2 non-finite result, 3 singular wrench
    distribution, 4 zero root quaternion)."""
    for i in range(qpos.shape[0]):
        if not np.isfinite(qpos[i]):
            return NONFINITE_STATE
    for i in range(qvel.shape[0]):
        if not np.isfinite(qvel[i]):
            return NONFINITE_STATE
    # the views below without reference counting (biped.control.buffers.borrowed)
    mi, mf, work, out = borrowed(mi), borrowed(mf), borrowed(work), borrowed(out)  # type: ignore[call-arg]
    t, m, w, o = unpack(mi, mf, work, out)
    r = t.qadr[0]  # qpos address of the root's free joint
    if qpos[r + 3] ** 2 + qpos[r + 4] ** 2 + qpos[r + 5] ** 2 + qpos[r + 6] ** 2 < 1e-20:
        return ZERO_QUATERNION

    alg12_kinematics(qpos, qvel, t, m, w)
    alg3_workspace_dynamics(
        t.parent,
        m.H,
        m.mass,
        m.inertia,
        t.feet,
        contact,
        t.beyond,
        m.big_base[0],
        w.gl,
        w.a,
        w.b,
        w.P,
        w.z,
        w.PH,
        w.c,
        w.c_in,
        w.Pa,
        w.Q,
        w.S,
    )
    o.z1[:] = w.z[0]
    o.P1[:, :] = w.P[0]
    alg4_desired_wrench(w.g, w.V, w.P, w.z, target, gains, w.q01, w.qd_conj, w.Re, o.X, o.qe, o.Fd)
    if t.mode[0] != STOP_AFTER_ALG4:  # else the caller distributes F_1^bd (biped.control.distribution)
        if not alg5_wrench_distribution(
            w.g,
            t.feet,
            contact,
            o.Fd,
            w.dist_vecs,
            w.dist_mats,
            w.R_foot,
            o.Fl,
            o.Fr,
            o.Fl_tilde,
            o.Fr_tilde,
            t.mode[0] == 1,
        ):
            return SINGULAR_DISTRIBUTION
        alg6_torques(t.parent, m.H, t.leg, t.beyond, w.gl, o.Fl_tilde, o.Fr_tilde, w.F, o.tau)
    for i in range(out.shape[0]):
        if not np.isfinite(out[i]):
            return NONFINITE_RESULT
    return OK
