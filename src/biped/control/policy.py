"""One factory for the push experiments' controllers: W's workspace controller or the joint-PD
baseline, with optional torque limits, as a policy ``(qpos, qvel, feet) -> torques``.

>>> import mujoco, numpy as np
>>> from biped import models
>>> m = mujoco.MjModel.from_xml_path(str(models.path("wendlandt")))
>>> qpos, qvel = m.key_qpos[m.key("wendlandt_initial").id], np.zeros(m.nv)   # W's initial state
>>> from biped.control.policy import PolicyConfig, make_policy
>>> policy = make_policy(PolicyConfig())                      # W's controller, set point, gains
>>> tau = policy(qpos, qvel, (True, True))                    # [N m], policy.joint_names order
>>> tau.shape
(12,)

``biped push`` and ``biped sweep`` both build their controllers here (``biped.sim.push`` turns a
:class:`~biped.sim.scenario.Scenario` into a :class:`PolicyConfig`); this module knows nothing of
scenarios or scenes. qpos (19,) / qvel (18,) are MuJoCo's layout of the biped's own model; feet
``(left, right)`` say which soles touch the floor (used by the workspace controller when
``support == "sensed"`` and always with ``distribution == "qp"``; otherwise both feet are taken
as fixed, as in W).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from os import PathLike
from typing import Any

import numpy as np

from biped.control.distribution import QPWeights
from biped.control.joint_pd import W_INITIAL_ANGLES_DEG, JointPDController
from biped.control.limits import JOINT_NAMES, TorqueLimits, clip_torques
from biped.control.workspace import DISTRIBUTIONS, Gains, Target, WorkspaceController
from biped.errors import ScenarioError, unknown_name
from biped.model import TreeModel

CONTROLLERS = ("workspace", "joint-pd")
SUPPORTS = ("fixed", "sensed")

__all__ = ["CONTROLLERS", "SUPPORTS", "Policy", "PolicyConfig", "make_policy", "symmetric_limits"]


@dataclass(frozen=True)
class PolicyConfig:
    """What a push policy is made of (plain values; every default is W's).

    controller: ``"workspace"`` (W's Alg. 1-6) or ``"joint-pd"`` (:mod:`biped.control.joint_pd`).
    target, gains: the workspace controller's set point and gains (unused by joint-pd).
    support: ``"fixed"`` (both feet fixed, W) or ``"sensed"`` (the feet on the floor); the
        ``"qp"`` distribution always takes the sensed feet.
    q_ref_deg: (12,) the posture the joint-PD holds [deg], the model's joint order (default W's
        initial angles, :data:`biped.control.joint_pd.W_INITIAL_ANGLES_DEG`).
    control_period_s: the zero-order-hold period (caps the joint-PD's gains).
    gain_scale: the joint-PD's stiffness factor (damping by its square root).
    torque_limits: bounds [N m] clipping the torques joint by joint, or None (W: unlimited);
        with ``distribution="qp"`` they are also constraints of the QP (clipping is then a no-op).
    distribution: the workspace controller's wrench distribution: ``"statics"`` (W's min-norm
        split, default), ``"printed"`` (W's printed subscripts) or ``"qp"`` (contact-feasible QP,
        :mod:`biped.control.distribution`).
    qp_weights: :class:`~biped.control.distribution.QPWeights` for ``"qp"`` (None: defaults).
    model_path: the biped's MJCF (None: the shipped ``wendlandt`` model).
    """

    controller: str = "workspace"
    target: Target = field(default_factory=Target.wendlandt)
    gains: Gains = field(default_factory=Gains.wendlandt)
    support: str = "fixed"
    q_ref_deg: tuple = W_INITIAL_ANGLES_DEG
    control_period_s: float = 0.002
    gain_scale: float = 1.0
    torque_limits: TorqueLimits | None = None
    model_path: str | PathLike | None = None
    distribution: str = "statics"
    qp_weights: QPWeights | None = None

    def __post_init__(self):
        if self.controller not in CONTROLLERS:
            raise ScenarioError(unknown_name("controller", self.controller, CONTROLLERS))
        if self.support not in SUPPORTS:
            raise ScenarioError(unknown_name("support", self.support, SUPPORTS))
        if self.distribution not in DISTRIBUTIONS:
            raise ScenarioError(unknown_name("distribution", self.distribution, DISTRIBUTIONS))


class Policy:
    """``policy(qpos (19,), qvel (18,), feet (left, right)) -> torques (12,)`` [N m] in
    ``joint_names`` order (a fresh array when torque limits apply or the order is permuted, else
    possibly a view into the controller's buffer, overwritten by the next call). ``controller``
    is the underlying controller object."""

    __slots__ = ("_call", "controller", "joint_names", "limits")

    def __init__(self, call, controller, joint_names: tuple, limits: TorqueLimits | None):
        self._call = call
        self.controller = controller
        self.joint_names = tuple(joint_names)
        self.limits = limits

    def __call__(self, qpos: np.ndarray, qvel: np.ndarray, feet: tuple[bool, bool]) -> np.ndarray:
        return self._call(qpos, qvel, feet)


def _model_path(config: PolicyConfig):
    if config.model_path is not None:
        return config.model_path
    import biped.models

    return biped.models.path("wendlandt")


def make_policy(
    config: PolicyConfig | None = None, joint_order=None, *, tree: TreeModel | None = None, **workspace
) -> Policy:
    """The policy of ``config`` (W's controller if None), its torques in ``joint_order`` (default
    the controller's own, i.e. the model's joint order), clipped by ``config.torque_limits``.

    ``tree``: the biped's :class:`~biped.model.TreeModel` for the workspace controller, if the
    caller already has one (e.g. cached across a sweep's trials); default: read from the model.
    ``workspace``: more keywords of the :class:`~biped.control.workspace.WorkspaceController`
    (a robot's ``soles`` and ``big_base``, :mod:`biped.sim.robot_stepping`).
    """
    config = config or PolicyConfig()
    if config.controller == "workspace":
        qp: dict[str, Any] = {}
        if config.distribution == "qp":
            qp = {"qp_weights": config.qp_weights, "torque_limits": config.torque_limits}
        ws = WorkspaceController(
            tree or TreeModel.from_mjcf(_model_path(config)),
            target=config.target,
            gains=config.gains,
            distribution=config.distribution,
            **qp,
            **workspace,
        )
        # the QP distributes over the contacts that exist: with W's fixed support it kept loading
        # a foot that had left the floor, and 15 of 64 sweep trials diverged (0 with the sensed
        # contacts; docs/controller.md), so "qp" always takes the sensed feet
        if config.support == "sensed" or config.distribution == "qp":
            raw = lambda q, v, feet: ws.torques(q, v, feet_in_contact=feet)
        else:
            raw = lambda q, v, feet: ws.torques(q, v)
        ctrl: WorkspaceController | JointPDController = ws
    else:
        pd = JointPDController.from_mjcf(
            _model_path(config),
            q_ref_deg=config.q_ref_deg,
            gain_scale=config.gain_scale,
            control_period_s=config.control_period_s,
        )
        raw = lambda q, v, feet: pd.compute(q, v).torques
        ctrl = pd
    names = tuple(ctrl.joint_names)
    order_names = tuple(joint_order) if joint_order is not None else names
    if sorted(order_names) != sorted(names):
        raise ScenarioError(f"controller joints {names} differ from the requested order {order_names}")
    limits = config.torque_limits
    if limits is not None:
        limits = limits.reorder(order_names)
        if limits.unlimited:
            limits = None
    if order_names == names and limits is None:
        call = raw
    else:
        order = np.array([names.index(n) for n in order_names])
        if limits is None:
            call = lambda q, v, feet: raw(q, v, feet)[order]
        else:
            call = lambda q, v, feet: clip_torques(raw(q, v, feet)[order], limits)
    return Policy(call, ctrl, order_names, limits)


def symmetric_limits(value, joint_names=JOINT_NAMES) -> TorqueLimits:
    """``|tau_j| <= value_j`` [N m]: one positive number for every joint or one per joint."""
    upper = np.broadcast_to(np.asarray(value, dtype=float), (len(joint_names),)).copy()
    return TorqueLimits("symmetric", tuple(joint_names), -upper, upper)
