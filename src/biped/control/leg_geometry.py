"""The stepping controller's height set points from the legs of the starting pose
(``step_reach = "leg"``, :class:`~biped.control.stepping_config.SteppingConfig`'s ``span_leg_m``
and ``stand_hip_m``; docs/validate.md, "The lean releases from human quiet stance").

From upright stance (knee 12 deg) W's crouch's fixed height drops and an upright height set point
ask a leg on the floor for a straighter knee than the stance's, toward the straight knee's
singularity, which W's controller does not handle. These functions take the stepping controller
(its MuJoCo data after ``mj_forward`` of the present state) and leave every run without
``span_leg_m`` as it was.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from biped.control.workspace import Target

__all__ = ["height_drop", "leg_capped", "swing_drop"]


def height_drop(stepping, span_m: float, fixed_m: float) -> float:
    """How much lower than the set point the hips are held for a step of ``span_m`` between the
    sole centres: ``fixed_m``, or (``span_leg_m`` set) as low as both legs at that length need to
    span it, ``stand_hip_m - sqrt(span_leg_m^2 - (span_m / 2)^2)``, between 0 and ``fixed_m``."""
    if stepping.span_leg_m is None or stepping.stand_hip_m is None:
        return fixed_m
    h = math.sqrt(max(stepping.span_leg_m**2 - (0.5 * span_m) ** 2, 0.0))
    return min(max(stepping.stand_hip_m - h, 0.0), fixed_m)


def swing_drop(ctrl, i: int) -> float:
    """The stance's height drop while foot ``i`` swings toward the landing target."""
    s = ctrl.stepping
    if s.span_leg_m is None or ctrl._landing is None:
        return s.swing_height_drop_m
    span = float(np.linalg.norm(np.asarray(ctrl._landing)[:2] - ctrl._sole_pose(1 - i)[0][:2]))
    return height_drop(s, span, s.swing_height_drop_m)


def leg_capped(ctrl, target: Target, legs) -> Target:
    """``target`` with its height no higher than the standing ``legs`` reach at the starting
    pose's hip-to-ankle length (``span_leg_m``; unchanged when it is not set): the central body's
    COM set point lowered by what the most stretched leg would have to extend beyond that length,
    its hip joint over its ankle at their present horizontal distance with the ankle at its
    flat-footed height of the controller's first call (a heel raised does not lengthen it)."""
    s = ctrl.stepping
    if s.span_leg_m is None or not legs:
        return target
    d = ctrl.data
    slack = math.inf
    for k in legs:
        hip, ank = d.xpos[ctrl._hip[k]], d.xpos[ctrl._ankle[k]]
        dxy2 = float((hip[0] - ank[0]) ** 2 + (hip[1] - ank[1]) ** 2)
        flat = ctrl._ankle_z0 if ctrl._ankle_z0 is not None else float(ank[2])
        slack = min(slack, flat + math.sqrt(max(s.span_leg_m**2 - dxy2, 0.0)) - float(hip[2]))
    z = float(d.xipos[ctrl._root][2]) + slack
    if target.com[2] <= z:
        return target
    return replace(target, com=(target.com[0], target.com[1], z))
