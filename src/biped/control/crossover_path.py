"""When a crossover's swing foot moves along and across (issue #23, stance slip; docs/sweep.md,
"The crossover's path").

A crossover (:mod:`biped.control.stepping_swing`) swings the foot around the stance foot: along x
to the landing point's end of the stance foot, then across to its far side, each coordinate on a
minimum-jerk path in its own window of the swing. The fixed windows (x in the first 60 %, y in the
last 60 %) moved a foot 0.7 m across in 0.12 s at 0.2 s (336 m/s^2 planned); the stance foot
carried the swing leg's reaction and slid 5 cm (90 deg 18 m/s, set C').

:func:`windows` times them from the step's geometry instead: the foot may move across from the
start as long as it reaches the stance sole's side band (the two soles' half widths) only once
the along-x move is done, so the soles clear; of the windows that do so it takes the one with the
smaller larger peak acceleration (a minimum-jerk move of d in time t peaks at 5.77 d / t^2).
"""

from __future__ import annotations

__all__ = ["FIXED", "MIN_JERK_PEAK", "min_jerk_inverse", "swing_time", "windows"]

#: The fixed windows (x, y) as fractions of the swing time.
FIXED = ((0.0, 0.6), (0.4, 1.0))

#: A minimum-jerk move of d in time t peaks at this times d / t^2 (10 / sqrt(3)).
MIN_JERK_PEAK = 10.0 / 3.0**0.5


def min_jerk_inverse(f: float) -> float:
    """The u in [0, 1] where the minimum-jerk profile ``10 u^3 - 15 u^4 + 6 u^5`` reaches ``f``
    (clamped to [0, 1]; bisection, monotone profile)."""
    if f <= 0.0 or f >= 1.0:
        return 0.0 if f <= 0.0 else 1.0
    lo, hi = 0.0, 1.0
    for _ in range(40):
        u = 0.5 * (lo + hi)
        if u**3 * (10 - 15 * u + 6 * u * u) < f:
            lo = u
        else:
            hi = u
    return 0.5 * (lo + hi)


def windows(dx: float, dy: float, gap: float, band: float, n: int = 61):
    """The along (x) and across (y) windows ((0, a), (b, 1)) of a crossover's swing, as fractions
    of its time: ``dx`` and ``dy`` the ankle's moves [m], ``gap`` the swing sole's distance across
    from the stance sole's centre at the start [m], ``band`` how near across the soles may come
    before they must be clear along x (the soles' half widths summed) [m]. The across move reaches
    the band at ``b + u (1 - b)``, u the minimum-jerk fraction ``(gap - band) / |dy|`` takes; the
    along move ends there (``a``). Of ``b`` in [0, 0.6] the one with the least larger of
    ``|dx| / a^2`` and ``|dy| / (1 - b)^2`` (the moves' peak accelerations up to one factor)."""
    u = min_jerk_inverse((abs(gap) - band) / abs(dy)) if abs(dy) > 1e-9 else 1.0
    best = None
    for k in range(n):
        b = 0.6 * k / (n - 1)
        a = b + u * (1.0 - b)
        if a <= 1e-3:
            continue
        cost = max(abs(dx) / a**2, abs(dy) / (1.0 - b) ** 2)
        if best is None or cost < best[0]:
            best = (cost, a, b)
    if best is None:
        return FIXED
    return ((0.0, best[1]), (best[2], 1.0))


def swing_time(dx: float, dy: float, wins, t0: float, a_max: float) -> float:
    """The crossover's swing time [s]: at least ``t0``, and long enough that neither move's
    minimum-jerk peak acceleration in its window (``wins`` = ((a0, a1), (b0, b1)) fractions of the
    swing, x then y) exceeds ``a_max`` [m/s^2]: ``MIN_JERK_PEAK |d| / (T w)^2 <= a_max`` for each
    move d and window length w."""
    t = t0
    for d, (w0, w1) in zip((dx, dy), wins, strict=True):
        if w1 > w0:
            t = max(t, (MIN_JERK_PEAK * abs(d) / a_max) ** 0.5 / (w1 - w0))
    return t
