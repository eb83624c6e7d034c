"""Spatial algebra in one convention (Murray, Li & Sastry 1994, as used by Wendlandt 1997).

- A rigid transform ``g = (R, p)`` maps coordinates in frame K to frame J (``g_{j,k}``, W eq. 3.1).
- Twists are ``[v; w]`` (linear on top), wrenches are ``[f; tau]`` (force on top).
- ``Ad_g = [[R, p^ R], [0, R]]`` (W eq. 3.7); twists map as ``V_j = Ad_{g_{j,k}} V_k`` and
  wrenches as ``F_k = Ad_{g_{j,k}}^T F_j`` (W eq. 3.8).
- ``ad_V = [[w^, v^], [0, w^]]`` is the twist cross product; ``d/dt Ad`` and velocity-product
  accelerations are written with it.
- Quaternions are ``(w, x, y, z)`` with the scalar first, Hamilton product, as MuJoCo stores them.

Every function is compiled with numba and callable from Python and from other compiled code.
The ``*_into`` forms write into a given output and allocate nothing (the controller's hot path).
The products at the end (``adjoint_mul`` ... ``cholesky6_solve``) are the steps W's Alg. 1-6
repeat, inlined into the compiled recursions: they apply ``Ad_g`` and its relatives to a 6-vector
or a 6x6 matrix without forming ``Ad_g``, and never allocate. Each keeps one fixed order of
floating-point operations, so the controller's numbers do not depend on how it is composed.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: a 3-vector: an array or, inside the compiled kernel, a tuple of three floats (no allocation)
Vec3 = np.ndarray | tuple[float, float, float]

__all__ = [
    "ad",
    "ad_into",
    "adjoint",
    "adjoint_T_mul",
    "adjoint_into",
    "adjoint_inv_T_mul",
    "adjoint_inv_congruence_add",
    "adjoint_inv_mul",
    "adjoint_mul",
    "axis_angle_quat",
    "cholesky6_solve",
    "compose",
    "cross",
    "dot6",
    "hat",
    "inverse",
    "mat6_mul_vec",
    "mat6_mul_vec_add",
    "quat_conj",
    "quat_mul",
    "quat_to_rot",
    "rot_T_mul",
    "rot_mul",
    "rot_to_quat",
    "transform",
    "vee",
]


@njit(cache=True)
def hat(w: np.ndarray) -> np.ndarray:
    """(3,) -> (3, 3) skew matrix with ``hat(w) @ v == cross(w, v)``."""
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


@njit(cache=True)
def vee(S: np.ndarray) -> np.ndarray:
    """(3, 3) skew matrix -> (3,) vector; inverse of :func:`hat`."""
    return np.array([S[2, 1], S[0, 2], S[1, 0]])


@njit(cache=True)
def quat_to_rot_into(q: np.ndarray, R: np.ndarray) -> None:
    """Unit quaternion ``(w, x, y, z)`` -> rotation matrix, written into ``R`` (3, 3)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    n = w * w + x * x + y * y + z * z
    s = 2.0 / n
    R[0, 0] = 1.0 - s * (y * y + z * z)
    R[0, 1] = s * (x * y - w * z)
    R[0, 2] = s * (x * z + w * y)
    R[1, 0] = s * (x * y + w * z)
    R[1, 1] = 1.0 - s * (x * x + z * z)
    R[1, 2] = s * (y * z - w * x)
    R[2, 0] = s * (x * z - w * y)
    R[2, 1] = s * (y * z + w * x)
    R[2, 2] = 1.0 - s * (x * x + y * y)


@njit(cache=True)
def quat_to_rot(q: np.ndarray) -> np.ndarray:
    """Unit quaternion ``(w, x, y, z)`` -> (3, 3) rotation matrix."""
    R = np.empty((3, 3))
    quat_to_rot_into(q, R)
    return R


@njit(cache=True)
def rot_to_quat(R: np.ndarray) -> np.ndarray:
    """(3, 3) rotation matrix -> unit quaternion ``(w, x, y, z)`` with ``w >= 0`` (Shepperd)."""
    q = np.empty(4)
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    if tr > 0.0:
        s = 2.0 * np.sqrt(1.0 + tr)
        q[0] = 0.25 * s
        q[1] = (R[2, 1] - R[1, 2]) / s
        q[2] = (R[0, 2] - R[2, 0]) / s
        q[3] = (R[1, 0] - R[0, 1]) / s
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = 2.0 * np.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        q[0] = (R[2, 1] - R[1, 2]) / s
        q[1] = 0.25 * s
        q[2] = (R[0, 1] + R[1, 0]) / s
        q[3] = (R[0, 2] + R[2, 0]) / s
    elif R[1, 1] > R[2, 2]:
        s = 2.0 * np.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2])
        q[0] = (R[0, 2] - R[2, 0]) / s
        q[1] = (R[0, 1] + R[1, 0]) / s
        q[2] = 0.25 * s
        q[3] = (R[1, 2] + R[2, 1]) / s
    else:
        s = 2.0 * np.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1])
        q[0] = (R[1, 0] - R[0, 1]) / s
        q[1] = (R[0, 2] + R[2, 0]) / s
        q[2] = (R[1, 2] + R[2, 1]) / s
        q[3] = 0.25 * s
    if q[0] < 0.0:
        q *= -1.0
    return q / np.sqrt(np.sum(q * q))


@njit(cache=True)
def quat_mul_into(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """Hamilton product ``a * b`` of ``(w, x, y, z)`` quaternions, written into ``out``."""
    w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3]
    x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2]
    y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1]
    z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z


@njit(cache=True)
def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` (the rotation ``R(a) @ R(b)``)."""
    out = np.empty(4)
    quat_mul_into(a, b, out)
    return out


@njit(cache=True)
def quat_conj(q: np.ndarray) -> np.ndarray:
    """Conjugate ``(w, -x, -y, -z)``: the inverse rotation of a unit quaternion."""
    return np.array([q[0], -q[1], -q[2], -q[3]])


def axis_angle_quat(axis: Vec3, angle: float) -> np.ndarray:
    """Unit quaternion ``(w, x, y, z)`` of a rotation by ``angle`` [rad] about ``axis`` (3,)."""
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    return np.concatenate([[np.cos(angle / 2.0)], np.sin(angle / 2.0) * axis])


@njit(cache=True)
def adjoint_into(R: np.ndarray, p: np.ndarray, A: np.ndarray) -> None:
    """``Ad_g`` of ``g = (R, p)``, W eq. 3.7, written into ``A`` (6, 6)."""
    for i in range(3):
        for j in range(3):
            A[i, j] = R[i, j]
            A[i + 3, j + 3] = R[i, j]
            A[i + 3, j] = 0.0
            # (p^ R)_{ij} = sum_k p^_{ik} R_{kj}
    for j in range(3):
        A[0, j + 3] = -p[2] * R[1, j] + p[1] * R[2, j]
        A[1, j + 3] = p[2] * R[0, j] - p[0] * R[2, j]
        A[2, j + 3] = -p[1] * R[0, j] + p[0] * R[1, j]


@njit(cache=True)
def adjoint(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``Ad_g`` (6, 6) of ``g = (R, p)``, W eq. 3.7: maps twists of frame K to frame J."""
    A = np.empty((6, 6))
    adjoint_into(R, p, A)
    return A


@njit(cache=True)
def ad_into(V: np.ndarray, out: np.ndarray) -> None:
    """``ad_V = [[w^, v^], [0, w^]]`` of a twist ``V = [v; w]``, written into ``out`` (6, 6)."""
    v0, v1, v2, w0, w1, w2 = V[0], V[1], V[2], V[3], V[4], V[5]
    for i in range(6):
        for j in range(6):
            out[i, j] = 0.0
    for off in (0, 3):
        out[off + 0, off + 1] = -w2
        out[off + 0, off + 2] = w1
        out[off + 1, off + 0] = w2
        out[off + 1, off + 2] = -w0
        out[off + 2, off + 0] = -w1
        out[off + 2, off + 1] = w0
    out[0, 4] = -v2
    out[0, 5] = v1
    out[1, 3] = v2
    out[1, 5] = -v0
    out[2, 3] = -v1
    out[2, 4] = v0


@njit(cache=True)
def ad(V: np.ndarray) -> np.ndarray:
    """``ad_V`` (6, 6): ``ad_V W`` is the Lie bracket of twists ``[V, W]``."""
    out = np.empty((6, 6))
    ad_into(V, out)
    return out


def transform(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """4x4 homogeneous matrix of ``g = (R, p)`` (W eq. 3.1)."""
    g = np.eye(4)
    g[:3, :3] = R
    g[:3, 3] = p
    return g


def inverse(g: np.ndarray) -> np.ndarray:
    """Inverse of a 4x4 rigid transform, W eq. 3.2."""
    R, p = g[:3, :3], g[:3, 3]
    return transform(R.T, -R.T @ p)


def compose(*gs: np.ndarray) -> np.ndarray:
    """Product ``g_1 g_2 ... g_n`` of 4x4 rigid transforms."""
    out = np.eye(4)
    for g in gs:
        out = out @ g
    return out


# ----------------------------------------------------------------------------- inlined products
# Arguments are arrays (or tuples for the 3-vectors); ``out`` must not alias an input.


@njit(cache=True, inline="always")
def cross(a: Vec3, b: Vec3) -> tuple[float, float, float]:
    """``a x b`` of two 3-vectors (arrays or tuples), returned as a tuple (allocates nothing)."""
    return a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]


@njit(cache=True, inline="always")
def rot_mul(R: np.ndarray, x: Vec3) -> tuple[float, float, float]:
    """``R x`` for a (3, 3) matrix and a 3-vector, returned as a tuple."""
    return (
        R[0, 0] * x[0] + R[0, 1] * x[1] + R[0, 2] * x[2],
        R[1, 0] * x[0] + R[1, 1] * x[1] + R[1, 2] * x[2],
        R[2, 0] * x[0] + R[2, 1] * x[1] + R[2, 2] * x[2],
    )


@njit(cache=True, inline="always")
def rot_T_mul(R: np.ndarray, x: Vec3) -> tuple[float, float, float]:
    """``R^T x`` for a (3, 3) matrix and a 3-vector, returned as a tuple."""
    return (
        R[0, 0] * x[0] + R[1, 0] * x[1] + R[2, 0] * x[2],
        R[0, 1] * x[0] + R[1, 1] * x[1] + R[2, 1] * x[2],
        R[0, 2] * x[0] + R[1, 2] * x[1] + R[2, 2] * x[2],
    )


@njit(cache=True, inline="always")
def adjoint_mul(R: np.ndarray, p: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """``out = Ad_g x = [R v + p x (R w); R w]`` for ``g = (R, p)`` (W eq. 3.6-3.7): the twist
    ``x = [v; w]`` of frame K in frame J when ``g = g_{j,k}``."""
    w0, w1, w2 = rot_mul(R, x[3:])
    v0, v1, v2 = rot_mul(R, x[:3])
    out[0] = v0 + p[1] * w2 - p[2] * w1
    out[1] = v1 + p[2] * w0 - p[0] * w2
    out[2] = v2 + p[0] * w1 - p[1] * w0
    out[3] = w0
    out[4] = w1
    out[5] = w2


@njit(cache=True, inline="always")
def adjoint_inv_mul(R: np.ndarray, p: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """``out = Ad_g^-1 x = Ad_{g^-1} x`` for ``g = (R, p)``, with ``g^-1 = (R^T, -R^T p)``
    (W eq. 3.2): the twist ``x`` of frame J in frame K when ``g = g_{j,k}``."""
    q0, q1, q2 = rot_T_mul(R, p)
    q0, q1, q2 = -q0, -q1, -q2
    w0, w1, w2 = rot_T_mul(R, x[3:])
    v0, v1, v2 = rot_T_mul(R, x[:3])
    out[0] = v0 + q1 * w2 - q2 * w1
    out[1] = v1 + q2 * w0 - q0 * w2
    out[2] = v2 + q0 * w1 - q1 * w0
    out[3] = w0
    out[4] = w1
    out[5] = w2


@njit(cache=True, inline="always")
def adjoint_T_mul(R: np.ndarray, p: np.ndarray, F: np.ndarray, out: np.ndarray) -> None:
    """``out = Ad_g^T F = [R^T f; R^T (tau - p x f)]`` for ``g = (R, p)`` (W eq. 3.8): the wrench
    ``F = [f; tau]`` of frame J in frame K when ``g = g_{j,k}``."""
    t0 = F[3] - (p[1] * F[2] - p[2] * F[1])
    t1 = F[4] - (p[2] * F[0] - p[0] * F[2])
    t2 = F[5] - (p[0] * F[1] - p[1] * F[0])
    out[0], out[1], out[2] = rot_T_mul(R, F[:3])
    out[3], out[4], out[5] = rot_T_mul(R, (t0, t1, t2))


@njit(cache=True, inline="always")
def adjoint_inv_T_mul(R: np.ndarray, p: np.ndarray, F: np.ndarray, out: np.ndarray) -> None:
    """``out = Ad_g^-T F = [R f; R tau + p x (R f)]`` for ``g = (R, p)``: the wrench ``F`` of
    frame K in frame J when ``g = g_{j,k}`` (W eq. 3.8 with ``Ad^T_{g_{k,j}} = Ad^-T_{g_{j,k}}``)."""
    f0, f1, f2 = rot_mul(R, F[:3])
    out[0] = f0
    out[1] = f1
    out[2] = f2
    out[3] = R[0, 0] * F[3] + R[0, 1] * F[4] + R[0, 2] * F[5] + p[1] * f2 - p[2] * f1
    out[4] = R[1, 0] * F[3] + R[1, 1] * F[4] + R[1, 2] * F[5] + p[2] * f0 - p[0] * f2
    out[5] = R[2, 0] * F[3] + R[2, 1] * F[4] + R[2, 2] * F[5] + p[0] * f1 - p[1] * f0


@njit(cache=True, inline="always")
def adjoint_inv_congruence_add(
    R: np.ndarray, p: np.ndarray, M: np.ndarray, out: np.ndarray, Q: np.ndarray, S: np.ndarray
) -> None:
    """``out += Ad_g^-T M Ad_g^-1`` for ``g = (R, p)`` and a symmetric (6, 6) ``M``: the inertia
    ``M`` of frame K added in frame J when ``g = g_{j,k}`` (``A^T M A`` with ``A = Ad_{g_{k,j}}``,
    W Alg. 3). Scratch ``Q`` (6, 6) and ``S`` (3, 3).

    With ``Ad_g^-T = [[I, 0], [p^, I]] blockdiag(R, R)``: first ``Q = blockdiag(R, R) M
    blockdiag(R, R)^T`` (blocks 11, 12, 22), then the shift by ``p``: ``B11 = Q11``,
    ``B12 = Q12 - Q11 p^ = S``, ``B22 = Q22 + p^ Q12 - S^T p^``, ``B21 = B12^T``.
    """
    r00, r01, r02 = R[0, 0], R[0, 1], R[0, 2]
    r10, r11, r12 = R[1, 0], R[1, 1], R[1, 2]
    r20, r21, r22 = R[2, 0], R[2, 1], R[2, 2]
    px, py, pz = p[0], p[1], p[2]
    for blk in range(3):  # Q_blk = R M_blk R^T, through S = M_blk R^T
        bi = 0 if blk < 2 else 3
        bj = 0 if blk == 0 else 3
        for i in range(3):
            m0, m1, m2 = M[bi + i, bj], M[bi + i, bj + 1], M[bi + i, bj + 2]
            S[i, 0] = m0 * r00 + m1 * r01 + m2 * r02
            S[i, 1] = m0 * r10 + m1 * r11 + m2 * r12
            S[i, 2] = m0 * r20 + m1 * r21 + m2 * r22
        for j in range(3):
            s0, s1, s2 = S[0, j], S[1, j], S[2, j]
            Q[bi, bj + j] = r00 * s0 + r01 * s1 + r02 * s2
            Q[bi + 1, bj + j] = r10 * s0 + r11 * s1 + r12 * s2
            Q[bi + 2, bj + j] = r20 * s0 + r21 * s1 + r22 * s2
    for i in range(3):  # S = B12 = Q12 - Q11 p^
        S[i, 0] = Q[i, 3] - (Q[i, 1] * pz - Q[i, 2] * py)
        S[i, 1] = Q[i, 4] - (Q[i, 2] * px - Q[i, 0] * pz)
        S[i, 2] = Q[i, 5] - (Q[i, 0] * py - Q[i, 1] * px)
    for j in range(3):  # B22 = Q22 + p^ Q12 - S^T p^
        h0 = py * Q[2, 3 + j] - pz * Q[1, 3 + j]
        h1 = pz * Q[0, 3 + j] - px * Q[2, 3 + j]
        h2 = px * Q[1, 3 + j] - py * Q[0, 3 + j]
        if j == 0:
            s0, s1, s2 = S[1, 0] * pz - S[2, 0] * py, S[1, 1] * pz - S[2, 1] * py, S[1, 2] * pz - S[2, 2] * py
        elif j == 1:
            s0, s1, s2 = S[2, 0] * px - S[0, 0] * pz, S[2, 1] * px - S[0, 1] * pz, S[2, 2] * px - S[0, 2] * pz
        else:
            s0, s1, s2 = S[0, 0] * py - S[1, 0] * px, S[0, 1] * py - S[1, 1] * px, S[0, 2] * py - S[1, 2] * px
        out[3, 3 + j] += Q[3, 3 + j] + h0 - s0
        out[4, 3 + j] += Q[4, 3 + j] + h1 - s1
        out[5, 3 + j] += Q[5, 3 + j] + h2 - s2
    for i in range(3):
        for j in range(3):
            out[i, j] += Q[i, j]
            out[i, 3 + j] += S[i, j]
            out[3 + j, i] += S[i, j]


@njit(cache=True, inline="always")
def mat6_mul_vec(M: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """``out = M x`` for a (6, 6) matrix and a 6-vector."""
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += M[i, j] * x[j]
        out[i] = s


@njit(cache=True, inline="always")
def mat6_mul_vec_add(M: np.ndarray, x: np.ndarray, y: np.ndarray, out: np.ndarray) -> None:
    """``out = y + M x`` for a (6, 6) matrix and 6-vectors (``out`` may be ``y``)."""
    for i in range(6):
        s = y[i]
        for j in range(6):
            s += M[i, j] * x[j]
        out[i] = s


@njit(cache=True, inline="always")
def dot6(x: np.ndarray, y: np.ndarray) -> float:
    """``x . y`` of two 6-vectors."""
    s = 0.0
    for i in range(6):
        s += x[i] * y[i]
    return s


@njit(cache=True, inline="always")
def cholesky6_solve(A: np.ndarray, b: np.ndarray, y: np.ndarray) -> bool:
    """Solve ``A y = b`` for a symmetric positive-definite (6, 6) ``A``; ``A`` is overwritten by
    its lower Cholesky factor. Returns False, leaving ``y`` unset, when a pivot is not positive
    to working precision (``A`` not positive definite, or not finite)."""
    for j in range(6):
        s = A[j, j]
        for m in range(j):
            s -= A[j, m] * A[j, m]
        if not (s > 1e-12 * (1.0 + abs(A[j, j]))):
            return False
        A[j, j] = np.sqrt(s)
        for i in range(j + 1, 6):
            s = A[i, j]
            for m in range(j):
                s -= A[i, m] * A[j, m]
            A[i, j] = s / A[j, j]
    for i in range(6):  # L u = b
        s = b[i]
        for m in range(i):
            s -= A[i, m] * y[m]
        y[i] = s / A[i, i]
    for i in range(5, -1, -1):  # L^T y = u
        s = y[i]
        for m in range(i + 1, 6):
            s -= A[m, i] * y[m]
        y[i] = s / A[i, i]
    return True
