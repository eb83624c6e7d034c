"""The swing's path shape for a rate-limited leg (the step program's ``swing_brake``;
docs/validate.md, "The swing's shape").

The step program (:mod:`biped.control.step_program`) moves the swing ankle along a path in time
from its start to the landing point. Its duration was chosen from a jerk limit (a torque rate
limit is a bound on the leg's jerk): a rest-to-rest move of length d within a jerk J takes at
least ``(32 d / J)^(1/3)``, the time of the bang-bang jerk profile (+J, -J, +J over a quarter,
a half and a quarter of the move). But the path it followed was the minimum-jerk polynomial
``10 u^3 - 15 u^4 + 6 u^5``, whose peak jerk is 60 d / T^3, not 32 d / T^3: for the same peak
jerk (the same torque rate) it takes ``(60 / 32)^(1/3) = 1.23`` times longer.

:func:`scurve` is the bang-bang jerk path itself (an "S-curve": the acceleration a triangle up,
down through zero, and back): the same endpoints (zero rate and acceleration at both ends,
``brake = 1``) in 0.81 of the time at the same peak jerk; with ``brake < 1`` the path ends
still moving (``brake = 0``: at twice the mean speed, peak jerk 8 d / T^3).

At 0.37 s the S-curve of a 0.7 m step asks 442 m/s^3, more than the young hip's rate limit gives
(~170 m/s^3): its foot lagged the plan 0.25 m and was counted as landed short. ``"s-curve-timed"``
times the path for the step's own length (:func:`swing_jerk_m_s3`; docs/validate.md, "The S-curve
tracked").
"""

from __future__ import annotations

__all__ = ["SWING_PATHS", "jerk_bound", "scurve", "swing_jerk_m_s3"]


def _segments(brake: float):
    b = 0.25 * min(max(brake, 0.0), 1.0)
    return ((1.0, 0.5 - b), (-1.0, 1.0 - b), (1.0, 1.0))


def _raw(u: float, brake: float) -> tuple[float, float, float]:
    """The unnormalised jerk-pattern move (jerk +-1) at ``u`` in [0, 1]: (x, v, a)."""
    x = v = acc = 0.0
    t0 = 0.0
    for j, t1 in _segments(brake):
        tau = min(u, t1) - t0
        if tau > 0:
            x += v * tau + acc * tau**2 / 2 + j * tau**3 / 6
            v += acc * tau + j * tau**2 / 2
            acc += j * tau
        t0 = t1
        if u <= t1:
            break
    return x, v, acc


def scurve(u: float, brake: float) -> tuple[float, float, float]:
    """(s, s', s'') at ``u`` in [0, 1] of a move of unit length whose jerk only switches sign (a
    torque rising and falling at one rate): jerk +J on [0, a], -J on [a, 1 - b], +J on
    [1 - b, 1] with ``b = brake / 4``, ``a = 1/2 - b`` (the acceleration zero at both ends).
    ``brake`` 1: rest to rest (J = 32: the ``(32 d / J)^(1/3)`` move); 0: it ends moving at twice
    the mean speed (J = 8: ``(8 d / J)^(1/3)``). ``u`` is clamped to [0, 1]."""
    n = _raw(1.0, brake)[0]
    x, v, acc = _raw(min(max(u, 0.0), 1.0), brake)
    return x / n, v / n, acc / n


def jerk_bound(brake: float) -> float:
    """The peak |s'''| of :func:`scurve` (unit length and time): 32 at ``brake`` 1, 8 at 0."""
    return 1.0 / _raw(1.0, brake)[0]


#: The leg's effective mass at the ankle [kg] and its length from the hip [m] that turn a hip
#: torque rate into an ankle jerk (the step program's 0.45 s swing was chosen with them:
#: :class:`~biped.control.step_program.StepProgramConfig`).
LEG_MASS_AT_ANKLE_KG = 6.0
LEG_LEVER_M = 0.8
#: The share of the hip flexion's rate limit a timed swing's plan asks for (the rest is left to
#: the feedback, the bump's lift and the leg's gravity); chosen by trying (docs/validate.md, "The
#: S-curve tracked"): at 11 deg the young foot lagged its plan 0.13 m at J 180 m/s^3 (share 1.05),
#: 0.03 m at 0.7 (J 120).
SWING_RATE_SHARE = 0.7


def swing_jerk_m_s3(hip_flexion_rate_n_m_s: float) -> float:
    """The ankle's jerk [m/s^3] that a hip torque rising at ``SWING_RATE_SHARE`` of its rate limit
    gives a leg of :data:`LEG_MASS_AT_ANKLE_KG` at :data:`LEG_LEVER_M`: J = share x rate / (m l)
    (young 827 N m/s: 120 m/s^3; no limit: inf)."""
    return SWING_RATE_SHARE * hip_flexion_rate_n_m_s / (LEG_MASS_AT_ANKLE_KG * LEG_LEVER_M)


#: The step program's settings for each value of the scenario key ``swing_path``
#: (:class:`~biped.control.step_program.StepProgramConfig` fields): "min-jerk", the program as it
#: was; "s-curve", the bang-bang jerk path at the minimum-jerk plan's peak jerk (0.45 s x
#: (32 / 60)^(1/3) = 0.365 s, rounded up to 0.37 s), with no weight transfer (docs/validate.md,
#: "The swing's shape"); "s-curve-timed", the same path timed for the step's own length (its
#: swing time the shortest whose peak jerk is :func:`swing_jerk_m_s3` of the preset's hip flexion
#: rate limit, at least 0.37 s) and a contact counted as the landing only within 0.1 m of the
#: landing point or once the plan is over (docs/validate.md, "The S-curve tracked").
SWING_PATHS: dict[str, dict[str, float]] = {
    "min-jerk": {},
    "s-curve": {"swing_brake": 1.0, "swing_time_s": 0.37, "transfer_s": 0.0},
    "s-curve-timed": {"swing_brake": 1.0, "swing_time_s": 0.37, "transfer_s": 0.0, "land_within_m": 0.1},
}
#: The paths timed by the preset's rate limit (``swing_jerk_m_s3`` set from it by the policy).
TIMED_PATHS = ("s-curve-timed",)
