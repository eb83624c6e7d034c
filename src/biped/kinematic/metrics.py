"""What B's code does not guarantee, measured on a sampled :class:`~biped.kinematic.plan.Motion`:
penetration, stance slip, swing clearance (:func:`walk_metrics`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from biped.kinematic.segments import SIDES

if TYPE_CHECKING:
    from biped.kinematic.plan import Motion


# ------------------------------------------------------------------------------------------
# what B's code does not guarantee
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class WalkMetrics:
    """Checks of a motion against the ground (m, rad).

    Attributes:
        max_penetration_m: deepest point of any sole below the terrain, over every frame.
        max_stance_slip_m: largest displacement of a heel or toe from where it stood when its
            foot began to bear weight, over every stance interval.
        min_swing_clearance_m: smallest gap between a swinging (or flying) sole and the terrain
            below it during the middle half of each swing (lift-off and touch-down are at 0).
        max_swing_penetration_m: deepest point of a swinging sole below the terrain (0 if none).
        max_joint_step_rad: largest change of a joint angle between two frames.
        distance_m: forward distance travelled by the pelvis.
        height_climbed_m: height gained on stairs (a jump down does not subtract from it).
        duration_s: length of the motion.
    """

    max_penetration_m: float
    max_stance_slip_m: float
    min_swing_clearance_m: float
    max_swing_penetration_m: float
    max_joint_step_rad: float
    distance_m: float
    height_climbed_m: float
    duration_s: float

    def as_dict(self) -> dict:
        return {k: float(v) for k, v in self.__dict__.items()}


def _runs(mask):
    """(start, stop) index pairs of the True runs of a 1-D bool array."""
    m = np.concatenate([[False], mask, [False]]).astype(int)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))


def walk_metrics(motion: Motion, lm: dict | None = None) -> WalkMetrics:
    """Penetration, stance slip and swing clearance of ``motion``, measured on the figure's
    forward kinematics (not on the planned targets)."""
    lm = lm or motion.landmarks()
    terrain = motion.plan.terrain
    pen, slip, clear, swing_pen = 0.0, 0.0, math.inf, 0.0
    for j, sd in enumerate(SIDES):
        heel, toe = lm[f"{sd}_heel"], lm[f"{sd}_toe"]
        gap = terrain.sole_gap(heel, toe)
        pen = max(pen, float(np.max(-gap, initial=0.0)))
        st = motion.stance[:, j]
        for a, b in _runs(st):
            for pt in (heel, toe):
                slip = max(slip, float(np.max(np.linalg.norm(pt[a:b] - pt[a], axis=1))))
        ph = motion.swing_phase[:, j]
        sw = ~st
        if np.any(sw):
            swing_pen = max(swing_pen, float(np.max(-gap[sw], initial=0.0)))
        mid = np.isfinite(ph) & (ph >= 0.25) & (ph <= 0.75)
        if np.any(mid):
            clear = min(clear, float(np.min(gap[mid])))
    return WalkMetrics(
        max_penetration_m=pen,
        max_stance_slip_m=slip,
        min_swing_clearance_m=clear if math.isfinite(clear) else float("nan"),
        max_swing_penetration_m=swing_pen,
        max_joint_step_rad=float(np.max(np.abs(np.diff(motion.angles, axis=0)), initial=0.0)),
        distance_m=float(motion.pelvis_pos[-1, 0] - motion.pelvis_pos[0, 0]),
        height_climbed_m=float(motion.plan.climbed),
        duration_s=float(motion.times[-1] - motion.times[0]),
    )
