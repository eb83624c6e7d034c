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

__all__ = ["height_drop", "knee_carried_drop", "knee_lever", "leg_capped", "swing_drop"]


def height_drop(stepping, span_m: float, fixed_m: float) -> float:
    """How much lower than the set point the hips are held for a step of ``span_m`` between the
    sole centres: ``fixed_m``, or (``span_leg_m`` set) as low as both legs at that length need to
    span it, ``stand_hip_m - sqrt(span_leg_m^2 - (span_m / 2)^2)``, between 0 and ``fixed_m``."""
    if stepping.span_leg_m is None or stepping.stand_hip_m is None:
        return fixed_m
    h = math.sqrt(max(stepping.span_leg_m**2 - (0.5 * span_m) ** 2, 0.0))
    return min(max(stepping.stand_hip_m - h, 0.0), fixed_m)


def swing_drop(ctrl, i: int) -> float:
    """The stance's height drop while foot ``i`` swings toward the landing target (no deeper than
    the knees carry, :func:`knee_carried_drop`)."""
    s = ctrl.stepping
    if s.span_leg_m is None or ctrl._landing is None:
        return carried(s.swing_height_drop_m, ctrl._knee_drop)
    span = float(np.linalg.norm(np.asarray(ctrl._landing)[:2] - ctrl._sole_pose(1 - i)[0][:2]))
    return height_drop(s, span, s.swing_height_drop_m)


def carried(drop_m: float, knee_drop_m: float | None) -> float:
    """``drop_m`` no deeper than the knee-carried drop ``knee_drop_m`` (the controller's
    ``_knee_drop``, :func:`knee_carried_drop` at its first call; None: ``drop_m``)."""
    return drop_m if knee_drop_m is None else min(drop_m, knee_drop_m)


def knee_lever(hip, knee, ankle, u, ends, drop_m: float) -> float:
    """The knee's lever [m] for the whole weight on one foot with the hips ``drop_m`` lower: the
    knee point found again (the thigh ``|hip - knee|`` and the shank ``|knee - ankle|`` kept, the
    hip joint lowered straight down, the ankle fixed, the knee on its side of the hip-ankle line,
    in the vertical plane along the sole's axis ``u``), then its largest horizontal distance along
    ``u`` from the sole's ends ``ends`` (positions along ``u``): the CoP the stance may need,
    farthest from the knee (W's crouch: the heel)."""
    hip, knee, ankle = (np.asarray(p, dtype=float) for p in (hip, knee, ankle))
    a, b = float(np.linalg.norm(hip - knee)), float(np.linalg.norm(knee - ankle))

    def plane(p):  # (along u, up)
        return np.array([float(u @ p[:2]), float(p[2])])

    H, K, A = plane(hip) - np.array([0.0, drop_m]), plane(knee), plane(ankle)
    v = A - H
    D = float(np.linalg.norm(v))
    if not 1e-9 < D < a + b:  # out of the legs' reach: the knee where it is
        return max(abs(K[0] - e) for e in ends)
    x = (a * a - b * b + D * D) / (2.0 * D)  # along hip -> ankle, from the hip
    y = math.sqrt(max(a * a - x * x, 0.0))
    n = np.array([-v[1], v[0]]) / D
    side = 1.0 if float(n @ (K - plane(hip))) >= 0.0 else -1.0
    k = H + x * v / D + side * y * n
    return max(abs(float(k[0]) - e) for e in ends)


def knee_carried_drop(ctrl, steps: int = 64) -> float | None:
    """The deepest height drop [m] (0 to the fixed drops) at which each knee's extension torque
    limit carries the whole weight with the CoP at its sole's end farthest from the knee,
    ``m g knee_lever <= tau_ext`` (:func:`knee_lever`), from the present state (the controller's
    first call: the standing pose); 0 if not even the standing knee carries it. None (the fixed
    drops) without ``knee_carried_drop``, without torque limits, or with ``span_leg_m`` (its drops
    keep the standing knee's flexion already)."""
    s = ctrl.stepping
    lim = ctrl.limits
    if not s.knee_carried_drop or s.span_leg_m is not None or lim is None or lim.upper is None:
        return None
    d, m = ctrl.data, ctrl.model
    fixed = max(s.swing_height_drop_m, s.post_step_height_drop_m)
    weight = ctrl._mass * ctrl._gravity
    best = fixed
    for leg, (k_hip, foot) in enumerate(zip(ctrl._hip, (0, 1), strict=True)):
        joints = ctrl.body.leg_joints[leg]
        kj = ctrl.joint_names.index(joints[3])
        q = float(d.qpos[ctrl._leg_qpos[leg][3]])
        tau_ext = float(lim.upper[kj]) if q < 0.0 else -float(lim.lower[kj])  # away from flexion
        c, yaw = ctrl._sole_pose(foot)
        u = np.array([math.cos(yaw), math.sin(yaw)])
        hl = ctrl._sole[foot][1]
        ends = (float(u @ c[:2]) - hl, float(u @ c[:2]) + hl)
        hip, knee, ankle = d.xpos[k_hip], d.xanchor[m.joint(joints[3]).id], d.xanchor[m.joint(joints[4]).id]

        def ok(drop, hip=hip, knee=knee, ankle=ankle, u=u, ends=ends, tau_ext=tau_ext):
            return weight * knee_lever(hip, knee, ankle, u, ends, drop) <= tau_ext

        if not ok(0.0):
            return 0.0
        lo, hi = 0.0, best
        if ok(hi):
            continue
        for _ in range(steps):  # the lever grows as the hips sink: bisection
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if ok(mid) else (lo, mid)
        best = lo
    return best


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
