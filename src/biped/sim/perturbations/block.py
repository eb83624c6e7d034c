"""W's thrown block (section 4): the block of the scenario's ``block_*`` keys, as before.

Nothing happens during the run (no :class:`~biped.sim.perturbations.base.Driver`), so a block
run is bit for bit what it was before paradigms existed. Its size is the block's horizontal speed
[m/s]; the impulse it delivers is measured from the block's momentum change (the sweep's
``ballistic_impulse``), not known beforehand.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from biped.sim.perturbations.base import Perturbation, Size, world_direction_deg


class Block(Perturbation):
    name = "block"
    keys = ("block_mass_kg", "block_position_m", "block_velocity_m_s", "block_size_m")
    unit = "m/s"

    def edit_spec(self, spec: mujoco.MjSpec) -> None:
        pass  # W's scene as it is

    def initial_state(self, scene, qpos: np.ndarray, qvel: np.ndarray) -> None:
        pass

    def over_row(self) -> None:
        """None: the block is over once it lies still or out of reach (the early-stop rule checks
        the scene's state, :mod:`biped.sim.early_stop`)."""
        return None

    def size(self, total_mass_kg: float) -> Size:
        v = self.scenario.block_velocity_m_s
        return Size(self.name, math.hypot(v[0], v[1]), self.unit, world_direction_deg(v))
