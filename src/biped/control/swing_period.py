"""A swing period of the stepping controller (:class:`~biped.control.stepping_swing.SwingPhase`) as
compiled code: the step's landing target, the ankle's path and the stance's feed-forward, one
numba call (:func:`period`), for the Python loop and the compiled push loop alike.

What it does, for a swing of W's body (foot ``i`` swinging, the other standing), the plain swing
only (no crossover or uncrossing path, no closing step, no robot's facing, sole axes or foot
rotation, none of the opt-in stance models: :func:`compiled_swing` says when): the lift-off's
time (the first period the foot is off the floor); the touchdown check (on the floor after half
the swing, once seen off it: :data:`TOUCHDOWN`, the touchdown is Python's); the stance CoP (the
point of the stance sole nearest the COM); the landing point
(:func:`~biped.control.capture.step_target`, retargeted for the first ``retarget_until`` of the
swing); the ankle's minimum-jerk path with its bump and the descent after ``swing_time_s``; the
point pulled back within ``reach_m`` of the hip; the stance's contact flags (both off when the
stance sole is over ``AIRBORNE_M`` up, ``airborne_stance``); the LIPM's acceleration over the
stance CoP, ``omega^2 (com - cop)``, the set point's feed-forward. The same operations as the NumPy
code of :class:`~biped.control.stepping_swing.SwingPhase` (kept for the other swings), but sums of
three products in index order where NumPy's matmul and norm may round otherwise (its results equal
the NumPy code's to rounding, ``tests/test_swing_period.py``). Both loops call this same
code, so a stepping run in the compiled loop is the Python loop's bit for bit.

Arrays (:class:`SwingPlan` fills them): ``prm`` the swing's float parameters (P_*), ``ints`` its
int ones (I_*), ``st`` the carried state (S_*: lift-off time, NaN before; the landing point and
whether it is set; time into the swing), ``pend`` the state after the period, ``out`` (O_*: the
ankle's pd, vd, ad after the reach check, the COM acceleration (2), the swing leg's torques (6)).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, types

from biped._numba_cache import compile_once

__all__ = ["GO", "NO", "NP", "NS", "NW", "TOUCHDOWN", "SwingPlan", "compiled_swing", "period", "plan"]

GO, TOUCHDOWN = 0, 1
# prm: swing time, its start, retarget_until, offset, side margin, the step limits (4), apex,
# descent rate, reach, airborne height (NaN: airborne_stance off), p0 (3), per foot the sole's
# centre in the foot frame (3), half length, half width
P_T, P_T0, P_RETARGET, P_OFFSET, P_SIDE, P_MAX_STEP, P_MIN_W, P_MAX_W, P_MAX_BACK = range(9)
P_APEX, P_DESCENT, P_REACH, P_AIRBORNE, P_P0 = 9, 10, 11, 12, 13
P_SOLE = 16
P_INV = 26  # the swing leg's inversion sign (the swing law's)
NP = 27
# ints: the swinging foot (0, 1), the feet's bodies (2), the swing leg's hip body, shank body;
# its 6 dofs, 6 qpos addresses, 6 torque indices; whether a swing runs compiled (the push loop's)
I_SW, I_FOOT, I_HIP, I_SHANK, I_DOFS, I_QADR, I_TAU, I_ON = 0, 1, 3, 4, 5, 11, 17, 23
NW = 24
S_LIFT, S_HAS_LAND, S_LAND, S_EL = 0, 1, 2, 4
NS = 5
O_PD, O_VD, O_AD, O_ACC, O_TAU = 0, 3, 6, 9, 11
NO = 17


@njit(cache=True, inline="always")
def _min_jerk(s):  # pragma: no cover - compiled
    """:func:`biped.control.capture.min_jerk` (Python's ``x**3`` is C's pow, so math.pow)."""
    if s <= 0.0:
        return 0.0, 0.0, 0.0
    if s >= 1.0:
        return 1.0, 0.0, 0.0
    u = 1.0 - s
    return (
        math.pow(s, 3.0) * (10.0 - 15.0 * s + 6.0 * s * s),
        30.0 * s * s * (u * u),
        60.0 * s * u * (1.0 - 2.0 * s),
    )


@njit(cache=True, inline="always")
def _bump(s):  # pragma: no cover - compiled
    """:func:`biped.control.capture.bump`."""
    if s <= 0.0 or s >= 1.0:
        return 0.0, 0.0, 0.0
    u = 1.0 - s
    s3, u3 = math.pow(s, 3.0), math.pow(u, 3.0)
    return (
        64.0 * s3 * u3,
        192.0 * s * s * u * u * (u - s),
        192.0 * (2.0 * s * u3 - 6.0 * s * s * u * u + 2.0 * s3 * u),
    )


@njit(cache=True)
def period(
    t, down, xi0, xi1, omega, com0, com1, xpos, xmat, prm, ints, st, pend, out, contact
):  # pragma: no cover
    """One swing period up to the controllers (the module's): the state after it into ``pend``,
    the ankle's path, the COM acceleration into ``out``, the stance's flags into ``contact``;
    :data:`GO`, or :data:`TOUCHDOWN` (``down``: the swing foot on the floor; ``com0``, ``com1``
    the whole body's COM)."""
    for j in range(NS):
        pend[j] = st[j]
    i = ints[I_SW]
    s_ = 1 - i
    T = prm[P_T]
    el = t - prm[P_T0]
    if np.isnan(pend[S_LIFT]) and not down:
        pend[S_LIFT] = t
    if down and el > 0.5 * T and not np.isnan(pend[S_LIFT]):
        return TOUCHDOWN
    # the stance sole's centre and yaw (sole_pose), the stance CoP (SwingPhase._stance_cop)
    b = ints[I_FOOT + s_]
    o = P_SOLE + 5 * s_
    c = np.empty(3)
    for r in range(3):
        c[r] = xpos[b, r] + (
            xmat[b, 3 * r] * prm[o] + xmat[b, 3 * r + 1] * prm[o + 1] + xmat[b, 3 * r + 2] * prm[o + 2]
        )
    yaw = math.atan2(xmat[b, 3], xmat[b, 0])
    cy, sy = math.cos(yaw), math.sin(yaw)
    rel0, rel1 = com0 - c[0], com1 - c[1]
    hl, hw = prm[o + 3], prm[o + 4]
    l0 = min(max(cy * rel0 + sy * rel1, -hl), hl)
    l1 = min(max(-sy * rel0 + cy * rel1, -hw), hw)
    cop0 = c[0] + (cy * l0 - sy * l1)
    cop1 = c[1] + (sy * l0 + cy * l1)
    pend[S_EL] = el
    side = 1.0 if i == 1 else -1.0
    if pend[S_HAS_LAND] == 0.0 or el < prm[P_RETARGET] * T:  # capture.step_target
        e = math.exp(omega * max(T - el, 0.0))
        td0, td1 = cop0 + (xi0 - cop0) * e, cop1 + (xi1 - cop1) * e
        d0, d1 = td0 - cop0, td1 - cop1
        rd = math.sqrt(d0 * d0 + d1 * d1)
        land0, land1 = td0, td1
        if rd > 1e-9:
            land0, land1 = td0 + prm[P_OFFSET] * d0 / rd, td1 + prm[P_OFFSET] * d1 / rd
        if prm[P_SIDE] > 0.0:
            land1 = side * max(side * land1, side * td1 + prm[P_SIDE])
        # capture.clamp_step
        rl0, rl1 = land0 - c[0], land1 - c[1]
        lat = min(max(side * rl1, prm[P_MIN_W]), prm[P_MAX_W])
        fwd = min(rl0, prm[P_MAX_BACK])
        rl1 = side * lat
        if math.sqrt(fwd * fwd + rl1 * rl1) > prm[P_MAX_STEP]:
            mx = prm[P_MAX_STEP]
            fwd_max = math.sqrt(max(mx * mx - lat * lat, 0.0))
            fwd = math.copysign(min(abs(fwd), fwd_max), fwd)
        pend[S_LAND], pend[S_LAND + 1] = c[0] + fwd, c[1] + rl1
        pend[S_HAS_LAND] = 1.0
    # the ankle's path: the sole centre lands on the landing point, flat, zero yaw
    oi = P_SOLE + 5 * i
    goal = (pend[S_LAND] - prm[oi], pend[S_LAND + 1] - prm[oi + 1], -prm[oi + 2])
    sc = el / T
    h, hd, hdd = _min_jerk(sc)
    bb, bd, bdd = _bump(sc)
    for k in range(3):
        dk = goal[k] - prm[P_P0 + k]
        out[O_PD + k] = prm[P_P0 + k] + dk * h
        out[O_VD + k] = dk * hd / T
        out[O_AD + k] = dk * hdd / (T * T)
    apex = prm[P_APEX]
    out[O_PD + 2] += apex * bb
    out[O_VD + 2] += apex * bd / T
    out[O_AD + 2] += apex * bdd / (T * T)
    if sc >= 1.0:
        out[O_PD + 2] = goal[2] - prm[P_DESCENT] * (el - T)
        out[O_VD + 2] = -prm[P_DESCENT]
    # out of reach: the nearest point within it
    hp = ints[I_HIP]
    r0, r1, r2 = out[O_PD] - xpos[hp, 0], out[O_PD + 1] - xpos[hp, 1], out[O_PD + 2] - xpos[hp, 2]
    rn = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    if rn > prm[P_REACH]:
        f = prm[P_REACH] / rn
        out[O_PD], out[O_PD + 1], out[O_PD + 2] = (
            xpos[hp, 0] + r0 * f,
            xpos[hp, 1] + r1 * f,
            xpos[hp, 2] + r2 * f,
        )
    contact[0] = 1 if i == 1 else 0
    contact[1] = 1 if i == 0 else 0
    if not np.isnan(prm[P_AIRBORNE]) and c[2] >= prm[P_AIRBORNE]:
        contact[0] = contact[1] = 0
    w2 = omega * omega
    out[O_ACC] = w2 * (com0 - cop0)
    out[O_ACC + 1] = w2 * (com1 - cop1)
    return GO


@njit(cache=True)
def plan(
    t, down, xi0, xi1, omega, com0, com1, xpos, xmat, prm, ints, st, pend, out, contact
):  # pragma: no cover
    """:func:`period` for its one signature (the Python loop's entry point; :func:`period` stays
    generic: the compiled push loop compiles it in, :mod:`biped.sim.fused_step`)."""
    return period(t, down, xi0, xi1, omega, com0, com1, xpos, xmat, prm, ints, st, pend, out, contact)


def compiled_swing(ctl) -> bool:
    """Whether stepping controller ``ctl``'s present swing runs :func:`plan` (W's body, the plain
    swing: see the module)."""
    from biped.control.stepping_swing import SwingPhase
    from biped.control.swing import swing_leg_torques

    s, cls = ctl.stepping, type(ctl)
    return (
        all(
            getattr(cls, n) is getattr(SwingPhase, n)
            for n in ("_swing_call", "_single_support", "_step_target", "_swing_torques", "_stance_cop")
        )
        and ctl.body.swing is swing_leg_torques
        and ctl._facing is None
        and ctl._foot_rot is None
        and ctl._sole_axes is None
        and not ctl._cross
        and not ctl._uncross
        and ctl._closing is None
        and not s.swing_reaction
        and not s.stance_contact_model
        and s.swing_inertia_share is None
        and not s.swing_drop_ramp
        and not s.lateral_swing_drop_ramp
        and s.stance_knee_min_deg is None
        and s.span_leg_m is None
        and not s.reach_on_floor
    )


class SwingPlan:
    """:func:`plan`'s arrays for a stepping controller (made once): :meth:`load` its present
    swing into them, :meth:`store` the state after a period back; ``__call__`` runs a period."""

    def __init__(self):
        self.prm, self.ints = np.zeros(NP), np.zeros(NW, dtype=np.int64)
        self.st, self.pend, self.out = np.zeros(NS), np.zeros(NS), np.zeros(NO)
        self.contact = np.zeros(2, dtype=np.int64)
        compile_plan()
        self._call: Any = plan
        if hasattr(plan, "overloads"):  # the compiled entry point: no typing of the arguments each call
            self._call = plan.overloads[plan.signatures[0]].entry_point  # type: ignore[attr-defined]

    def load(self, ctl) -> None:
        """``ctl``'s swing (parameters and carried state) into the arrays."""
        from biped.control.stepping_swing import AIRBORNE_M

        s, i, prm, ints, st = ctl.stepping, ctl.swing, self.prm, self.ints, self.st
        lim = ctl._limits
        prm[P_T], prm[P_T0], prm[P_RETARGET] = ctl._T, ctl._t_start, s.retarget_until
        prm[P_OFFSET], prm[P_SIDE] = ctl._offset, s.side_margin_m
        prm[P_MAX_STEP], prm[P_MIN_W], prm[P_MAX_W], prm[P_MAX_BACK] = (
            lim.max_step,
            lim.min_width,
            lim.max_width,
            lim.max_back,
        )
        prm[P_APEX], prm[P_DESCENT], prm[P_REACH] = s.apex_m, s.descent_m_s, s.reach_m
        prm[P_AIRBORNE] = AIRBORNE_M if s.airborne_stance else np.nan
        prm[P_P0 : P_P0 + 3] = ctl._p0
        for k in range(2):
            off, hl, hw = ctl._sole[k]
            prm[P_SOLE + 5 * k : P_SOLE + 5 * k + 5] = (*off, hl, hw)
        prm[P_INV] = ctl._inv_sign[i]
        ints[I_SW] = i
        ints[I_FOOT], ints[I_FOOT + 1] = ctl._foot
        ints[I_HIP], ints[I_SHANK] = ctl._hip[i], ctl._shank[i]
        ints[I_DOFS : I_DOFS + 6] = ctl._leg_dofs[i]
        ints[I_QADR : I_QADR + 6] = ctl._leg_qpos[i]
        ints[I_TAU : I_TAU + 6] = ctl._leg_tau[i]
        lift = ctl.steps[-1]["lift_off_s"]
        st[S_LIFT] = np.nan if lift is None else lift
        st[S_HAS_LAND] = 0.0 if ctl._landing is None else 1.0
        if ctl._landing is not None:
            st[S_LAND : S_LAND + 2] = ctl._landing[:2]
        st[S_EL] = ctl._swing_el

    def store(self, ctl, st) -> None:
        """The state ``st`` (after a period) back into ``ctl``: the lift-off, the landing point
        (and the step's ``target_m``), the time into the swing."""
        step = ctl.steps[-1]
        if not np.isnan(st[S_LIFT]):
            step["lift_off_s"] = float(st[S_LIFT])
        if st[S_HAS_LAND] != 0.0:
            land = st[S_LAND : S_LAND + 2].copy()
            if ctl._landing is None or not np.array_equal(land, ctl._landing):
                ctl._landing = land
            step["target_m"] = [float(land[0]), float(land[1]), 0.0]
        ctl._swing_el = float(st[S_EL])

    def __call__(self, ctl, t, down, xi, omega) -> int:
        """One period of ``ctl``'s swing (its data after the period's forward pass): GO (the ankle's
        path and the COM acceleration in ``out``, the flags in ``contact``, the state stored
        into ``ctl``) or TOUCHDOWN (the lift-off stored)."""
        self.load(ctl)
        d = ctl.data
        com = d.subtree_com[0]
        code = self._call(
            float(t), bool(down), float(xi[0]), float(xi[1]), float(omega), float(com[0]), float(com[1]),
            d.xpos, d.xmat, self.prm, self.ints, self.st, self.pend, self.out, self.contact,
        )  # fmt: skip
        self.store(ctl, self.pend)
        return int(code)


def _signature():
    f1, f2, i1 = types.float64[::1], types.float64[:, ::1], types.int64[::1]
    f = types.float64
    return types.int64(f, types.boolean, f, f, f, f, f, f2, f2, f1, i1, f1, f1, f1, i1)


_SIGNATURE = _signature()


def compile_plan() -> None:
    """Compile :func:`plan` for its one signature (or load it from numba's cache); a no-op once done."""
    compile_once(plan, _SIGNATURE)
