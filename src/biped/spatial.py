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
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = [
    "hat", "vee", "quat_to_rot", "rot_to_quat", "quat_mul", "quat_conj", "axis_angle_quat",
    "adjoint", "adjoint_into", "ad", "ad_into", "transform", "inverse", "compose",
]


@njit(cache=True)
def hat(w):
    """(3,) -> (3, 3) skew matrix with ``hat(w) @ v == cross(w, v)``."""
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


@njit(cache=True)
def vee(S):
    """(3, 3) skew matrix -> (3,) vector; inverse of :func:`hat`."""
    return np.array([S[2, 1], S[0, 2], S[1, 0]])


@njit(cache=True)
def quat_to_rot_into(q, R):
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
def quat_to_rot(q):
    """Unit quaternion ``(w, x, y, z)`` -> (3, 3) rotation matrix."""
    R = np.empty((3, 3))
    quat_to_rot_into(q, R)
    return R


@njit(cache=True)
def rot_to_quat(R):
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
def quat_mul_into(a, b, out):
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
def quat_mul(a, b):
    """Hamilton product ``a * b`` (the rotation ``R(a) @ R(b)``)."""
    out = np.empty(4)
    quat_mul_into(a, b, out)
    return out


@njit(cache=True)
def quat_conj(q):
    """Conjugate ``(w, -x, -y, -z)``: the inverse rotation of a unit quaternion."""
    return np.array([q[0], -q[1], -q[2], -q[3]])


def axis_angle_quat(axis, angle: float) -> np.ndarray:
    """Unit quaternion ``(w, x, y, z)`` of a rotation by ``angle`` [rad] about ``axis`` (3,)."""
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    return np.concatenate([[np.cos(angle / 2.0)], np.sin(angle / 2.0) * axis])


@njit(cache=True)
def adjoint_into(R, p, A):
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
def adjoint(R, p):
    """``Ad_g`` (6, 6) of ``g = (R, p)``, W eq. 3.7: maps twists of frame K to frame J."""
    A = np.empty((6, 6))
    adjoint_into(R, p, A)
    return A


@njit(cache=True)
def ad_into(V, out):
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
def ad(V):
    """``ad_V`` (6, 6): ``ad_V W`` is the Lie bracket of twists ``[V, W]``."""
    out = np.empty((6, 6))
    ad_into(V, out)
    return out


def transform(R, p) -> np.ndarray:
    """4x4 homogeneous matrix of ``g = (R, p)`` (W eq. 3.1)."""
    g = np.eye(4)
    g[:3, :3] = R
    g[:3, 3] = p
    return g


def inverse(g) -> np.ndarray:
    """Inverse of a 4x4 rigid transform, W eq. 3.2."""
    R, p = g[:3, :3], g[:3, 3]
    return transform(R.T, -R.T @ p)


def compose(*gs) -> np.ndarray:
    """Product ``g_1 g_2 ... g_n`` of 4x4 rigid transforms."""
    out = np.eye(4)
    for g in gs:
        out = out @ g
    return out
