"""Early termination of a push trial once its outcome is decided (scenario key ``early_stop``).

A trial's outcome is decided by the rules of :func:`biped.sim.push.run_closed_loop`:

- **fell**: the central-body COM below ``fall_height_m`` or a body other than a foot on the floor
  (the contact monitor). That already ends every run at the row where it happens, with or without
  this module: a fall is irreversible by definition (it is the rule, not a prediction), and no
  earlier "about to fall" guess is made here.
- **recovered**: the run reached ``duration_s`` without a fall, error or divergence and, at its
  end, the COM is within ``recovery_com_tol_m`` and the orientation within
  ``recovery_orientation_tol_deg`` of the set point (with stepping: the stepping policy's set
  point over the final feet, and COM speed < 5 cm/s).

With ``early_stop`` on, a run also ends as **at rest** (``stop_reason = "at_rest"``; it then
counts as completed and recovered) at a check row where, over the last :data:`HOLD_S` of
simulated time (every row of that window):

1. the perturbation is over: the window starts at or after the paradigm's
   :meth:`~biped.sim.perturbations.base.Perturbation.over_row` (the row from which every input
   it sets holds constant: a force pulse's end, a platform ramp's end, the sensed release; the
   block has none), every other degree of freedom of the scene is still (the platform's slide:
   < :data:`BLOCK_SPEED_M_S`), and the block can no longer touch the biped: it is still (speed <
   :data:`BLOCK_SPEED_M_S`, spin < :data:`BLOCK_SPIN_RAD_S`, wherever it lies; parked and still
   for the other paradigms), or it is out of reach: it does not touch the biped and its
   horizontal distance from the central-body COM exceeds the biped's reach (the farthest of its
   geoms' bounding spheres from that COM in the first state, the feet) plus the block's half
   diagonal plus :data:`REACH_FACTOR` x the farthest its energy could carry it against floor
   friction, ``(v^2 + (I/m) w^2 + 2 g dz) / (2 mu g)`` (its speed, spin and height above rest;
   exact for a sliding block, the factor 2 for a tumbling one);
2. the biped is at rest: central-body speed < :data:`BODY_SPEED_M_S`, its angular speed <
   :data:`BODY_SPIN_RAD_S`, every joint slower than :data:`JOINT_SPEED_RAD_S`;
3. both feet stand flat (heel and toe of each on the floor);
4. the final criterion holds with margin: COM error < :data:`MARGIN` x ``recovery_com_tol_m``,
   orientation error < :data:`MARGIN` x ``recovery_orientation_tol_deg``, against the set point
   the run's end is judged by (the scenario's; a paradigm's driver's ``final_target``, e.g. the
   quiet-stance pose or the platform's moved one; stepping: the policy's current set point).

Why the rest of the run cannot change the outcome: the scene's only time-varying inputs are the
perturbation's, now over (constant inputs, every other body at rest); the controllers are state
feedback with a fixed set point, so a biped at rest on flat feet, inside half the tolerance of
that set point, is at (a small neighbourhood of) the closed loop's equilibrium and stays there.
That argument is not a proof for every controller and model, so it is checked: docs/sweep.md
("Early stop") lists the grids rerun with and without the rule and the per-trial comparison of
their outcomes.

Checks run every :data:`CHECK_S` of simulated time: between two calls of the compiled loop
(:mod:`biped.sim.fused` runs that many rows a call when the rule is on) and at the same rows in
the Python loop, so both loops stop at the same row.
"""

from __future__ import annotations

import weakref

import numpy as np

from biped.sim.contact import _BLOCK_BIT, STANDING

#: Simulated time the rest conditions must hold before a run may stop [s].
HOLD_S = 0.1
#: How often the rule is evaluated [s] (rows = CHECK_S * control rate).
CHECK_S = 0.05
#: Fraction of the recovery tolerances the errors must stay under.
MARGIN = 0.5
BODY_SPEED_M_S = 0.02
BODY_SPIN_RAD_S = 0.05
JOINT_SPEED_RAD_S = 0.1
BLOCK_SPEED_M_S = 0.02
BLOCK_SPIN_RAD_S = 0.2
#: Safety factor on the distance the block's energy could carry it against floor friction.
REACH_FACTOR = 2.0

AT_REST = "at_rest"

_KINEMATICS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

__all__ = ["AT_REST", "CHECK_S", "HOLD_S", "MARGIN", "EarlyStop", "applies"]


def applies(scenario) -> bool:
    """Whether ``scenario``'s runs may stop early: ``early_stop`` is on (every perturbation
    paradigm says when it is over, :meth:`~biped.sim.perturbations.base.Perturbation.over_row`)."""
    return bool(scenario.early_stop)


class EarlyStop:
    """The rule for one run: ``check(rows)`` is True when the ``rows`` recorded so far (rows
    ``[0, rows)`` of the loop's record arrays) end in a window that decides "recovered"."""

    def __init__(self, scenario, scene, records: dict, policy=None, driver=None):
        from biped.sim.perturbations import of

        rate = scenario.control_rate_hz
        over = of(scenario).over_row()
        #: the first row a rest window may start at (the perturbation is over)
        self.over = 0 if over is None else int(over)
        self.driver = driver  # its final_target (set at row 0) is the set point the run is judged by
        self.every = max(1, round(CHECK_S * rate))
        self.hold = max(1, round(HOLD_S * rate))
        self.records = records
        self.scene = scene
        self.policy = policy
        self.com_tol = MARGIN * scenario.recovery_com_tol_m
        self.cos_half = np.cos(np.radians(MARGIN * scenario.recovery_orientation_tol_deg) / 2.0)
        self.target_com = np.asarray(scenario.target_com_m, dtype=float)
        from biped.sim.scene import tilt_quat

        self.target_quat = np.asarray(tilt_quat(scenario.target_axis, scenario.target_tilt_deg), dtype=float)
        iv = np.asarray(scene.biped_qvel_index)
        self.lin, self.ang, self.joints = iv[:3], iv[3:6], iv[6:]
        self.quat = np.asarray(scene.biped_qpos_index)[3:7]
        bv = np.asarray(scene.block_qvel_index)
        self.block_lin, self.block_ang = bv[:3], bv[3:6]
        # every other degree of freedom of the scene (a paradigm's bodies: the platform's slide)
        self.others = np.setdiff1d(np.arange(scene.model.nv), np.r_[iv, bv]).astype(np.int64)
        self.flat = STANDING  # the four sole-part bits (biped.sim.contact.SOLE_GEOMS)
        self.block_bit = _BLOCK_BIT  # the block touches the biped
        self.block_pos = np.asarray(scene.block_qpos_index)[:3]
        size = np.asarray(scenario.block_size_m, dtype=float)
        self.block_half_diag = 0.5 * float(np.linalg.norm(size))
        self.block_rest_z = 0.5 * float(np.min(size))  # its centre's lowest height on the floor
        self.block_inertia_per_mass = float(size @ size) / 12.0  # >= a box's largest I / m
        self.friction = float(scenario.friction)
        self.gravity = float(-scene.model.opt.gravity[2])
        self.reach: float | None = None  # the biped's reach plus the block's half diagonal [m]

    def _block_still(self, v: np.ndarray) -> bool:
        return bool(
            np.max(np.linalg.norm(v[:, self.block_lin], axis=1)) < BLOCK_SPEED_M_S
            and np.max(np.linalg.norm(v[:, self.block_ang], axis=1)) < BLOCK_SPIN_RAD_S
        )

    def _block_out_of_reach(self, w: slice) -> bool:
        """The block cannot touch the biped again (module docstring, condition 1)."""
        r = self.records
        if np.any(r["bits"][w] & self.block_bit):
            return False
        if self.reach is None:
            self.reach = self._biped_reach(r["qpos"][0]) + self.block_half_diag
        q, v = r["qpos"][w], r["qvel"][w]
        p = q[:, self.block_pos]
        lin, ang = v[:, self.block_lin], v[:, self.block_ang]
        g = self.gravity
        # the block's mechanical energy above rest on the floor, per unit mass, as a speed squared
        v2 = (
            np.einsum("ij,ij->i", lin, lin)
            + self.block_inertia_per_mass * np.einsum("ij,ij->i", ang, ang)
            + 2.0 * g * np.maximum(p[:, 2] - self.block_rest_z, 0.0)
        )
        travel = REACH_FACTOR * v2 / (2.0 * self.friction * g)
        d = np.linalg.norm(p[:, :2] - r["com"][w][:, :2], axis=1)
        return bool(np.all(d > self.reach + travel))

    def _biped_reach(self, qpos0: np.ndarray) -> float:
        """The largest horizontal distance of a biped geom's bounding sphere from the central-body
        COM in the run's first state (the feet, for a standing biped) [m]."""
        import mujoco

        m = self.scene.model
        d = _KINEMATICS.get(m)
        if d is None:  # one MjData per model (a new one costs ~1.5 ms, a sweep asks once a trial)
            d = _KINEMATICS[m] = mujoco.MjData(m)
        d.qpos[:] = qpos0
        mujoco.mj_kinematics(m, d)
        c = d.xipos[self.scene.central_body, :2]
        g = np.asarray(self.scene.biped_geoms)
        return float(np.max(np.linalg.norm(d.geom_xpos[g, :2] - c, axis=1) + m.geom_rbound[g]))

    def check(self, rows: int) -> bool:
        """Whether the run may stop after row ``rows - 1`` (see the module docstring)."""
        if rows - self.hold < self.over:
            return False
        r = self.records
        last = rows - 1  # the last row first, the cheapest test: most checks fail on it
        if (int(r["bits"][last]) & self.flat) != self.flat:
            return False
        v1 = r["qvel"][last]
        if np.max(np.abs(v1[self.joints])) >= JOINT_SPEED_RAD_S:
            return False
        lin = v1[self.lin]
        if float(lin @ lin) >= BODY_SPEED_M_S**2:
            return False
        w = slice(rows - self.hold, rows)
        if not bool(np.all((r["bits"][w] & self.flat) == self.flat)):
            return False
        v = r["qvel"][w]
        if not (self._block_still(v) or self._block_out_of_reach(w)):
            return False
        if len(self.others) and np.max(np.abs(v[:, self.others])) >= BLOCK_SPEED_M_S:
            return False
        if np.max(np.linalg.norm(v[:, self.lin], axis=1)) >= BODY_SPEED_M_S:
            return False
        if np.max(np.linalg.norm(v[:, self.ang], axis=1)) >= BODY_SPIN_RAD_S:
            return False
        if np.max(np.abs(v[:, self.joints])) >= JOINT_SPEED_RAD_S:
            return False
        target, target_quat = self.target_com, self.target_quat
        final = getattr(self.driver, "final_target", None)  # a paradigm's: what the run is judged by
        if final is not None:
            target, target_quat = (np.asarray(x, dtype=float) for x in final)
        set_point = getattr(self.policy, "set_point_com", None)  # stepping: over the current feet
        if set_point is not None:
            target = np.asarray(set_point, dtype=float)
        if np.max(np.linalg.norm(r["com"][w] - target, axis=1)) >= self.com_tol:
            return False
        q = r["qpos"][w][:, self.quat]
        c = np.abs(q @ target_quat) / np.linalg.norm(q, axis=1)
        return bool(np.min(c) > self.cos_half)
