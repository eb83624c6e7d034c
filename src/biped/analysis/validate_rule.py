"""The one-step lean's success rule (Wojcik et al. 1999; :data:`ONE_STEP`). docs/validate.md,
"The one-step rule: Wojcik's success".

Wojcik et al. 1999 (J Gerontol A 54:M44-50, the abstract; read.qxmd.com/read/10026662): ten young
and ten older women "were released from forward leans and instructed to regain standing balance
by taking a single step forward. The lean angle was incrementally increased from its smallest
value, approximately 14 degrees, until the subject failed to regain balance as instructed"
(Thelen et al. 1997, J Gerontol A 52:M8-13, the same in men). The success is standing balance
regained with one step; an upright trunk or the starting stance is not asked. So a trial of the
biped passes when

(a) it does not fall (nor diverge, nor meet a controller error) for the whole run;
(b) it takes at most one step: the stepping controller's steps, a closing step included (a step
    that brings the feet together after the recovery is a second step, not "a single step";
    ``extra["steps"]`` records it with ``closing``; validate's runs leave it off). No step at all
    passes: people were tested from ~14 deg, where everyone steps; the biped's smaller leans
    recovered with the feet in place are below its stepping lean, not leans "the single step
    failed" at (counting them as failures would end the staircase at its first lean, 2 deg);
(c) it stands still at the end ("regain standing balance"): the central body's speed below
    :data:`STILL_SPEED_M_S` (the stepping rule's 5 cm/s) at every row of the run's last
    :data:`STILL_S`, or the run ended at rest by ``early_stop`` (below). A trial still moving at
    the run's end fails, so the result does not hang on a fall just after it.

The run ends early only where the outcome is decided: at a fall, or at rest over the final feet
by ``early_stop``'s rule (:mod:`biped.sim.early_stop`: inside half the strict rule's tolerances
of the set point, where the closed loop is at its equilibrium and stays). A looser
"still" stop (0.5 s under early_stop's speeds, wherever the body is) was measured and not
adopted: it would have ended the young's 8 deg trial at 3.2 s, which falls at 8.79 s
(docs/validate.md).
"""

from __future__ import annotations

import math

import numpy as np

from biped.sim.stepping import RECOVERY_SPEED_M_S

__all__ = ["ONE_STEP", "STILL_S", "STILL_SPEED_M_S", "one_step_passes", "still_at_end"]

#: The one-step lean's criterion (Wojcik's): no fall, at most one step, still at the end.
ONE_STEP = "one step"
#: The largest central-body speed of a biped standing still [m/s] (the stepping rule's).
STILL_SPEED_M_S = RECOVERY_SPEED_M_S
#: How long the biped must have been still at the end of the run [s].
STILL_S = 0.5


def still_at_end(qvel: np.ndarray | None, rate_hz: float) -> tuple[bool, float]:
    """(still: the central body's speed, ``qvel[:, :3]``, below :data:`STILL_SPEED_M_S` at every
    row of the last :data:`STILL_S`; the largest speed in that window [m/s]). Not still when the
    run is shorter than the window or has no rows."""
    hold = max(1, round(STILL_S * rate_hz))
    if qvel is None or len(qvel) < hold:
        return False, math.nan
    peak = float(np.max(np.linalg.norm(qvel[-hold:, :3], axis=1)))
    return bool(peak < STILL_SPEED_M_S), peak


def one_step_passes(survived: bool, steps: int, still: bool) -> bool:
    """Wojcik's success (the module docstring): (a) no fall, (b) at most one step, (c) still."""
    return bool(survived and steps <= 1 and still)
