"""Hof's feet-in-place bound for a robot (:mod:`biped.models.robot`): its mass, its whole-body
COM at the standing pose (MuJoCo's ``subtree_com``) and the convex hull of its two sole
rectangles' corners (the module's sole rule) go into
:func:`biped.analysis.feet_in_place.hof_bound`."""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial import ConvexHull

from biped.analysis.feet_in_place import FeetInPlaceBound, hof_bound
from biped.models.robot import RobotDescription, plant_model, robot_soles
from biped.sim.robot import robot_controller, standing_qpos


def sole_corners(desc: RobotDescription) -> np.ndarray:
    """(8, 3) world corners [m] of the two sole rectangles at the standing pose (left foot first)."""
    ctrl = robot_controller(desc, "statics", "none")
    q = standing_qpos(desc, ctrl)
    g = ctrl.link_poses(q)
    out = []
    for f, s in zip(ctrl.tree.feet, robot_soles(desc), strict=True):
        for i in (-1, 1):
            for j in (-1, 1):
                out.append((g[f] @ s.g_foot_sole @ np.array([i * s.half_length, j * s.half_width, 0, 1]))[:3])
    return np.array(out)


def robot_hof_bound(desc: RobotDescription, directions_deg) -> FeetInPlaceBound:
    """Hof's J_max [N s] of the robot standing at its keyframe, per push direction (of travel)."""
    m = plant_model(desc)
    d = mujoco.MjData(m)
    ctrl = robot_controller(desc, "statics", "none")
    d.qpos[:] = standing_qpos(desc, ctrl)
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    com = d.subtree_com[m.body(desc.root).id]
    corners = sole_corners(desc)
    hull = ConvexHull(corners[:, :2])
    return hof_bound(
        directions_deg,
        desc.mass,
        float(com[2] - corners[:, 2].min()),
        com[:2],
        corners[hull.vertices, :2],
        float(-m.opt.gravity[2]),
    )
