"""The human results ``biped validate`` holds the biped's thresholds against, with their sources
(:data:`HUMAN`; copied from the project's notes and the abstracts cited, never read at run time),
and the measures reported without a human number. docs/validate.md."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["HUMAN", "MEASURES", "NOT_RUN", "HumanValue", "human_for"]


@dataclass(frozen=True)
class HumanValue:
    """A human measurement: mean +/- SD [unit] and its source (``sd_assumed``: no SD given)."""

    quantity: str
    unit: str
    mean: float
    sd: float
    source: str
    sd_assumed: bool = False

    def inside(self, value: float) -> bool | None:
        """Whether ``value`` lies within mean +/- 2 SD (None when it is not a number)."""
        if value is None or not math.isfinite(value):
            return None
        return abs(value - self.mean) <= 2 * self.sd


ROBINOVITCH = "Robinovitch et al. 2002, J Neurophysiol 88:613-620 (23 young adults)"
WOJCIK = (
    "Wojcik et al. 1999, J Gerontol A 54:M44-50 (abstract: 10 young, 10 older women released from forward "
    "leans raised from ~14 deg until one step failed; no SD in the abstract: 20 % assumed; Thelen et al. "
    "1997, J Gerontol A 52:M8-13: young men 32.5, older men 23.9 deg)"
)
KOUSHYAR = (
    "Koushyar, Bieryla, Nussbaum & Madigan 2019, PLoS ONE 14:e0210049 (abstract: the largest backward "
    "support-surface displacement withstood without stepping, 5 young adults 20-30 y, 6 older 70-80 y; "
    "hips free, not ankles only; the platform's velocity profile is theirs, not our 0.3 s ramp)"
)
MILLE = (
    "Mille et al. 2003, J Neurophysiol 90:666-674, 'Thresholds for inducing protective stepping responses "
    "to external perturbations of human standing' (abstract: motor-driven forward waist pulls; the "
    "threshold is a position 'nearer to the ankles' as the pull's velocity grows, in % of the base of "
    "support (BoS); young never stepped with the waist behind TH = 72 % BoS (fast pulls, velocity no "
    "longer mattering above ~121 % BoS/s), always stepped past TL = 107 % (slow); older 59 % and 91 %; "
    "read here as the waist's position ahead of the ankles, % of the ankle-to-toe length; no SD in the "
    "abstract: 20 % assumed)"
)

#: The human results the experiments are held against (/work/shared/HUMAN-DATA.md and the
#: abstracts cited, copied). Keys ``<experiment>.<measure>``; ``<experiment>_older.<measure>``
#: is the older adults' value, compared with ``neuromotor = "older"``.
HUMAN = {
    "ankle_release.lean_deg": HumanValue(
        "largest forward lean recovered, ankles only", "deg", 5.9, 1.1, ROBINOVITCH
    ),
    "ankle_release.peak_ankle_torque_n_m": HumanValue(
        "peak ankle torque in that recovery", "N m", 116.0, 32.0, ROBINOVITCH
    ),
    "ankle_release.onset_ms": HumanValue("ankle torque onset after release", "ms", 99.0, 13.0, ROBINOVITCH),
    "platform_backward.displacement_m": HumanValue(
        "largest backward platform translation recovered without a step, young adults",
        "m",
        0.162,
        0.026,
        KOUSHYAR,
    ),
    "platform_backward_older.displacement_m": HumanValue(
        "the same, older adults", "m", 0.118, 0.021, KOUSHYAR
    ),
    "waist_pull.percent_bos": HumanValue(
        "the waist's position ahead of the ankles at the end of the largest fast forward waist pull "
        "recovered without a step, % of the ankle-to-toe length",
        "% BoS",
        72.0,
        14.4,
        MILLE,
        sd_assumed=True,
    ),
    "waist_pull_older.percent_bos": HumanValue(
        "the same, older adults", "% BoS", 59.0, 11.8, MILLE, sd_assumed=True
    ),
    "step_release.lean_deg": HumanValue(
        "largest forward lean recovered with one step, young women",
        "deg",
        30.7,
        6.14,
        WOJCIK,
        sd_assumed=True,
    ),
    "step_release_older.lean_deg": HumanValue(
        "the same, older women", "deg", 16.2, 3.24, WOJCIK, sd_assumed=True
    ),
}

#: Measures reported without a human number: (what, unit).
MEASURES = {
    "step_release.step_length_m": ("one-step lean release: step length at the threshold (the stepping "
                                   "foot's horizontal displacement)", "m"),
    "step_release.contact_ms": ("one-step lean release: time from release to the stepping foot's contact "
                                "at the threshold", "ms"),
}  # fmt: skip

#: Experiments of the issue that ``biped validate`` does not run, and why.
NOT_RUN: dict[str, str] = {}


def human_for(quantity: str, preset: str) -> HumanValue | None:
    """The human value ``preset``'s result at ``quantity`` is held against: the older adults'
    (``<experiment>_older.<measure>``) for ``"older"`` where there is one, else the quantity's own;
    None for ``"older"`` against a young-only number when an older one exists elsewhere."""
    exp, measure = quantity.split(".", 1)
    older = HUMAN.get(f"{exp}_older.{measure}")
    if preset == "older":
        return older if older is not None else HUMAN.get(quantity)
    return HUMAN.get(quantity)
