"""W's swing law (:func:`biped.control.swing.swing_leg_torques`) compiled: one numba call a
control period, MuJoCo's ``mj_jacBody`` and ``mj_fullM`` called through their C functions
(:mod:`biped.control.mj_functions`; their addresses as integers), every array preallocated (:class:`SwingLaw`).

The law, for foot ``i``'s leg (W's order: hip abduction, flexion, rotation, knee, ankle
inversion, dorsiflexion): the ankle point follows (pd, vd, ad) by task-space computed torque on
abduction, flexion and knee, ``qdd_t = J3^T (J3 J3^T + 1e-4 I)^-1 (a - J_h qdd_h)``,
``a = ad + kp_pos (pd - p) + kv_pos (vd - v)`` (p, v the foot body's origin and its velocity in
the world, J3 / J_h its position Jacobian's columns of those joints / the held ones); hip
rotation is held at 0 and the two ankle hinges at the angles that put the sole flat with zero
yaw, ``qdd_h = kp_rot (q_h* - q_h) - kv_rot q_h'``; ``tau = M_ll qdd + b_l - p_l`` (the leg's
block of the mass matrix, its bias and passive forces); the ankle hinges instead by a stiff PD
on the foot's world angular velocity, ``ankle_kp (q* - q) - ankle_kv w + b``; all clipped to
``swing_torque_max_n_m``. The 3 x 3 system is solved by Cholesky (it is symmetric positive
definite), the products summed in index order: the Python loop and the compiled loop call this
same kernel, so both give the same torques bit for bit (they need not equal NumPy's BLAS).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from biped._numba_cache import compile_once, key_by_sources
from biped.control import mj_functions
from biped.control.mj_functions import call_fullm, call_jac, mj_address

__all__ = ["NG", "SwingLaw", "compile_law", "law", "swing_law"]

#: gains (the law's float parameters), in this order
G_KP_POS, G_KV_POS, G_KP_ROT, G_KV_ROT, G_ANKLE_KP, G_ANKLE_KV, G_MAX = range(7)
NG = 7


@njit(cache=True)
def law(
    jac, fullm, m, d, foot, shank, inv_sign, dofs, qadr, qpos, qvel, xpos, xmat, bias, passive, jp, jr, mm, g,
    pd, vd, ad, tau,
):  # fmt: skip  # pragma: no cover - compiled
    """W's swing law (the module's; ``jac``, ``fullm`` the addresses of MuJoCo's ``mj_jacBody``,
    ``mj_fullM``, ``m``, ``d`` of its model and data) for the foot body ``foot`` (shank body ``shank``, inversion
    sign ``inv_sign``, the leg's 6 dofs ``dofs`` and qpos addresses ``qadr``) into ``tau`` (6,);
    ``jp``, ``jr`` (3, nv) and ``mm`` (nv, nv) scratch, each written whole by MuJoCo."""
    call_jac(jac, m, d, jp.ctypes.data, jr.ctypes.data, np.int64(foot))
    call_fullm(fullm, m, d, mm.ctypes.data)
    # the flat foot's ankle angles from the shank's orientation (R = X^T, X = xmat row-major)
    x = xmat[shank]
    inv = inv_sign * math.atan2(x[5], x[4])
    dors = math.atan2(x[6], x[0])
    qdd = np.zeros(6)
    q = np.empty(6)
    qd = np.empty(6)
    for k in range(6):
        q[k] = qpos[qadr[k]]
        qd[k] = qvel[dofs[k]]
    qdd[2] = g[G_KP_ROT] * (0.0 - q[2]) - g[G_KV_ROT] * qd[2]
    qdd[4] = g[G_KP_ROT] * (inv - q[4]) - g[G_KV_ROT] * qd[4]
    qdd[5] = g[G_KP_ROT] * (dors - q[5]) - g[G_KV_ROT] * qd[5]
    nv = qvel.shape[0]
    a = np.empty(3)
    w = np.zeros(3)
    for r in range(3):
        v = 0.0
        for c in range(nv):
            v += jp[r, c] * qvel[c]
            w[r] += jr[r, c] * qvel[c]
        held = jp[r, dofs[2]] * qdd[2] + jp[r, dofs[4]] * qdd[4] + jp[r, dofs[5]] * qdd[5]
        a[r] = ad[r] + g[G_KP_POS] * (pd[r] - xpos[foot, r]) + g[G_KV_POS] * (vd[r] - v) - held
    # J3 = the columns of abduction, flexion, knee; A = J3 J3^T + 1e-4 I by Cholesky
    task = (dofs[0], dofs[1], dofs[3])
    A = np.empty((3, 3))
    for r in range(3):
        for c in range(3):
            s = 0.0
            for k in range(3):
                s += jp[r, task[k]] * jp[c, task[k]]
            A[r, c] = s
        A[r, r] += 1e-4
    L = np.zeros((3, 3))
    for r in range(3):
        for c in range(r + 1):
            s = A[r, c]
            for k in range(c):
                s -= L[r, k] * L[c, k]
            L[r, c] = math.sqrt(s) if r == c else s / L[c, c]
    y = np.empty(3)
    for r in range(3):
        s = a[r]
        for k in range(r):
            s -= L[r, k] * y[k]
        y[r] = s / L[r, r]
    for r in range(2, -1, -1):
        s = y[r]
        for k in range(r + 1, 3):
            s -= L[k, r] * y[k]
        y[r] = s / L[r, r]
    qdd[0] = jp[0, task[0]] * y[0] + jp[1, task[0]] * y[1] + jp[2, task[0]] * y[2]
    qdd[1] = jp[0, task[1]] * y[0] + jp[1, task[1]] * y[1] + jp[2, task[1]] * y[2]
    qdd[3] = jp[0, task[2]] * y[0] + jp[1, task[2]] * y[1] + jp[2, task[2]] * y[2]
    for r in range(6):
        s = 0.0
        for c in range(6):
            s += mm[dofs[r], dofs[c]] * qdd[c]
        tau[r] = s + bias[dofs[r]] - passive[dofs[r]]
    tau[4] = g[G_ANKLE_KP] * (inv - q[4]) - g[G_ANKLE_KV] * (inv_sign * w[0]) + bias[dofs[4]]
    tau[5] = g[G_ANKLE_KP] * (dors - q[5]) - g[G_ANKLE_KV] * w[1] + bias[dofs[5]]
    for r in range(6):
        tau[r] = min(max(tau[r], -g[G_MAX]), g[G_MAX])


key_by_sources(law, (mj_functions,))


@njit(cache=True)
def swing_law(
    jac, fullm, m, d, foot, shank, inv_sign, dofs, qadr, qpos, qvel, xpos, xmat, bias, passive, jp, jr, mm, g,
    pd, vd, ad, tau,
):  # fmt: skip  # pragma: no cover - compiled
    """:func:`law` for its one signature (the Python loop's entry point; :func:`law` itself stays
    generic, so the compiled push loop compiles it in for its own argument types,
    :mod:`biped.sim.fused_step`)."""
    law(jac, fullm, m, d, foot, shank, inv_sign, dofs, qadr, qpos, qvel, xpos, xmat, bias, passive, jp, jr, mm, g,
        pd, vd, ad, tau)  # fmt: skip


key_by_sources(swing_law, (mj_functions,))


class SwingLaw:
    """:func:`swing_law` bound to a stepping controller's model and data (its buffers made once):
    ``law(i, pd, vd, ad)`` -> the swing torques (6,) of foot ``i`` (a new array)."""

    def __init__(self, ctl):
        m, d, s = ctl.model, ctl.data, ctl.stepping
        jac, fullm = mj_address("mj_jacBody"), mj_address("mj_fullM")
        nv = m.nv
        self._keep = (m, d)  # the addresses below point into them
        self.jp, self.jr, self.mm = np.zeros((3, nv)), np.zeros((3, nv)), np.zeros((nv, nv))
        self.g = np.array(
            [s.kp_pos, s.kv_pos, s.kp_rot, s.kv_rot, s.ankle_kp, s.ankle_kv, s.swing_torque_max_n_m],
            dtype=float,
        )
        self.legs = [
            (
                int(ctl._foot[i]),
                int(ctl._shank[i]),
                float(ctl._inv_sign[i]),
                np.ascontiguousarray(ctl._leg_dofs[i], dtype=np.int64),
                np.ascontiguousarray(ctl._leg_qpos[i], dtype=np.int64),
            )
            for i in range(2)
        ]
        self.head = (jac, fullm, int(m._address), int(d._address))
        self.data = (
            d.qpos,
            d.qvel,
            d.xpos,
            d.xmat,
            d.qfrc_bias,
            d.qfrc_passive,
            self.jp,
            self.jr,
            self.mm,
            self.g,
        )
        compile_law()
        self._call: Any = swing_law
        if hasattr(swing_law, "overloads"):  # the compiled entry point: no typing of the arguments each call
            self._call = swing_law.overloads[swing_law.signatures[0]].entry_point  # type: ignore[attr-defined]

    def __call__(self, i, pd, vd, ad) -> np.ndarray:
        tau = np.empty(6)
        self._call(*self.head, *self.legs[i], *self.data, _vec(pd), _vec(vd), _vec(ad), tau)
        return tau


def _vec(x) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.float64)


def _signature():
    from numba import types

    f1, f2 = types.float64[::1], types.float64[:, ::1]
    i1 = types.int64[::1]
    return types.void(
        types.uintp, types.uintp, types.uintp, types.uintp,
        types.int64, types.int64, types.float64, i1, i1,
        f1, f1, f2, f2, f1, f1, f2, f2, f2, f1,
        f1, f1, f1, f1,
    )  # fmt: skip


_SIGNATURE = _signature()


def compile_law() -> None:
    """Compile :func:`swing_law` for its one signature (or load it from numba's cache); a no-op
    once done (:mod:`biped.sim.jit` warms it up before a stepping run)."""
    compile_once(swing_law, _SIGNATURE)
