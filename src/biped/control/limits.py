"""Joint torque limits for the push experiments: none (as in W) or a human-like set.

>>> import numpy as np
>>> from biped.control.limits import torque_limits, clip_torques
>>> lim = torque_limits("human", body_mass_kg=73.0)       # TorqueLimits, per joint (lower, upper)
>>> tau = clip_torques(np.full(12, 1e4), lim)             # (12,) clipped [N m]
>>> bool(np.all(tau == lim.upper))
True

Sign convention (checked against the shipped MJCF's joint axes, see ``docs/sweep.md``): a
positive torque on ``*_hip_abduction`` abducts, ``*_hip_flexion`` flexes the hip,
``*_hip_rotation`` rotates the thigh internally, ``*_knee`` *extends* the knee (the knee angle is
negative when flexed), ``*_ankle_inversion`` inverts and ``*_ankle_dorsiflexion`` dorsiflexes.

The human-like set: maximal voluntary isometric joint torques of healthy young adult men,
normalised by body mass [N m / kg] and scaled to the model's mass (73.06 kg), with the weaker
direction of each joint limited separately (plantarflexion is ~3.5x dorsiflexion). Sources:

* knee extension 3.2 and flexion 1.4 N m/kg: the midpoints of the pooled 95 % confidence
  intervals for adult healthy males at mid-range knee angles (extension 2.92-3.45, flexion
  1.15-1.62 N m/kg) of a meta-analysis of 411 isometric knee-strength studies (13,893
  participants), https://pmc.ncbi.nlm.nih.gov/articles/PMC8554160 (2021).
* hip flexion/extension and ankle plantar-/dorsiflexion: rounded isometric peaks of young men
  in the ranges reported by Anderson, Madigan & Nussbaum, J. Biomech. 40(14):3105-3113 (2007)
  and Hussain & Frey-Law, J. Foot Ankle Res. (2016), rounded (not re-read value by value); hip
  ab-/adduction and rotation and ankle inversion/eversion: rounded typical hand-held /
  isokinetic dynamometry values. These are representative magnitudes (about +-25 % between
  studies, postures and subjects), not a measurement of one person;
  ``docs/sweep.md`` says so next to every result that uses them.

Limits are applied by clipping the controller's torques, joint by joint (no redistribution).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from biped import models
from biped.errors import ScenarioError, unknown_name
from biped.models import JOINT_NAMES

#: Human-like maximal isometric torques [N m / kg body mass] per joint: (negative direction,
#: positive direction) with the anatomical names of each direction (see the module docstring).
HUMAN_N_M_PER_KG: dict[str, tuple[tuple[str, float], tuple[str, float]]] = {
    "hip_abduction": (("adduction", 1.8), ("abduction", 1.8)),
    "hip_flexion": (("extension", 3.0), ("flexion", 2.0)),
    "hip_rotation": (("external rotation", 0.8), ("internal rotation", 0.7)),
    "knee": (("flexion", 1.4), ("extension", 3.2)),
    "ankle_inversion": (("eversion", 0.45), ("inversion", 0.5)),
    "ankle_dorsiflexion": (("plantarflexion", 2.2), ("dorsiflexion", 0.6)),
}

#: Total mass of the shipped model [kg] (73.06: de Leva's 73 kg body and W's intermediate hip and
#: ankle bodies), read from the MJCF.
MODEL_MASS_KG = models.total_mass_kg("wendlandt")

KINDS = ("none", "human")


@dataclass(frozen=True)
class TorqueLimits:
    """Per-joint torque bounds [N m]: ``lower`` (12,) <= 0 <= ``upper`` (12,), in ``joint_names``
    order; ``None`` bounds mean unlimited (W's setting)."""

    name: str
    joint_names: tuple
    lower: np.ndarray | None
    upper: np.ndarray | None

    def __post_init__(self):
        if (self.lower is None) != (self.upper is None):
            raise ScenarioError("torque limits need both lower and upper bounds, or neither")
        if self.lower is not None:
            lo, hi = np.asarray(self.lower, float), np.asarray(self.upper, float)
            n = len(self.joint_names)
            if lo.shape != (n,) or hi.shape != (n,):
                raise ScenarioError(
                    f"torque limits need {n} lower and upper bounds "
                    f"({', '.join(self.joint_names)}); got {lo.shape}, {hi.shape}"
                )
            if np.any(lo > 0) or np.any(hi < 0) or not np.all(np.isfinite(lo) & np.isfinite(hi)):
                raise ScenarioError("torque limits must satisfy finite lower <= 0 <= upper [N m]")
            object.__setattr__(self, "lower", lo)
            object.__setattr__(self, "upper", hi)

    @property
    def unlimited(self) -> bool:
        return self.lower is None

    def reorder(self, joint_names: Iterable[str]) -> TorqueLimits:
        """The same limits in another joint order (names must match)."""
        if self.unlimited:
            return TorqueLimits(self.name, tuple(joint_names), None, None)
        idx = []
        for n in joint_names:
            if n not in self.joint_names:
                raise ScenarioError(unknown_name("joint", n, self.joint_names))
            idx.append(self.joint_names.index(n))
        assert self.lower is not None and self.upper is not None  # not unlimited
        return TorqueLimits(self.name, tuple(joint_names), self.lower[idx], self.upper[idx])


def torque_limits(kind: str = "none", *, body_mass_kg: float = MODEL_MASS_KG) -> TorqueLimits:
    """``"none"`` (unlimited, W) or ``"human"`` (:data:`HUMAN_N_M_PER_KG` times ``body_mass_kg``),
    in :data:`JOINT_NAMES` order [N m]."""
    if kind == "none":
        return TorqueLimits("none", JOINT_NAMES, None, None)
    if kind != "human":
        raise ScenarioError(unknown_name("torque-limit set", kind, KINDS))
    if not (np.isfinite(body_mass_kg) and body_mass_kg > 0):
        raise ScenarioError(f"body_mass_kg must be > 0; got {body_mass_kg!r}")
    lower, upper = [], []
    for name in JOINT_NAMES:
        (_, neg), (_, pos) = HUMAN_N_M_PER_KG[name.split("_", 1)[1]]
        lower.append(-neg * body_mass_kg)
        upper.append(pos * body_mass_kg)
    return TorqueLimits("human", JOINT_NAMES, np.array(lower), np.array(upper))


def clip_torques(tau: np.ndarray, limits: TorqueLimits) -> np.ndarray:
    """``tau`` (12,) [N m] clipped joint by joint to ``[lower, upper]`` (a copy)."""
    tau = np.asarray(tau, dtype=float)
    if limits.unlimited:
        return tau.copy()
    assert limits.lower is not None and limits.upper is not None  # not unlimited
    if tau.shape != limits.lower.shape:
        raise ScenarioError(
            f"torques must have shape {limits.lower.shape} ({', '.join(limits.joint_names)}); got {tau.shape}"
        )
    return np.minimum(np.maximum(tau, limits.lower), limits.upper)


__all__ = [
    "HUMAN_N_M_PER_KG",
    "JOINT_NAMES",
    "KINDS",
    "MODEL_MASS_KG",
    "TorqueLimits",
    "clip_torques",
    "torque_limits",
]
