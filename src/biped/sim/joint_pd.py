"""A joint-space PD baseline with the workspace controller's interface (``controller = "joint-pd"``).

Not in W. It answers "what does a plain joint servo do under the same push?": the set point
(central-body COM and orientation) is turned once into joint angles by inverse kinematics with both
feet flat on the floor where the initial state puts them, and every joint is then servoed
``tau = Kp (q_d - q) - Kd qdot`` plus the static torques that hold the body's weight on both feet
(the gravity wrench of the whole biped shared by the feet with the minimum-norm solution, the
same Jacobian-transpose idea as W Alg. 5-6 without the dynamics).

>>> ctrl = JointPDController.from_mjcf(biped.models.path("wendlandt"))
>>> ctrl.compute(qpos, qvel, target=Target.wendlandt()).torques   # (12,) [N m], ctrl.joint_names
"""

from __future__ import annotations

from dataclasses import dataclass
from os import PathLike

import mujoco
import numpy as np

from biped.errors import ReachError, StateError

FEET = ("left_foot", "right_foot")


@dataclass(frozen=True)
class JointPDGains:
    """Per-joint gains in ``joint_names`` order: kp (12,) [N m/rad], kd (12,) [N m s/rad].

    Default: hips and knees 800 / 40, ankles 300 / 1.5 (an unloaded foot weighs 1 kg; a larger
    ankle damping with a 2 ms zero-order hold is unstable for it)."""

    kp: tuple = (800.0, 800.0, 800.0, 800.0, 300.0, 300.0) * 2
    kd: tuple = (40.0, 40.0, 40.0, 40.0, 1.5, 1.5) * 2


@dataclass(frozen=True)
class JointPDOutput:
    torques: np.ndarray  # (12,) [N m]
    joint_targets: np.ndarray  # (12,) [rad]


class JointPDController:
    """Joint PD + static gravity compensation toward the IK solution of the set point."""

    def __init__(self, model: mujoco.MjModel, *, target=None, gains: JointPDGains | None = None,
                 initial_qpos: np.ndarray | None = None):
        self.model = model
        self.data = mujoco.MjData(model)
        hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
        self.joint_names = tuple(model.joint(j).name for j in hinges)
        self._qadr = np.array([model.jnt_qposadr[j] for j in hinges])
        self._dadr = np.array([model.jnt_dofadr[j] for j in hinges])
        self._feet = [model.body(f).id for f in FEET]
        self.gains = gains or JointPDGains()
        self._kp = np.array(self.gains.kp, dtype=float)
        self._kd = np.array(self.gains.kd, dtype=float)
        q0 = model.key_qpos[0].copy() if initial_qpos is None and model.nkey else (
            np.asarray(initial_qpos, dtype=float) if initial_qpos is not None else model.qpos0.copy())
        self._foot_goal = self._feet_on_floor(q0)
        self._target = None
        self._qd = None
        if target is not None:
            self._set_target(target)

    @classmethod
    def from_mjcf(cls, source: str | PathLike, **kwargs) -> JointPDController:
        return cls(mujoco.MjModel.from_xml_path(str(source)), **kwargs)

    # -- the set point in joint space -----------------------------------------------------------
    def _feet_on_floor(self, q0):
        """Foot poses (pos (3,), rot (3, 3)) at ``q0``, lowered so the lowest sole touches z = 0."""
        m, d = self.model, self.data
        d.qpos[:] = q0
        mujoco.mj_kinematics(m, d)
        low = min(d.geom_xpos[g, 2] - np.abs(d.geom_xmat[g].reshape(3, 3)) @ m.geom_size[g] @ [0, 0, 1]
                  if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX else np.inf
                  for g in range(m.ngeom) if m.geom_bodyid[g] in self._feet)
        return [(d.xpos[b] - [0, 0, low], d.xmat[b].reshape(3, 3).copy()) for b in self._feet]

    def joint_targets(self, com, quat) -> np.ndarray:
        """(12,) joint angles [rad] putting the central-body COM at ``com`` [m] with orientation
        ``quat`` (w, x, y, z) and both feet flat where they start (Gauss-Newton IK on MuJoCo's
        kinematics and body Jacobians)."""
        m, d = self.model, self.data
        q = m.key_qpos[0].copy() if m.nkey else m.qpos0.copy()
        q[:3], q[3:7] = com, quat
        jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        for _ in range(100):
            d.qpos[:] = q
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            err, rows = [], []
            for b, (p, R) in zip(self._feet, self._foot_goal):
                Rc = d.xmat[b].reshape(3, 3)
                dr = 0.5 * (np.cross(Rc[:, 0], R[:, 0]) + np.cross(Rc[:, 1], R[:, 1])
                            + np.cross(Rc[:, 2], R[:, 2]))
                err += [p - d.xpos[b], dr]
                mujoco.mj_jacBody(m, d, jacp, jacr, b)
                rows += [jacp[:, self._dadr].copy(), jacr[:, self._dadr].copy()]
            e = np.concatenate(err)
            if np.linalg.norm(e) < 1e-10:
                break
            J = np.vstack(rows)
            q[self._qadr] += np.linalg.lstsq(J, e, rcond=None)[0]
        if np.linalg.norm(e) > 1e-6:
            raise ReachError(f"joint-pd: the set point COM {list(com)} is out of the legs' reach "
                             f"with the feet where they start (IK residual {np.linalg.norm(e):.3g})")
        return q[self._qadr].copy()

    def _set_target(self, target):
        key = (tuple(target.com), tuple(target.quat))
        if key != self._target:
            self._qd = self.joint_targets(np.array(target.com), np.array(target.quat))
            self._target = key

    # -- control --------------------------------------------------------------------------------
    def gravity_torques(self, qpos) -> np.ndarray:
        """(12,) joint torques [N m] holding the biped static on both (fixed) feet: with the
        generalized gravity forces g(q) (MuJoCo's bias at zero velocity) and the feet Jacobians
        J_f (12 x nv), solve J_f,root^T w = g_root for the feet wrenches w (minimum norm) and
        return g_joints - J_f,joints^T w."""
        m, d = self.model, self.data
        d.qpos[:] = qpos
        d.qvel[:] = 0
        mujoco.mj_forward(m, d)
        g = d.qfrc_bias.copy()
        jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        J = []
        for b in self._feet:
            mujoco.mj_jacBody(m, d, jacp, jacr, b)
            J += [jacp.copy(), jacr.copy()]
        J = np.vstack(J)
        w = np.linalg.lstsq(J[:, :6].T, g[:6], rcond=None)[0]
        return (g - J.T @ w)[self._dadr]

    def compute(self, qpos, qvel, target=None, gains=None) -> JointPDOutput:
        """Torques (12,) [N m] at ``qpos`` (19,) / ``qvel`` (18,) (MuJoCo layout of the biped)."""
        qpos = np.asarray(qpos, dtype=float)
        qvel = np.asarray(qvel, dtype=float)
        if qpos.shape != (self.model.nq,) or qvel.shape != (self.model.nv,):
            raise StateError(f"qpos must have shape ({self.model.nq},) and qvel ({self.model.nv},); "
                             f"got {qpos.shape} and {qvel.shape}")
        if not (np.isfinite(qpos).all() and np.isfinite(qvel).all()):
            raise StateError("qpos and qvel must be finite")
        if target is not None:
            self._set_target(target)
        if self._qd is None:
            raise StateError("joint-pd: no target given (pass target=Target(...))")
        q, qd = qpos[self._qadr], qvel[self._dadr]
        tau = self._kp * (self._qd - q) - self._kd * qd + self.gravity_torques(qpos)
        return JointPDOutput(torques=tau, joint_targets=self._qd.copy())
