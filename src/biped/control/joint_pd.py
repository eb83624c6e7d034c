"""The baseline of the push-recovery envelopes: a joint-space PD controller holding a posture.

>>> import mujoco, numpy as np
>>> from biped import models
>>> m = mujoco.MjModel.from_xml_path(str(models.path("wendlandt")))
>>> qpos, qvel = m.key_qpos[m.key("wendlandt_initial").id], np.zeros(m.nv)   # W's initial state
>>> from biped.control.joint_pd import JointPDController
>>> ctrl = JointPDController.from_mjcf(models.path("wendlandt"))   # holds W's initial angles
>>> tau = ctrl.compute(qpos, qvel).torques    # (12,) [N m], ordered as ctrl.joint_names
>>> round(float(np.abs(tau).max()), 6)        # at its set point and at rest: no torque
0.0

Control law, joint by joint (no coupling, no model of the floating base)::

    tau_j = kp_j (q_ref_j - q_j) - kd_j qdot_j  [+ g_j(q)]

Gains (:func:`default_gains`): every hip ab-/adduction, hip flexion, knee and ankle joint gets the
stiffness that gives the whole body, seen as an inverted pendulum of mass M at COM height h on
two ankles, the natural frequency ``omega = sqrt(50) = 7.07 rad/s`` and damping ratio
``zeta = 0.5`` of W's COM gains (K_c^p = 50, K_c^v = 7.07 in x and y):

    kp = (M h^2 omega^2 + M g h) / 2     (the M g h term cancels the gravitational "negative
                                          stiffness"; the 2 shares it between the legs)
    kd = 2 zeta omega (M h^2 / 2)

With the shipped model (M = 73.06 kg, h = 0.809 m at W's initial posture) that is
kp = 1468 N m/rad and kd = 167 N m s/rad. Hip rotation, which carries no gravity load, gets a
quarter of both. The same gains at the hips and knees (which carry less than the whole body)
make them relatively stiffer: a plain, stiff posture holder, as a baseline should be.

Sampled-data cap: the torques are held for a control period T (2 ms at 500 Hz). A joint whose
outboard part is unloaded (a lifted foot: about 0.008 kg m^2 about the ankle) is then a PD on a
small inertia I with a zero-order hold, stable only for ``kd T / I < 2`` and
``kp T^2 / I < 4 - 2 kd T / I`` (Jury's test on the Euler discretisation). Each joint's gains are
capped at half of that, ``kd <= 0.5 I / T`` and ``kp <= I / T^2``, with I the *apparent* inertia
of the joint, ``1 / (M^-1)_jj``: what its torque accelerates when every other joint is free and
the feet are off the floor (MuJoCo's joint-space mass matrix M of the floating biped at the
reference posture). With the shipped model the caps bind for every damping gain: hip
ab-/adduction 50, flexion 127, rotation 18, knee 47, ankle inversion 0.6 and dorsiflexion
2.0 N m s/rad, and for the ankles' stiffness (inversion 605, dorsiflexion 1468 -> kept).
Without the caps (kd = 167 at the hips) the closed loop diverges within 30 ms of W's push.

Gravity compensation (``gravity_compensation=True``, off by default): ``g(q)`` is the set of
joint torques that holds the biped still with both feet fixed, computed by W's own recursion
(Alg. 1-6 of :class:`~biped.control.WorkspaceController`) with zero gains, a zero desired
acceleration and zero velocity: the desired central-body wrench is then ``z_1``, the weight of
the body, shared between the legs. Without it the PD holds the posture by stiffness alone, with a
small static sag of ``g_j / kp_j``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from os import PathLike

import mujoco
import numpy as np

from biped.errors import ScenarioError, StateError, unknown_name
from biped.model import DEFAULT_FEET, TreeModel
from biped.models import W_INITIAL_ANGLES_DEG

OMEGA = math.sqrt(50.0)  # [rad/s], W's K_c^p = 50
ZETA = 0.5  # W's K_c^v = 7.07 = 2 * 0.5 * sqrt(50)


@dataclass(frozen=True)
class JointPDGains:
    """Per-joint gains, in the controller's ``joint_names`` order: kp (12,) [N m/rad],
    kd (12,) [N m s/rad]."""

    kp: np.ndarray
    kd: np.ndarray

    def scaled(self, s: float) -> JointPDGains:
        """Stiffness times s and damping times sqrt(s) (each damping ratio kept)."""
        if not (math.isfinite(s) and s > 0):
            raise ScenarioError(f"gain scale must be > 0; got {s!r}")
        return JointPDGains(self.kp * s, self.kd * math.sqrt(s))


@dataclass(frozen=True)
class JointPDOutput:
    """One call's results: torques (12,) [N m] in ``joint_names`` order; gravity (12,) the
    gravity-compensation share (zeros when off)."""

    torques: np.ndarray
    gravity: np.ndarray


def whole_body_com_height(model: mujoco.MjModel, qpos: np.ndarray) -> tuple[float, float]:
    """(total mass [kg], height of the whole-body COM [m]) of a MuJoCo model at ``qpos``."""
    d = mujoco.MjData(model)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(model, d)
    mujoco.mj_comPos(model, d)
    return float(np.sum(model.body_mass)), float(d.subtree_com[0][2])


def default_gains(
    tree: TreeModel,
    mass_kg: float,
    com_height_m: float,
    omega: float = OMEGA,
    zeta: float = ZETA,
    *,
    apparent_inertia=None,
    control_period_s: float = 0.002,
) -> JointPDGains:
    """The documented gains (module docstring) for every joint of ``tree``, with the vertical
    gravity of its model; with ``apparent_inertia`` (12,) [kg m^2] the sampled-data caps for
    ``control_period_s``."""
    inertia = mass_kg * com_height_m**2
    g = -float(tree.gravity[2])  # [m/s^2]
    kp = 0.5 * (inertia * omega**2 + mass_kg * g * com_height_m)
    kd = 2.0 * zeta * omega * 0.5 * inertia
    scale = np.array([0.25 if name.endswith("hip_rotation") else 1.0 for name in tree.joint_names])
    gains = JointPDGains(kp * scale, kd * scale)
    if apparent_inertia is not None:
        gains = _capped(gains, np.asarray(apparent_inertia, dtype=float), float(control_period_s))
    return gains


def apparent_inertia(model: mujoco.MjModel, qpos: np.ndarray, dof_adr) -> np.ndarray:
    """Apparent inertia [kg m^2] of each joint, ``1 / (M^-1)_jj`` with M MuJoCo's joint-space
    mass matrix of the (floating, contact-free) model at ``qpos``, for the dofs ``dof_adr``."""
    d = mujoco.MjData(model)
    d.qpos[:] = qpos
    mujoco.mj_forward(model, d)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, d, M)
    return 1.0 / np.diag(np.linalg.inv(M))[np.asarray(dof_adr)]


class JointPDController:
    """Joint-space PD holding ``q_ref`` (module docstring), same interface as
    :class:`~biped.control.WorkspaceController`: ``compute(qpos, qvel).torques`` (12,) ordered as
    ``joint_names``, MuJoCo's qpos (19,) / qvel (18,) of the biped's own model."""

    def __init__(
        self, tree: TreeModel, q_ref: np.ndarray, gains: JointPDGains, *, gravity_compensation: bool = False
    ):
        n = tree.n_links - 1
        q_ref = np.asarray(q_ref, dtype=float)
        if q_ref.shape != (n,) or not np.all(np.isfinite(q_ref)):
            raise ScenarioError(
                f"q_ref must be {n} finite joint angles [rad] "
                f"({', '.join(tree.joint_names)}); got shape {q_ref.shape}"
            )
        kp, kd = np.asarray(gains.kp, float), np.asarray(gains.kd, float)
        if kp.shape != (n,) or kd.shape != (n,) or np.any(kp < 0) or np.any(kd < 0):
            raise ScenarioError(f"joint PD gains must be {n} non-negative kp and kd values")
        self.tree = tree
        self.q_ref = q_ref
        self.gains = JointPDGains(kp, kd)
        self.gravity_compensation = bool(gravity_compensation)
        self._qadr = tree.qpos_adr[1:].astype(np.int64)
        self._vadr = tree.dof_adr[1:].astype(np.int64)
        self._qoff = tree.qpos_ref[1:].astype(float)
        self._ws = None
        if self.gravity_compensation:
            from biped.control import Gains, Target, WorkspaceController

            zero = (0.0, 0.0, 0.0)
            self._ws = WorkspaceController(tree, gains=Gains(zero, zero, zero, zero), target=Target())
            self._zero_v = np.zeros(tree.nv)

    @classmethod
    def from_mjcf(
        cls,
        source: str | PathLike,
        *,
        q_ref_deg=W_INITIAL_ANGLES_DEG,
        gains: JointPDGains | None = None,
        gain_scale: float = 1.0,
        gravity_compensation: bool = False,
        control_period_s: float = 0.002,
        feet: tuple[str, str] = DEFAULT_FEET,
    ) -> JointPDController:
        """PD for the biped of an MJCF file holding ``q_ref_deg`` (12 angles in the model's joint
        order, default W's initial posture) with :func:`default_gains` (times ``gain_scale`` on
        kp, ``sqrt(gain_scale)`` on kd, capped for ``control_period_s``) unless ``gains`` is
        given."""
        tree = TreeModel.from_mjcf(source, feet=feet)
        q_ref = np.radians(np.asarray(q_ref_deg, dtype=float))
        if gains is None:
            from biped.model import _load

            model, _ = _load(source)
            qpos = model.qpos0.copy()
            if model.nkey:
                qpos = model.key_qpos[0].copy()
            qpos[tree.qpos_adr[1:]] = q_ref + tree.qpos_ref[1:]
            mass, h = whole_body_com_height(model, qpos)
            gains = default_gains(tree, mass, h - _lowest_sole(model, qpos)).scaled(gain_scale)
            gains = _capped(gains, apparent_inertia(model, qpos, tree.dof_adr[1:]), control_period_s)
        else:
            gains = gains.scaled(gain_scale)
        return cls(tree, q_ref, gains, gravity_compensation=gravity_compensation)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.tree.joint_names

    def compute(self, qpos, qvel) -> JointPDOutput:
        """Torques at state (qpos (19,), qvel (18,)), MuJoCo layout of the biped's model."""
        qpos = np.ascontiguousarray(qpos, dtype=float)
        qvel = np.ascontiguousarray(qvel, dtype=float)
        if qpos.shape != (self.tree.nq,) or qvel.shape != (self.tree.nv,):
            raise StateError(
                f"qpos must have shape ({self.tree.nq},) and qvel ({self.tree.nv},); "
                f"got {qpos.shape} and {qvel.shape}"
            )
        q = qpos[self._qadr] - self._qoff
        qd = qvel[self._vadr]
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
            raise StateError("qpos and qvel must be finite")
        tau = self.gains.kp * (self.q_ref - q) - self.gains.kd * qd
        grav = np.zeros_like(tau)
        if self._ws is not None:
            grav = self._ws.compute(qpos, self._zero_v).torques
            tau = tau + grav
        return JointPDOutput(torques=tau, gravity=grav)

    def joint_index(self, name: str) -> int:
        if name not in self.joint_names:
            raise ScenarioError(unknown_name("joint", name, self.joint_names))
        return self.joint_names.index(name)


def _capped(gains: JointPDGains, i_out: np.ndarray, T: float) -> JointPDGains:
    return JointPDGains(np.minimum(gains.kp, i_out / T**2), np.minimum(gains.kd, 0.5 * i_out / T))


def _lowest_sole(model: mujoco.MjModel, qpos: np.ndarray) -> float:
    """Height [m] of the lowest geom point of the model at ``qpos`` (the soles: the floor level
    of a biped standing on them)."""
    d = mujoco.MjData(model)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(model, d)
    low = np.inf
    for g in range(model.ngeom):
        if model.geom_type[g] != mujoco.mjtGeom.mjGEOM_BOX:
            continue
        half = model.geom_size[g]
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
        z = d.geom_xpos[g][2] + corners @ d.geom_xmat[g].reshape(3, 3)[2]
        low = min(low, float(z.min()))
    return 0.0 if not np.isfinite(low) else low


__all__ = [
    "W_INITIAL_ANGLES_DEG",
    "JointPDController",
    "JointPDGains",
    "JointPDOutput",
    "apparent_inertia",
    "default_gains",
    "whole_body_com_height",
]
