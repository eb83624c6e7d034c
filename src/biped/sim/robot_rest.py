""":mod:`biped.sim.early_stop`'s "at rest" rule on a robot's run (:func:`biped.sim.robot.robot_push`
with ``early_stop``)."""

from __future__ import annotations

import mujoco
import numpy as np

from biped.models.robot import RobotDescription
from biped.sim.early_stop import (
    BLOCK_SPEED_M_S,
    BLOCK_SPIN_RAD_S,
    BODY_SPEED_M_S,
    BODY_SPIN_RAD_S,
    HOLD_S,
    JOINT_SPEED_RAD_S,
    MARGIN,
    REACH_FACTOR,
)

BLOCK, BLOCK_JOINT, FLOOR = "robot_block", "robot_block_root", "robot_floor"
#: Horizontal distance of the central-body COM from its set point at the end that counts as
#: recovered [m] (docs/robots.md).
RECOVERED_WITHIN_M = 0.01


class RobotRest:
    """:mod:`biped.sim.early_stop`'s "at rest" rule on a robot's run, checked every physics step:
    a run may end as recovered once, for :data:`~biped.sim.early_stop.HOLD_S` of simulated time
    after its perturbation is over (a kick's row, a force pulse's end, a platform ramp's end), the
    platform (if any) slides slower than ``BLOCK_SPEED_M_S``, the block (if any) is
    still or out of the robot's reach (:meth:`_block_done`), the floating body moves slower than
    ``BODY_SPEED_M_S`` and spins slower than ``BODY_SPIN_RAD_S``, every leg joint is slower than
    ``JOINT_SPEED_RAD_S``, and the central-body COM is within ``MARGIN`` x the robot's recovery
    tolerance (:data:`RECOVERED_WITHIN_M`, horizontal) of its set point. The robot's controller
    is state feedback on a fixed set point and the scene's inputs are then constant, so the rest
    of the run cannot change the outcome; docs/robots.md lists the grids rerun with and without
    the rule."""

    def __init__(self, m: mujoco.MjModel, desc: RobotDescription, block: bool, target: np.ndarray, others=()):
        self.dt = float(m.opt.timestep)
        self.hold = max(1, round(HOLD_S / self.dt))
        self.target = np.asarray(target[:2], float).copy()
        root = m.body(desc.root)
        self.root = int(root.id)
        self.gravity = float(-m.opt.gravity[2])
        j = int(root.jntadr[0])
        self.lin = int(m.jnt_dofadr[j])
        self.legs = np.array([m.jnt_dofadr[m.joint(n).id] for n in desc.leg_joints])  # the tree's joints
        self.others = np.asarray(others, dtype=int)  # other bodies' dofs (the platform's slide)
        self.block = block
        if block:
            bj = m.joint(BLOCK_JOINT)
            self.bq, self.bv = int(bj.qposadr[0]), int(bj.dofadr[0])
            # the robot's own geoms (not the floor's, the block's or the platform's)
            self.geoms = np.flatnonzero(m.body_rootid[m.geom_bodyid] == self.root)
            self.rbound = m.geom_rbound[self.geoms]
            half = float(m.geom_size[m.geom(BLOCK).id, 0])  # the cube's half edge
            self.block_half_diag, self.block_rest_z = float(np.sqrt(3.0)) * half, half
            self.block_inertia_per_mass = (2.0 * half) ** 2 / 6.0  # a cube's I / m
            self.friction = float(m.geom_friction[m.geom(FLOOR).id, 0])
            self.reach: float | None = None
        self.count = 0

    def _block_done(self, d: mujoco.MjData) -> bool:
        """The block cannot touch the robot again: it is still, or farther from the robot's COM
        than the robot's reach plus its half diagonal plus twice the distance its energy could
        carry it against floor friction (:mod:`biped.sim.early_stop`, condition 1)."""
        v, w = d.qvel[self.bv : self.bv + 3], d.qvel[self.bv + 3 : self.bv + 6]
        if float(v @ v) < BLOCK_SPEED_M_S**2 and float(w @ w) < BLOCK_SPIN_RAD_S**2:
            return True
        c = d.subtree_com[self.root, :2]
        if self.reach is None:  # the robot's geoms' farthest bounding sphere from its COM
            self.reach = float(np.max(np.linalg.norm(d.geom_xpos[self.geoms, :2] - c, axis=1) + self.rbound))
        p = d.qpos[self.bq : self.bq + 3]
        g = self.gravity
        e = float(v @ v) + self.block_inertia_per_mass * float(w @ w)
        e += 2.0 * g * max(float(p[2]) - self.block_rest_z, 0.0)
        travel = REACH_FACTOR * e / (2.0 * self.friction * g)
        return float(np.linalg.norm(p[:2] - c)) > self.reach + self.block_half_diag + travel

    def update(self, d: mujoco.MjData, central_com: np.ndarray, over: bool) -> bool:
        """Count this step toward the hold; True when the run may stop after it."""
        v = d.qvel
        lin, ang = v[self.lin : self.lin + 3], v[self.lin + 3 : self.lin + 6]
        rest = (
            over
            and float(lin @ lin) < BODY_SPEED_M_S**2
            and float(ang @ ang) < BODY_SPIN_RAD_S**2
            and float(np.max(np.abs(v[self.legs]))) < JOINT_SPEED_RAD_S
            and float(np.linalg.norm(central_com[:2] - self.target)) < MARGIN * RECOVERED_WITHIN_M
            and (not self.block or self._block_done(d))
            and (not self.others.size or float(np.max(np.abs(v[self.others]))) < BLOCK_SPEED_M_S)
        )
        self.count = self.count + 1 if rest else 0
        return self.count >= self.hold
