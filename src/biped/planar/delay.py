"""Delayed PD balance: the stability margin of a feedback delay (B's linear analysis, extended).

One axis of the balanced biped, linearised: a body that gravity tips over at the rate ``a``
[1/s^2] (``a = m g h / J`` for the inverted pendulum on the ankles, 0 for a double integrator)
under a PD whose torque acts ``delay`` seconds late, through an optional first-order activation
lag ``tau_a`` [s]. W's controller computes its gravity compensation from the same (delayed)
state, so in accelerations::

    theta'' = a theta(t) - (a + kp) theta(t - delay) - kv theta'(t - delay)     (tau_a = 0)

Peterka (2002, J Neurophysiol 88:1097-1118) writes the same loop in torques: ``J theta'' =
m g h theta - K theta(t - delay) - B theta'(t - delay)``, so ``K = J (a + kp)`` and ``B = J kv``.
Characteristic equation: ``(s^2 - a)(tau_a s + 1) + (a + kp + kv s) e^(-s delay) = 0``, i.e.
``1 + L(s) e^(-s delay) = 0`` with ``L(s) = (a + kp + kv s) / ((s^2 - a)(tau_a s + 1))``.

:func:`delay_margin` is the exact largest delay the loop tolerates (the smallest delay at which a
root reaches the imaginary axis, from the frequencies where ``|L(i w)| = 1``); ``tests/
test_neuromotor_delay.py`` checks it against python-control's Pade approximation of the delay.

>>> round(delay_margin(a=0.0, kp=1.0, kv=2.0), 4)     # double integrator, critically damped
0.6474
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from biped.errors import ScenarioError

__all__ = [
    "DelayMargin",
    "best_damping",
    "delay_free_stable",
    "delay_margin",
    "loop_gain",
    "margin_report",
    "stiffest_gains",
]


def _check(a: float, kp: float, kv: float, tau_a: float) -> None:
    for name, v in (("a", a), ("kp", kp), ("kv", kv), ("tau_a", tau_a)):
        if not (isinstance(v, (int, float)) and math.isfinite(v)):
            raise ScenarioError(f"{name} must be a finite number; got {v!r}")
    if a < 0 or kv < 0 or tau_a < 0:
        raise ScenarioError(f"a, kv and tau_a must be >= 0; got a={a}, kv={kv}, tau_a={tau_a}")


def loop_gain(w: np.ndarray, a: float, kp: float, kv: float, tau_a: float = 0.0) -> np.ndarray:
    """``L(i w)`` (complex) at the angular frequencies ``w`` [rad/s]."""
    s = 1j * np.asarray(w, dtype=float)
    return (a + kp + kv * s) / ((s * s - a) * (tau_a * s + 1.0))


def delay_free_stable(a: float, kp: float, kv: float, tau_a: float = 0.0) -> bool:
    """Whether the loop without delay is asymptotically stable (Routh-Hurwitz of
    ``tau_a s^3 + s^2 + (kv - a tau_a) s + kp``, or ``s^2 + kv s + kp`` for ``tau_a = 0``)."""
    _check(a, kp, kv, tau_a)
    if tau_a == 0:
        return kp > 0 and kv > 0
    c1 = kv - a * tau_a
    return kp > 0 and c1 > 0 and c1 > tau_a * kp


def delay_margin(a: float, kp: float, kv: float, tau_a: float = 0.0) -> float:
    """The largest feedback delay [s] for which the loop stays asymptotically stable (0 when it is
    not stable without delay; inf when no delay destabilises it)."""
    if not delay_free_stable(a, kp, kv, tau_a):
        return 0.0
    # |L(i w)| = 1  <=>  (a + kp)^2 + kv^2 w^2 = (w^2 + a)^2 (1 + tau_a^2 w^2), a polynomial in w^2
    x = np.polynomial.Polynomial([a, 1.0]) ** 2 * np.polynomial.Polynomial([1.0, tau_a * tau_a])
    x = x - np.polynomial.Polynomial([(a + kp) ** 2, kv * kv])
    roots = [
        float(r.real) for r in np.asarray(x.roots(), dtype=complex) if abs(r.imag) < 1e-9 * max(1.0, abs(r))
    ]
    roots = [r for r in roots if r > 0]
    best = math.inf
    for w2 in roots:
        w = math.sqrt(w2)
        phase = float(np.angle(loop_gain(np.array([w]), a, kp, kv, tau_a))[0])
        # L(i w) e^(-i w d) = -1  <=>  phase - w d = -pi (mod 2 pi): the smallest d >= 0
        d = ((phase + math.pi) % (2 * math.pi)) / w
        best = min(best, d)
    return best


@dataclass(frozen=True)
class DelayMargin:
    """One axis's gains and their margin: ``margin_s`` the largest delay [s], ``ratio`` margin /
    delay (> 1 stable), ``stiffness_mgh`` and ``damping_mgh_s`` Peterka's K / (m g h) and
    B / (m g h) [s] when ``a > 0``."""

    axis: str
    a: float
    kp: float
    kv: float
    tau_a: float
    delay_s: float
    margin_s: float
    ratio: float
    stiffness_mgh: float
    damping_mgh_s: float


def margin_report(axis: str, a: float, kp: float, kv: float, tau_a: float, delay_s: float) -> DelayMargin:
    """The :class:`DelayMargin` of one axis at the feedback delay ``delay_s`` [s]."""
    m = delay_margin(a, kp, kv, tau_a)
    ratio = m / delay_s if delay_s > 0 else math.inf
    k = (a + kp) / a if a > 0 else math.nan
    b = kv / a if a > 0 else math.nan
    return DelayMargin(axis, a, kp, kv, tau_a, delay_s, m, ratio, k, b)


def best_damping(a: float, kp: float, tau_a: float = 0.0) -> tuple[float, float]:
    """(kv, margin): the damping gain that maximises the delay margin at stiffness ``kp``
    (a golden-section search over log kv in [1e-2, 1e3], then the best of a grid around it)."""
    import scipy.optimize

    def neg(log_kv: float) -> float:
        return -delay_margin(a, kp, float(np.exp(log_kv)), tau_a)

    grid = np.linspace(np.log(1e-2), np.log(1e3), 61)
    vals = [neg(x) for x in grid]
    i = int(np.argmin(vals))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    res = scipy.optimize.minimize_scalar(neg, bounds=(lo, hi), method="bounded", options={"xatol": 1e-6})
    x = float(res.x) if res.fun <= vals[i] else float(grid[i])
    return float(np.exp(x)), -neg(x)


def stiffest_gains(a: float, tau_a: float, min_margin_s: float) -> tuple[float, float, float]:
    """(kp, kv, margin): the largest stiffness ``kp`` (to 1 %) whose best damping
    (:func:`best_damping`) still tolerates ``min_margin_s`` of delay; ScenarioError if none does."""
    kps = a * 0.0 + np.geomspace(1e-2, 1e4, 241)
    found = None
    for kp in kps:
        kv, m = best_damping(a, float(kp), tau_a)
        if m >= min_margin_s:
            found = (float(kp), kv, m)
    if found is None:
        raise ScenarioError(f"no PD gains tolerate a delay of {min_margin_s} s (a = {a}, tau_a = {tau_a})")
    return found
