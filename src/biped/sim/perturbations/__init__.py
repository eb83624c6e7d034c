"""The perturbation paradigms of human balance research (scenario key ``perturbation``), one
module each behind one interface (:mod:`biped.sim.perturbations.base`); docs/perturbations.md.

- ``block``: W's thrown block (:mod:`~biped.sim.perturbations.block`), the default;
- ``force``: a force pulse at a point of the body (:mod:`~biped.sim.perturbations.force`);
- ``platform``: the floor under the feet translates (:mod:`~biped.sim.perturbations.platform`);
- ``release``: lean, tethered, then let go (:mod:`~biped.sim.perturbations.release`);
- ``pull``: a motor-driven waist pull imposing a displacement (:mod:`~biped.sim.perturbations.pull`).

A new paradigm is one module with a :class:`~biped.sim.perturbations.base.Perturbation` subclass
and one line in :data:`PARADIGMS`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from biped.sim.perturbations.base import Driver, Perturbation, Size
from biped.sim.perturbations.block import Block
from biped.sim.perturbations.force import Force
from biped.sim.perturbations.platform import Platform
from biped.sim.perturbations.pull import Pull
from biped.sim.perturbations.release import Release

if TYPE_CHECKING:
    from biped.sim.scenario import Scenario

#: name -> paradigm class
PARADIGMS: dict[str, type[Perturbation]] = {p.name: p for p in (Block, Force, Platform, Release, Pull)}
NAMES = tuple(PARADIGMS)


def of(scenario: Scenario) -> Perturbation:
    """The paradigm of ``scenario.perturbation``, bound to it."""
    return PARADIGMS[scenario.perturbation](scenario)


def run_extra(scenario: Scenario, scene, driver, d, inputs: list) -> dict:
    """``PushResult.extra`` of a run: ``{"perturbation": {...}}`` (its paradigm, size and what
    its driver measured) and ``"inputs"`` (what the driver set: ``rows`` (m,), ``ctrl`` (m, nu),
    ``xfrc`` (m, nbody, 6), each holding from its row on, which
    :func:`biped.sim.measure.measure_rows` applies again) for every paradigm but W's block, whose
    result stays as it was."""
    if scenario.perturbation == "block":
        return {}
    mass = float(scene.model.body_subtreemass[scene.model.body_rootid[scene.central_body]])
    size = of(scenario).size(mass)
    info = size.entry()
    if driver is not None:
        info.update(driver.finish(d))
    out: dict = {"perturbation": info}
    if inputs:
        out["inputs"] = {
            "rows": np.array([k for k, _, _ in inputs], dtype=np.int64),
            "ctrl": np.array([c for _, c, _ in inputs]),
            "xfrc": np.array([x for _, _, x in inputs]),
        }
    return out


__all__ = [
    "NAMES",
    "PARADIGMS",
    "Block",
    "Driver",
    "Force",
    "Perturbation",
    "Platform",
    "Pull",
    "Release",
    "Size",
    "of",
]
