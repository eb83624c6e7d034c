"""The stepping controller's double support as compiled code, for the compiled push loop.

:class:`~biped.control.stepping.SteppingController` spends most of a run in double support: before
its first step exactly the feet-in-place controller, after a touchdown W's controller over the new
feet. Each such control period it computes the capture point and its filtered rate, updates the
step trigger (:class:`~biped.control.capture.CaptureTrigger` and the dwell rule), may switch to the
settling controller, picks the contact flags and calls W's controller. :func:`double_support` does
everything before that call from the biped's whole-body COM and foot poses (MuJoCo's
``subtree_com``, ``subtree_linvel``, ``xpos``, ``xmat`` of the policy's own model); the compiled
loop (:mod:`biped.sim.fused_step`) then calls W's controller itself. Anything else (a step
starting, the settling switch, a state it cannot decide) is handed back to the Python controller
for that period (:data:`HAND_BACK`), which then runs it as it always does.

Exactness. The state carried from period to period (the capture point, its filtered rate, the
trigger's count and armed flag, the dwell start, the settled flag) is the controller's, loaded
before and stored after each compiled stretch (:func:`load`, :func:`store`); the capture point
and its rate are computed with the same floating-point operations in the same order as
``SteppingController.__call__``, so they are equal bit for bit. The support polygon (convex hull
of the sole corners) and the distances compared with the trigger's thresholds are computed here
in their own order (numpy's hull snaps to a grid, its matmul and norms may round differently in
the last bits, ~1e-16 m): every comparison whose quantity lies within :data:`EPS` (1e-9 m or
m/s) of its threshold hands the period back, so each decision (a boolean, the trigger's count)
is the Python controller's. ``tests/test_step_trigger.py`` drives both with the same random
states and compares every decision and the state after each period; ``tests/test_sim_fused_step.py``
compares whole stepping runs.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["EPS", "GO", "HAND_BACK", "NI", "NQ", "NS", "capture", "double_support", "load", "params", "store"]

#: what :func:`double_support` says: W's controller may run the period with ``contact``; or not
GO, HAND_BACK = 0, 1
#: decisions closer than this to their threshold go back to Python [m, m/s]
EPS = 1e-9
#: a foot counts in the support polygon while its sole centre is below this [m]
#: (``SteppingController._polygon``'s literal)
POLYGON_Z_M = 0.02
#: the lowest COM height of omega_0 (``SteppingController.__call__``'s literal) [m]
MIN_HEIGHT_M = 0.05

# the state (st, pend): capture point (2), whether it is set, the previous call's time, the
# rate (2), the dwell start (NaN: None), the trigger's count and armed flag, settled
S_XI, S_HAS_XI, S_T_PREV, S_RATE, S_DWELL, S_COUNT, S_ARMED, S_SETTLED = 0, 2, 3, 4, 6, 7, 8, 9
NS = 10
# the float parameters (prm); NaN: None
Q_G, Q_TAU, Q_MARGIN, Q_REARM, Q_LATERAL, Q_MIN_RATE, Q_DWELL_M, Q_DWELL_S = range(8)
Q_REFRACTORY, Q_LAST_TD, Q_ARM, Q_SETTLE_AFTER, Q_SETTLE_SPEED, Q_AIRBORNE, Q_PERIOD = range(8, 15)
Q_SOLE = 15  # per foot: the sole centre in the foot body's frame (3), half length, half width
Q_CLOSE_SPEED = 25  # the closing step's at-rest speed
NQ = 26
# the int parameters (ints): the foot bodies, hold, the trigger on (fewer steps than max_steps),
# the settling check on, the contact flags' rule, a closing step's check pending
I_F0, I_F1, I_HOLD, I_TRIGGER, I_SETTLE, I_FLAGS, I_CLOSE = range(7)
NI = 7
FLAGS_BOTH, FLAGS_SENSED, FLAGS_AIRBORNE = 0, 1, 2


@njit(cache=True, inline="always")
def _sole(xpos, xmat, b, prm, i, out):  # pragma: no cover - compiled
    """Sole ``i``'s centre (world) into out[0:3], its yaw into out[3] (``_sole_pose``)."""
    o = Q_SOLE + 5 * i
    for r in range(3):
        rot = xmat[b, 3 * r] * prm[o] + xmat[b, 3 * r + 1] * prm[o + 1] + xmat[b, 3 * r + 2] * prm[o + 2]
        out[r] = xpos[b, r] + rot
    out[3] = math.atan2(xmat[b, 3], xmat[b, 0])


@njit(cache=True)
def _excess(poles, npts, xi0, xi1):  # pragma: no cover - compiled
    """(signed distance of xi to the convex hull of ``poles[:npts]``, its y excess): capture.excess."""
    # Andrew's monotone chain on the sorted, distinct points
    pts = np.empty((npts, 2))
    n = 0
    for i in range(npts):
        pts[n, 0], pts[n, 1] = poles[i, 0], poles[i, 1]
        n += 1
    for i in range(1, n):  # insertion sort by (x, y)
        j = i
        while j > 0 and (
            pts[j, 0] < pts[j - 1, 0] or (pts[j, 0] == pts[j - 1, 0] and pts[j, 1] < pts[j - 1, 1])
        ):
            a0, a1 = pts[j, 0], pts[j, 1]
            pts[j, 0], pts[j, 1] = pts[j - 1, 0], pts[j - 1, 1]
            pts[j - 1, 0], pts[j - 1, 1] = a0, a1
            j -= 1
    m = 0
    for i in range(n):  # drop duplicates
        if m == 0 or pts[i, 0] != pts[m - 1, 0] or pts[i, 1] != pts[m - 1, 1]:
            pts[m, 0], pts[m, 1] = pts[i, 0], pts[i, 1]
            m += 1
    hull = np.empty((2 * m + 1, 2))
    h = 0
    for rev in range(2):
        start = h
        for ii in range(m):
            i = ii if rev == 0 else m - 1 - ii
            while (
                h - start >= 2
                and (
                    (hull[h - 1, 0] - hull[h - 2, 0]) * (pts[i, 1] - hull[h - 2, 1])
                    - (hull[h - 1, 1] - hull[h - 2, 1]) * (pts[i, 0] - hull[h - 2, 0])
                )
                <= 0
            ):
                h -= 1
            hull[h, 0], hull[h, 1] = pts[i, 0], pts[i, 1]
            h += 1
        h -= 1  # the last point is the next chain's first
    sd = -np.inf
    ymax, ymin = -np.inf, np.inf
    for i in range(h):
        j = (i + 1) % h
        dx, dy = hull[j, 0] - hull[i, 0], hull[j, 1] - hull[i, 1]
        r = math.sqrt(dx * dx + dy * dy)
        nx, ny = dy / r, -dx / r
        sd = max(sd, nx * xi0 + ny * xi1 - (nx * hull[i, 0] + ny * hull[i, 1]))
        ymax, ymin = max(ymax, hull[i, 1]), min(ymin, hull[i, 1])
    return sd, max(xi1 - ymax, ymin - xi1)


@njit(cache=True, inline="always")
def capture(t, com, vcom, st, pend, prm):  # pragma: no cover - compiled
    """``SteppingController.__call__``'s capture point and its filtered rate, every period: ``st``
    into ``pend``, the new capture point and rate into ``pend``; (omega_0, xi_x, xi_y)."""
    pend[:] = st
    h = com[2] if com[2] >= MIN_HEIGHT_M else MIN_HEIGHT_M
    omega = math.sqrt(prm[Q_G] / h)
    xi0 = com[0] + vcom[0] / omega
    xi1 = com[1] + vcom[1] / omega
    if st[S_HAS_XI] != 0.0 and t > st[S_T_PREV]:  # the rate's low-pass filter
        dt = t - st[S_T_PREV]
        raw0 = (xi0 - st[S_XI]) / dt
        raw1 = (xi1 - st[S_XI + 1]) / dt
        a = min(1.0, dt / prm[Q_TAU])
        pend[S_RATE] = st[S_RATE] + a * (raw0 - st[S_RATE])
        pend[S_RATE + 1] = st[S_RATE + 1] + a * (raw1 - st[S_RATE + 1])
    pend[S_T_PREV] = t
    pend[S_XI], pend[S_XI + 1], pend[S_HAS_XI] = xi0, xi1, 1.0
    return omega, xi0, xi1


@njit(cache=True)
def double_support(t, left, right, com, vcom, xpos, xmat, st, pend, prm, ints, contact):  # pragma: no cover
    """One double-support period of ``SteppingController.__call__`` up to its call of W's
    controller: the new state into ``pend`` (from ``st``), the contact flags into ``contact``;
    :data:`GO`, or :data:`HAND_BACK` (a step starts, the settling switch, a decision within
    :data:`EPS` of its threshold)."""
    omega, xi0, xi1 = capture(t, com, vcom, st, pend, prm)
    feet = (left, right)
    soles = np.empty((2, 4))
    _sole(xpos, xmat, ints[I_F0], prm, 0, soles[0])
    _sole(xpos, xmat, ints[I_F1], prm, 1, soles[1])
    if ints[I_TRIGGER] and t - prm[Q_LAST_TD] >= prm[Q_REFRACTORY] and t >= prm[Q_ARM]:
        use = np.zeros(2, dtype=np.bool_)
        for i in range(2):
            z = soles[i, 2]
            if not feet[i] and abs(z - POLYGON_Z_M) < EPS:
                return HAND_BACK
            use[i] = feet[i] or z < POLYGON_Z_M
        if not use[0] and not use[1]:
            use[:] = True
        poles = np.empty((8, 2))
        npts = 0
        for i in range(2):
            if not use[i]:
                continue
            c, s = math.cos(soles[i, 3]), math.sin(soles[i, 3])
            hl, hw = prm[Q_SOLE + 5 * i + 3], prm[Q_SOLE + 5 * i + 4]
            for lx, ly in ((hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)):
                poles[npts, 0] = soles[i, 0] + lx * c - ly * s
                poles[npts, 1] = soles[i, 1] + lx * s + ly * c
                npts += 1
        ex, ey = _excess(poles, npts, xi0, xi1)
        # CaptureTrigger.update
        d = max(ex + prm[Q_MARGIN], ey + prm[Q_LATERAL])
        if not np.isnan(prm[Q_MIN_RATE]) and d > -EPS:
            return HAND_BACK  # the rate condition: Python's
        if st[S_ARMED] == 0.0:
            thr = -(prm[Q_REARM] - prm[Q_MARGIN])
            if abs(d - thr) < EPS:
                return HAND_BACK
            if d < thr:
                pend[S_ARMED] = 1.0
            pend[S_COUNT] = 0.0
        else:
            if abs(d) < EPS:
                return HAND_BACK
            pend[S_COUNT] = st[S_COUNT] + 1.0 if d > 0 else 0.0
            if pend[S_COUNT] >= ints[I_HOLD]:
                return HAND_BACK  # the trigger fires: a step starts
        # SteppingController._dwelt
        if not np.isnan(prm[Q_DWELL_S]):
            e = max(ex, ey)
            thr = -prm[Q_DWELL_M]
            if abs(e - thr) < EPS:
                return HAND_BACK
            if e <= thr:
                pend[S_DWELL] = np.nan
            else:
                if np.isnan(pend[S_DWELL]):
                    pend[S_DWELL] = t
                if t - pend[S_DWELL] >= prm[Q_DWELL_S]:
                    return HAND_BACK  # the slow trigger fires
    if ints[I_SETTLE] and t - prm[Q_LAST_TD] >= prm[Q_SETTLE_AFTER]:
        speed = math.hypot(vcom[0], vcom[1])
        if abs(speed - prm[Q_SETTLE_SPEED]) < EPS or speed < prm[Q_SETTLE_SPEED]:
            return HAND_BACK  # the settling controller takes over (or too close to tell)
    if ints[I_CLOSE]:  # SteppingController.__call__'s closing check: at rest, Python decides
        speed = math.hypot(vcom[0], vcom[1])
        if abs(speed - prm[Q_CLOSE_SPEED]) < EPS or speed < prm[Q_CLOSE_SPEED]:
            return HAND_BACK
    mode = ints[I_FLAGS]
    for i in range(2):
        if mode == FLAGS_BOTH:
            contact[i] = 1
        elif mode == FLAGS_SENSED or feet[i]:
            contact[i] = 1 if feet[i] else 0
        else:  # FLAGS_AIRBORNE: a foot off the floor counts while its sole centre is low
            z = soles[i, 2]
            if abs(z - prm[Q_AIRBORNE]) < EPS:
                return HAND_BACK
            contact[i] = 1 if z < prm[Q_AIRBORNE] else 0
    return GO


# ---------------------------------------------------------------------------------------------
# the controller's state and parameters (Python)


def load(policy, st: np.ndarray) -> None:
    """The stepping controller's carried state into ``st``."""
    xi = policy.last_capture_point
    st[S_HAS_XI] = 0.0 if xi is None else 1.0
    if xi is not None:
        st[S_XI : S_XI + 2] = xi
    st[S_T_PREV] = policy._t_prev
    st[S_RATE : S_RATE + 2] = policy._xi_rate
    st[S_DWELL] = np.nan if policy._dwell_since is None else policy._dwell_since
    trig = policy.trigger
    st[S_COUNT] = trig._count
    st[S_ARMED] = 1.0 if trig.armed else 0.0
    st[S_SETTLED] = 1.0 if policy._settled else 0.0


def store(policy, st: np.ndarray) -> None:
    """``st`` back into the stepping controller (after compiled periods)."""
    if st[S_HAS_XI] != 0.0:
        policy.last_capture_point = st[S_XI : S_XI + 2].copy()
    policy._t_prev = float(st[S_T_PREV])
    policy._xi_rate = st[S_RATE : S_RATE + 2].copy()
    policy._dwell_since = None if np.isnan(st[S_DWELL]) else float(st[S_DWELL])
    trig = policy.trigger
    trig._count = int(st[S_COUNT])
    trig.armed = bool(st[S_ARMED])
    policy._settled = bool(st[S_SETTLED])


def _nan(x) -> float:
    return np.nan if x is None else float(x)


def params(policy, prm: np.ndarray, ints: np.ndarray, period: float) -> None:
    """The stepping controller's parameters of its next double-support periods into ``prm`` and
    ``ints`` (they change only in Python periods: a touchdown, the settling switch, the release)."""
    from biped.control import stepping as mod

    s, trig, cfg = policy.stepping, policy.trigger, policy.config
    prm[Q_G], prm[Q_TAU] = policy._gravity, mod.RATE_TAU_S
    prm[Q_MARGIN], prm[Q_REARM], prm[Q_LATERAL] = trig.margin_m, trig.rearm_margin_m, trig.lateral_margin_m
    prm[Q_MIN_RATE] = _nan(trig.min_rate_m_s)
    prm[Q_DWELL_M], prm[Q_DWELL_S] = s.dwell_margin_m, _nan(s.dwell_s)
    prm[Q_REFRACTORY], prm[Q_LAST_TD], prm[Q_ARM] = s.refractory_s, policy._last_td, policy.arm_time_s
    prm[Q_SETTLE_AFTER], prm[Q_SETTLE_SPEED] = _nan(s.settle_after_s), s.settle_speed_m_s
    prm[Q_AIRBORNE], prm[Q_PERIOD] = mod.AIRBORNE_M, period
    prm[Q_CLOSE_SPEED] = s.closing_speed_m_s
    for i in range(2):
        off, hl, hw = policy._sole[i]
        prm[Q_SOLE + 5 * i : Q_SOLE + 5 * i + 5] = (*off, hl, hw)
    ints[I_F0], ints[I_F1] = policy._foot
    ints[I_HOLD] = trig.hold
    ints[I_CLOSE] = 1 if policy._close_pending else 0
    ints[I_TRIGGER] = 1 if policy.recovery_steps < s.max_steps else 0  # a closing step not counted
    ints[I_SETTLE] = 1 if (s.settle_after_s is not None and policy.steps and not policy._settled) else 0
    if not policy.steps and s.holding_sensed and cfg.distribution == "qp":
        ints[I_FLAGS] = FLAGS_SENSED
    elif cfg.support == "sensed":
        ints[I_FLAGS] = FLAGS_SENSED
    elif cfg.distribution != "qp":
        ints[I_FLAGS] = FLAGS_BOTH
    else:
        ints[I_FLAGS] = FLAGS_AIRBORNE


def double_support_controller(policy):
    """The :class:`~biped.control.workspace.WorkspaceController` the stepping controller's next
    double-support period calls (``SteppingController.__call__``'s choice)."""
    if policy._settled:
        return policy._ctrl_settle
    return policy._ctrl_post if policy.steps else policy._ctrl_before
