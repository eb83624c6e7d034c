"""A human nervous system between the controller and the joints: delay, activation, rate limit.

W's controller senses the whole state exactly, acts at once, and its torques jump from any value
to any other in one control period. A person's do not: the feedback loop is ~100 ms late, muscle
force follows the neural command through activation dynamics, and it rises at most so fast.
Three scenario keys model that (``biped.sim.scenario``; each 0 / "none" = W's ideal controller):

* ``feedback_delay_s``: the controller acts on the state (qpos, qvel, which soles touch the floor)
  of that long ago (sensing, transmission and motor delay lumped; a whole number of control
  periods; the history before t = 0 is the initial state);
* ``activation_time_s``: a first-order lag of the torque behind the controller's command,
  discretised exactly for the zero-order hold: ``act += alpha (u - act)``,
  ``alpha = 1 - exp(-T / activation_time_s)``;
* ``torque_rate_limit_n_m_s``: the most a joint torque may change per second, applied to the lag's
  step: ``|act_k - act_(k-1)| <= rate T``.

The filter's state before the first control period is the first command (the body was holding it;
no ramp from zero at t = 0). :func:`neural_filter` is the one compiled function both push loops
call, so the Python loop and the compiled loop (:mod:`biped.sim.fused`) agree bit for bit.

``neuromotor = "ideal" | "young" | "older"`` names a preset of these keys, W's gains replaced by
Peterka's human-like ones (a controller with W's stiff gains is unstable with a 100 ms delay:
:mod:`biped.planar.delay`) and the torque limits; :data:`PRESETS` and ``docs/validate.md`` give
every value with its source. They were chosen from the literature before any validation run.

>>> import numpy as np
>>> tau, act = np.array([10.0]), np.zeros(1)
>>> neural_filter(tau, act, 1.0, np.array([2.0]), True); float(tau[0])    # first period: held
10.0
>>> tau[0] = 20.0; neural_filter(tau, act, 1.0, np.array([2.0]), False); float(tau[0])
12.0
"""

from __future__ import annotations

import math

from numba import njit

from biped.control.limits import HUMAN_N_M_PER_KG, MODEL_MASS_KG
from biped.control.setpoint import Gains
from biped.errors import ScenarioError
from biped.models import JOINT_NAMES

__all__ = [
    "NEUROMOTOR",
    "OLDER_RATE_FACTOR",
    "OLDER_STRENGTH_FACTOR",
    "PRESETS",
    "PRESET_KEYS",
    "human_rate_limits",
    "neural_filter",
    "peterka_com_gains",
]

NEUROMOTOR = ("ideal", "young", "older")

# ---- the cited values (docs/validate.md "Neuromotor presets"; chosen before any validation run)

#: Lumped feedback delay of young adults [s]: system identification of human stance with a
#: delayed-PD inverted-pendulum model gives 0.097 s (PMC5664365, Table 1) and 0.104 s
#: (J NeuroEng Rehabil 2017, doi:10.1186/s12984-017-0299-x, Table 3); Peterka (2002) reports
#: 100-180 ms. 0.100 s.
YOUNG_DELAY_S = 0.100
#: Older adults: the young delay times Thelen et al.'s (1996, J Gerontol A 51:M226-232) ratio of
#: reaction times before ankle torque, old / young women 164 / 141 ms; rounded to 2 ms.
OLDER_DELAY_S = 0.116
#: Activation: the identified activation dynamics of stance (a critically damped second order,
#: natural frequency 16.8 rad/s, Mugge et al. 2010 via PMC5664365 Table 1) as one first-order lag
#: of time constant 1 / 16.8 s. No age difference cited: the same for older adults.
ACTIVATION_TIME_S = 0.060
#: Peterka (2002): stance is a delayed PD on body lean with stiffness ~1.2 m g h per rad and
#: damping ~0.3-0.4 m g h s/rad (0.35 used). Normalised as K / (m g h), B / (m g h) [s].
PETERKA_STIFFNESS_MGH = 1.2
PETERKA_DAMPING_MGH_S = 0.35
#: Rate of torque development: knee extensors of young men 881.7 N m/s, older men 577.5 N m/s
#: (Quinlan et al. 2018, J Gerontol A 73:539-545, PMC5861887); taken for the shipped 73 kg body
#: and given to the other joints in proportion to their maximal torque (the rate of torque
#: development scales with maximal strength; Thelen et al. 1996), scaled with body mass. With the
#: activation lag, a maximal step command rises at exactly this rate for the first ~0.2 s (the
#: lag alone would ask u / tau, 4.4 times more), so the mean RTD over 0-50, 0-100 and 0-200 ms and
#: the peak are the cited figure: no double counting (tests/test_rtd.py; docs/validate.md "Is the
#: rate limit the cited RTD?").
KNEE_RTD_YOUNG_N_M_S = 881.7
OLDER_RATE_FACTOR = 577.5 / 881.7
#: Strength of older adults relative to young ones: 26 % less dorsiflexor and 32 % less knee
#: extensor torque (Lanza et al. 2003, J Appl Physiol 95:2361-2369), mean loss 29 %; Thelen et
#: al. 1996: 20-40 %.
OLDER_STRENGTH_FACTOR = 0.71

#: Intrinsic (undelayed) joint damping of muscle [N m s/rad per hinge]: the identified intrinsic
#: ankle damping of stance, 68.8 N m s/rad (PMC5664365, Table 1) and 10.9 N m s/rad (J NeuroEng
#: Rehabil 2017, Table 3) for both ankles together; their mean, per joint (68.8 + 10.9) / 4,
#: given to every hinge (the plant's ``joint_damping_n_m_s``, W's run: 1). Without it the
#: delayed biped's trunk drifted and fell in quiet stance (docs/validate.md).
INTRINSIC_DAMPING_N_M_S = 19.9

#: Body geometry for the gains (shipped model, W's set point): whole-body COM and W's controlled
#: point (the central body's COM) above the ankle axes [m].
BODY_COM_HEIGHT_M = 0.80
CONTROLLED_HEIGHT_M = 1.069
#: Axes with no cited gain: the largest stiffness (1/s^2, on a 6 % grid) whose best damping keeps
#: a delay margin of 1.5x the older preset's delay (0.174 s) with the activation lag
#: (:func:`biped.planar.delay.stiffest_gains`), for the central body (44 kg HAT, COM 0.322 m above
#: the hips: an inverted pendulum on the hips, a = m g l / I_hip = 19.90 / 20.96 1/s^2 about x / y)
#: and for yaw and the vertical (a = 0). tests/test_neuromotor.py checks each margin.
TRUNK_KP = (2.5119, 2.2387, 10.0)
TRUNK_KV = (6.6175, 6.7502, 4.2021)
VERTICAL_KP, VERTICAL_KV = 10.0, 4.2021


def peterka_com_gains(
    stiffness_mgh: float = PETERKA_STIFFNESS_MGH,
    damping_mgh_s: float = PETERKA_DAMPING_MGH_S,
    body_com_height_m: float = BODY_COM_HEIGHT_M,
    controlled_height_m: float = CONTROLLED_HEIGHT_M,
    g: float = 9.81,
) -> tuple[float, float]:
    """(kp, kv) of W's COM PD [1/s^2, 1/s] that give a straight body leaning about its ankles
    Peterka's ankle stiffness and damping. W's controller compensates gravity (from the state it
    sees) and accelerates its controlled point, at height H above the ankles, by ``-kp x - kv x'``;
    with x = H theta its ankle torque is ``m g h theta + m H^2 (kp theta + kv theta')``, so
    ``kp = (K / mgh - 1) g h / H^2`` and ``kv = (B / mgh) g h / H^2``."""
    a = g * body_com_height_m / controlled_height_m**2
    return (stiffness_mgh - 1.0) * a, damping_mgh_s * a


def human_rate_limits(body_mass_kg: float = MODEL_MASS_KG, factor: float = 1.0) -> tuple[float, ...]:
    """Per-joint torque rate limits [N m/s] in :data:`JOINT_NAMES` order: the knee extensors'
    rate of torque development (:data:`KNEE_RTD_YOUNG_N_M_S` for the 73 kg body) given to each
    joint in proportion to its larger maximal torque (:data:`HUMAN_N_M_PER_KG`), times the body
    mass ratio and ``factor``."""
    if not (math.isfinite(body_mass_kg) and body_mass_kg > 0):
        raise ScenarioError(f"body_mass_kg must be > 0; got {body_mass_kg!r}")
    knee = HUMAN_N_M_PER_KG["knee"][1][1]
    out = []
    for name in JOINT_NAMES:
        (_, neg), (_, pos) = HUMAN_N_M_PER_KG[name.split("_", 1)[1]]
        out.append(KNEE_RTD_YOUNG_N_M_S * max(neg, pos) / knee * body_mass_kg / MODEL_MASS_KG * factor)
    return tuple(out)


def _preset(delay: float, rate: str, strength: str) -> dict:
    kp, kv = peterka_com_gains()
    return {
        "feedback_delay_s": delay,
        "torque_rate_limit_n_m_s": rate,
        "activation_time_s": ACTIVATION_TIME_S,
        "torque_limits": strength,
        "joint_damping_n_m_s": INTRINSIC_DAMPING_N_M_S,
        "kp_com": (round(kp, 4), round(kp, 4), VERTICAL_KP),
        "kv_com": (round(kv, 4), round(kv, 4), VERTICAL_KV),
        "kp_rot": TRUNK_KP,
        "kv_rot": TRUNK_KV,
    }


#: The presets: the values they give the scenario keys they set when those are not given.
#: "ideal" is W's controller (its gains, no delay, no lag, no rate or torque limit).
PRESETS: dict[str, dict] = {
    "ideal": {
        "feedback_delay_s": 0.0,
        "torque_rate_limit_n_m_s": "none",
        "activation_time_s": 0.0,
        "torque_limits": "none",
        "joint_damping_n_m_s": 1.0,
        "kp_com": Gains().kp_com,
        "kv_com": Gains().kv_com,
        "kp_rot": Gains().kp_rot,
        "kv_rot": Gains().kv_rot,
    },
    "young": _preset(YOUNG_DELAY_S, "human", "human"),
    "older": _preset(OLDER_DELAY_S, "human-older", "human-older"),
}
PRESET_KEYS = tuple(PRESETS["ideal"])


@njit(cache=True)
def neural_filter(tau, act, alpha, rate_step, first):  # pragma: no cover - compiled
    """In place: ``tau`` (nj,) the controller's command -> the torque the joints get this period;
    ``act`` (nj,) the filter's state (the last torque), ``alpha`` the lag's step (1: no lag),
    ``rate_step`` (nj,) the most a torque may change in one period [N m] (inf: no limit);
    ``first``: the first period (the state becomes the command)."""
    for j in range(tau.shape[0]):
        if first:
            act[j] = tau[j]
        else:
            a = tau[j] if alpha == 1.0 else act[j] + alpha * (tau[j] - act[j])
            d = a - act[j]
            r = rate_step[j]
            if d > r:
                a = act[j] + r
            elif d < -r:
                a = act[j] - r
            act[j] = a
        tau[j] = act[j]
