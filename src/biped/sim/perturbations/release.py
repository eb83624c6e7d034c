"""Lean-and-release (Robinovitch et al. 2002; Thelen et al. 1997; Wojcik et al. 1999;
Carbonneau & Smeesters 2014): the biped leans straight about its ankles, held by a horizontal
tether at the pelvis, and is let go without warning.

Keys: ``release_lean_deg`` the lean [deg], ``release_direction_deg`` its direction in the biped's
own terms (0 = forward, the way it faces, world -x; 90 = to its left, world -y; 180 = backward),
``release_time_s`` when the tether goes (at or after ``duration_s``: never, the test of the held
state).

The held state, a static equilibrium by construction:

1. the pose: the scenario's initial pose (W's joint angles and tilt) with the soles on the floor,
   then the whole body above the feet turned by the lean about the horizontal axis through the
   ankles' midpoint (perpendicular to the lean's direction); each leg's six joints are then solved
   (Newton on MuJoCo's Jacobians) to put its foot back where it stood, flat. A forward or backward
   lean turns the ankles only (the body straight); a sideways one is a parallelogram of the legs.
2. the tether: a constant horizontal force T at the pelvis (the midpoint of the hip joints),
   pulling against the lean, of the size that keeps the centre of pressure where it was in the
   upright pose (under its whole-body COM): the tether carries the whole of the lean's extra
   gravity moment, the ankles only what upright stance needs, ``T = m g e / h`` with e the
   whole-body COM's move along the lean and h the pelvis height. No lean, no tether force.
3. the controller "already holding the rest of the body": its set point is the leaned pose and
   its desired acceleration a feed-forward ``X = -P_1^{-1} W_tether`` (the target's ``pddot_d``
   and ``wdot_d``, W Alg. 4), so that its desired wrench (W eq. 3.10, ``F = P_1 X + z_1``)
   cancels the tether's wrench on the central body exactly, whatever the gains (an offset set
   point, ``X / kp``, could not hold a lean with the soft gains of a human-like controller). With
   the feet in place the accelerations are then zero (the controller's statics), so nothing
   moves while the tether holds (``tests/test_perturbations.py``).

With ``stepping = true`` the stepping controller (:mod:`biped.control.stepping`) holds the lean the
same way through its own set point (a :class:`~biped.control.setpoint.Target` with that
feed-forward), and its step trigger is armed only when the release is sensed (while the tether
holds, a large lean's capture point already lies beyond the toes): ``max_steps = 1`` is Wojcik et
al.'s one-step protocol.

Like every paradigm but the block, the run starts from quiet stance (the soles on the floor, the
set point the starting pose; :mod:`biped.sim.perturbations.base`).
At ``release_time_s`` the tether's force goes to zero and the set point returns to the unleaned
pose's (the central body's COM and orientation before the lean): the biped wants to stand
upright again, and must catch the lean's fall to do it.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from biped.errors import ScenarioError
from biped.sim.perturbations.base import (
    Driver,
    Perturbation,
    Size,
    horizontal,
    onto_floor,
    pelvis_point,
    point_track,
    set_target,
    workspace_controller,
)

_LEGS = ("left", "right")


def world_direction(release_direction_deg: float) -> float:
    """The lean's direction from +x toward +y [deg] (0 in the biped's terms is world -x)."""
    return (180.0 + release_direction_deg) % 360.0


def _quat_mul(a, b) -> np.ndarray:
    out = np.zeros(4)
    mujoco.mju_mulQuat(out, np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    return out


def _conj(q) -> np.ndarray:
    return np.array([q[0], -q[1], -q[2], -q[3]])


def lean_pose(scene, qpos: np.ndarray, lean_deg: float, direction_world_deg: float) -> dict:
    """Lower ``qpos`` (scene layout, changed in place) onto the floor and lean it (module
    docstring, step 1); returns the upright pose's central-body COM and quaternion, the ankles'
    midpoint and the lean's unit direction."""
    m = scene.model
    d = mujoco.MjData(m)
    onto_floor(scene, qpos)  # the soles on the floor, z = 0
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    cb = scene.central_body
    upright_com, upright_quat = d.xipos[cb].copy(), d.xquat[cb].copy()
    upright_body_com = d.subtree_com[m.body_rootid[cb]].copy()
    ankles = np.mean([d.xpos[m.body(f"{leg}_ankle_1").id] for leg in _LEGS], axis=0)
    u = horizontal(direction_world_deg)
    if not turn_body(scene, qpos, ankles, np.cross([0.0, 0.0, 1.0], u), math.radians(lean_deg)):
        raise ScenarioError(
            f"release_lean_deg = {lean_deg:g}: a foot cannot stay flat where it stood at this lean "
            "(its leg's joints found no solution); use a smaller lean"
        )
    return {
        "upright_com": upright_com,
        "upright_quat": upright_quat,
        "upright_body_com": upright_body_com,
        "ankles": ankles,
        "direction": u,
    }


def turn_body(scene, qpos: np.ndarray, point, axis, angle_rad: float) -> bool:
    """Turn the central body of ``qpos`` (in place) by ``angle_rad`` about ``axis`` through
    ``point`` (world), then solve each leg's six joints (Newton on MuJoCo's body Jacobian) to put
    its foot back where it was, position and orientation; False if a leg finds no solution."""
    m = scene.model
    legs = [[m.joint(n).id for n in scene.joint_names if n.startswith(leg)] for leg in _LEGS]
    feet = [m.body(f"{leg}_foot").id for leg in _LEGS]
    return turn_about(m, qpos, scene.biped_qpos_index[:7], feet, legs, point, axis, angle_rad)


def turn_about(m, qpos: np.ndarray, root, feet, legs, point, axis, angle_rad: float) -> bool:
    """:func:`turn_body` on any MuJoCo model: ``root`` the floating body's 7 qpos addresses,
    ``feet`` the two foot body ids, ``legs`` each foot's joint ids (its leg's hinges); the
    floating body of ``qpos`` (in place) turned by ``angle_rad`` about ``axis`` through ``point``
    (world), each leg's joints solved to put its foot back, position and orientation (every other
    joint keeps its angle); False if a leg finds no solution."""
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    goals = [(d.xpos[f].copy(), d.xquat[f].copy()) for f in feet]
    root = np.asarray(root)
    ql = np.zeros(4)
    mujoco.mju_axisAngle2Quat(ql, np.asarray(axis, dtype=float), angle_rad)
    r9 = np.zeros(9)
    mujoco.mju_quat2Mat(r9, ql)
    point = np.asarray(point, dtype=float)
    qpos[root[:3]] = point + r9.reshape(3, 3) @ (qpos[root[:3]] - point)
    qpos[root[3:]] = _quat_mul(ql, qpos[root[3:]])
    for joints, f, (fp, fq) in zip(legs, feet, goals, strict=True):
        qa = m.jnt_qposadr[joints]
        va = m.jnt_dofadr[joints]
        jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        for _ in range(50):
            d.qpos[:] = qpos
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            err = np.zeros(6)
            err[:3] = fp - d.xpos[f]
            mujoco.mju_subQuat(err[3:], fq, d.xquat[f])  # the rotation from the foot to its goal
            err[3:] = d.xmat[f].reshape(3, 3) @ err[3:]  # subQuat is in the foot's frame: to world
            if np.abs(err).max() < 1e-12:
                break
            mujoco.mj_jacBody(m, d, jp, jr, f)
            qpos[qa] += np.linalg.solve(np.vstack([jp[:, va], jr[:, va]]), err)
        else:
            return False
    return True


class ReleaseDriver(Driver):
    """Row 0: the tether's force and the offset set point; the release row: both gone."""

    def __init__(self, scenario, model, data, controller, hold: dict, stepper=None):
        self.stepper = stepper  # a SteppingController (its set point is a Target it holds), or None
        self.period = 1.0 / scenario.control_rate_hz
        self.k_release = round(scenario.release_time_s * scenario.control_rate_hz)
        # the nervous system learns of the release from the state it sees, feedback_delay_s late:
        # the set point returns upright then (the same row without a delay)
        self.k_sense = self.k_release + scenario.delay_steps
        n = scenario.control_steps
        rows = [0] + ([self.k_release] if 0 < self.k_release <= n else [])
        if 0 < self.k_release < self.k_sense <= n:
            rows.append(self.k_sense)
        self.rows = np.array(rows, dtype=np.int64)
        self.controller = controller
        self.hold = hold
        self.body = hold["body"]
        self.released_at: float | None = None
        self.final_target = (hold["upright_com"], hold["upright_quat"]) if self.k_release <= n else None

    def _set_target(self, com, quat, acc=None) -> None:
        if self.stepper is not None:  # its own set point: a Target object, not the array
            from biped.control.setpoint import Target

            a = np.zeros(6) if acc is None else np.asarray(acc, dtype=float)
            self.stepper.target = Target(com=tuple(map(float, com)), quat=tuple(map(float, quat)),
                                         com_acc=tuple(a[:3]), ang_acc=tuple(a[3:]))  # fmt: skip
            if acc is None:  # upright again: what its steps move with the feet
                self.stepper.base_target = self.stepper.target
            return
        set_target(self.controller, com, quat)
        if acc is not None:  # the feed-forward accelerations (world frame) that hold the lean
            arr = self.controller.target.array
            arr[6:9] = acc[:3]
            arr[16:19] = acc[3:]

    def apply(self, k: int, t: float, data: mujoco.MjData) -> None:
        h = self.hold
        if k == 0 and self.k_release > 0:
            data.xfrc_applied[self.body, :3] = h["tether_force"]
            data.xfrc_applied[self.body, 3:] = h["tether_moment"]
            self._set_target(h["hold_com"], h["hold_quat"], h["hold_acc"])
        if k == self.k_release:
            data.xfrc_applied[self.body] = 0.0
            self.released_at = t
        if k == self.k_sense and self.k_release > 0:
            self._set_target(h["upright_com"], h["upright_quat"])
            if self.stepper is not None:  # steps only once the release is sensed
                self.stepper.arm_time_s = k * self.period

    def finish(self, data) -> dict:
        return {
            "tether_force_n": float(np.linalg.norm(self.hold["tether_force"])),
            "released_at_s": self.released_at,
        }


class Release(Perturbation):
    name = "release"
    keys = ("release_lean_deg", "release_direction_deg", "release_time_s")
    unit = "deg"

    def initial_state(self, scene, qpos, qvel) -> None:
        super().initial_state(scene, qpos, qvel)  # parks the block, soles on the floor
        s = self.scenario
        lean_pose(scene, qpos, s.release_lean_deg, world_direction(s.release_direction_deg))
        qvel[scene.biped_qvel_index] = 0.0

    def driver(self, scene, model, data, policy):
        from biped.control.stepping import SteppingController

        stepper = policy if isinstance(policy, SteppingController) else None
        if stepper is not None:  # no step while the tether holds: armed at the sensed release
            stepper.reset()
            stepper.arm_time_s = math.inf
        ctrl = stepper.holding_controller if stepper is not None else workspace_controller(policy)
        if ctrl is None:
            raise ScenarioError(
                "perturbation = 'release' needs W's workspace controller, with or without stepping (it "
                "holds the lean with the controller's set point); got another policy"
            )
        from biped.sim.scene import w_initial_state

        s = self.scenario  # the upright pose and the lean again (the run's data holds the leaned state)
        pose = lean_pose(scene, w_initial_state(scene, s)[0], s.release_lean_deg,
                         world_direction(s.release_direction_deg))  # fmt: skip
        hold = hold_state(scene, model, data, ctrl, pose)
        drv = ReleaseDriver(self.scenario, model, data, ctrl, hold, stepper)
        if stepper is not None and drv.k_release == 0:  # released at the start: no tether row
            stepper.arm_time_s = drv.k_sense * drv.period
        return drv

    def over_row(self) -> int:
        """The row the release is sensed (``release_time_s`` plus the feedback delay): the
        tether is gone and the set point upright from there. A release at or after the run's
        end: row 0 (the tether and the lean's set point hold the whole run)."""
        s = self.scenario
        k = round(s.release_time_s * s.control_rate_hz)
        return k + s.delay_steps if 0 < k <= s.control_steps else (s.delay_steps if k == 0 else 0)

    def markers(self) -> list[tuple[float, str]]:
        s = self.scenario
        k = round(s.release_time_s * s.control_rate_hz)
        return [(k / s.control_rate_hz, f"tether released ({s.release_lean_deg:g} deg lean)")]

    def arrows(self, scene, result) -> np.ndarray | None:
        """The tether while it holds: from the pelvis 0.5 m back against the lean."""
        s = self.scenario
        n = len(result.times)
        out = np.full((n, 2, 3), np.nan)
        rows = np.arange(0, min(n, round(s.release_time_s * s.control_rate_hz)))
        if not len(rows) or s.release_lean_deg == 0:
            return out
        cb = scene.central_body
        p = point_track(scene, result.qpos, cb, pelvis_point(scene.model, cb), rows)
        back = -horizontal(world_direction(s.release_direction_deg))
        out[rows, 0] = p
        out[rows, 1] = p + 0.5 * back
        return out

    def size(self, total_mass_kg: float) -> Size:
        s = self.scenario
        return Size(self.name, s.release_lean_deg, self.unit, world_direction(s.release_direction_deg),
                    com_velocity_change_m_s=0.0)  # fmt: skip

    @classmethod
    def sized(cls, base, magnitude: float, direction_deg: float) -> dict:
        return {
            "release_lean_deg": float(magnitude),
            "release_direction_deg": (direction_deg - 180.0) % 360.0,
        }


def hold_state(scene, model, data, ctrl, pose: dict) -> dict:
    """The tether's force and moment on the central body and the controller's set point and
    feed-forward acceleration (module docstring, steps 2 and 3) at ``data``'s state (the leaned pose, at rest)."""
    mujoco.mj_forward(model, data)
    cb = scene.central_body
    root_body = model.body_rootid[cb]
    total = float(model.body_subtreemass[root_body])
    g = float(-model.opt.gravity[2])
    com = data.subtree_com[root_body]
    u = pose["direction"]
    p = data.xpos[cb] + data.xmat[cb].reshape(3, 3) @ pelvis_point(model, cb)  # the pelvis, world
    lean = float((com - pose["upright_body_com"]) @ u)  # the whole-body COM's move along the lean [m]
    mu = float(model.geom_friction[scene.sole_geoms[0], 0])
    f = tether_force(total, g, lean, float(p[2]), u, mu)
    c = data.xipos[cb]
    moment = np.cross(p - c, f)
    qb = data.qpos[scene.biped_qpos_index]
    out = ctrl.compute(qb, np.zeros(len(scene.biped_qvel_index)), feet_in_contact=(True, True))
    R = data.ximat[cb].reshape(3, 3)
    hold_acc = hold_acceleration(out.P1, R, f, moment)
    hold_com = c.copy()
    hold_quat = data.xquat[cb].copy()
    return {
        "hold_acc": hold_acc,
        "body": cb,
        "tether_force": f,
        "tether_moment": moment,
        "hold_com": hold_com,
        "hold_quat": hold_quat / np.linalg.norm(hold_quat),
        "upright_com": pose["upright_com"],
        "upright_quat": pose["upright_quat"],
    }


def tether_force(total: float, g: float, lean_m: float, pelvis_z: float, u, mu: float) -> np.ndarray:
    """(3,) the tether's force [N, world] (module docstring, step 2): ``T = m g e / h`` against the
    lean's direction ``u``, e = ``lean_m`` the whole-body COM's move along it, h = ``pelvis_z``;
    refused when friction ``mu`` could not hold it at the feet (``T > 0.95 mu m g``)."""
    T = total * g * lean_m / pelvis_z
    if abs(T) > 0.95 * mu * total * g:
        raise ScenarioError(
            f"release_lean_deg: the tether pulls {abs(T):.0f} N, "
            f"{abs(T) / (total * g):.2f} of the body's weight, more than friction = {mu:g} lets the feet hold "
            f"(they would slide before the release); set friction >= {abs(T) / (0.95 * total * g):.2f} "
            "(shod feet on a floor: 0.6 to 1) or lean less"
        )
    return -T * np.asarray(u, dtype=float)


def hold_acceleration(P1: np.ndarray, R: np.ndarray, f: np.ndarray, moment: np.ndarray) -> np.ndarray:
    """(6,) the set point's feed-forward (COM acceleration, angular acceleration; world) that makes
    the controller's desired wrench cancel the tether's (force ``f``, ``moment`` about the central
    body's COM, world) on a central body of orientation ``R`` (module docstring, step 3)."""
    W = np.concatenate([R.T @ f, R.T @ moment])  # the tether's wrench, body COM frame
    X = -np.linalg.solve(P1, W)
    # at the set point (the pose itself, at rest) W Alg. 4 gives X^b = R^T pddot_d, R^T wdot_d
    return np.concatenate([R @ X[:3], R @ X[3:]])
