"""The perturbation paradigms of human balance research (scenario key ``perturbation``), one
module each behind one interface (:mod:`biped.sim.perturbations.base`); docs/perturbations.md.

- ``block``: W's thrown block (:mod:`~biped.sim.perturbations.block`), the default;
- ``force``: a force pulse at a point of the body (:mod:`~biped.sim.perturbations.force`);
- ``platform``: the floor under the feet translates (:mod:`~biped.sim.perturbations.platform`);
- ``release``: lean, tethered, then let go (:mod:`~biped.sim.perturbations.release`).

A new paradigm is one module with a :class:`~biped.sim.perturbations.base.Perturbation` subclass
and one line in :data:`PARADIGMS`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from biped.sim.perturbations.base import Driver, Perturbation, Size
from biped.sim.perturbations.block import Block
from biped.sim.perturbations.force import Force
from biped.sim.perturbations.platform import Platform
from biped.sim.perturbations.release import Release

if TYPE_CHECKING:
    from biped.sim.scenario import Scenario

#: name -> paradigm class
PARADIGMS: dict[str, type[Perturbation]] = {p.name: p for p in (Block, Force, Platform, Release)}
NAMES = tuple(PARADIGMS)


def of(scenario: Scenario) -> Perturbation:
    """The paradigm of ``scenario.perturbation``, bound to it."""
    return PARADIGMS[scenario.perturbation](scenario)


__all__ = [
    "NAMES",
    "PARADIGMS",
    "Block",
    "Driver",
    "Force",
    "Perturbation",
    "Platform",
    "Release",
    "Size",
    "of",
]
