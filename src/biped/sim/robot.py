"""A robot's own MJCF on the floor under W's controller (:mod:`biped.models.robot`'s mapping).

The plant is the file's model edited at load (:func:`biped.models.robot.plant_spec`: leg servos
made torque motors) plus a floor plane, and, for :func:`robot_push` with a block, the thrown
block. The robot starts at its keyframe, lowered or raised so that its lowest sole point touches
the floor; the set point is the folded central body's pose there (COM over the feet as the
keyframe has it). Held joints keep their position servos at the keyframe angles; the legs get
the controller's torques every physics step (``ctrlrange`` clamps them to the joints'
``actuatorfrcrange``, which ``torque_limits="model"`` also puts inside the QP).

A push is either a COM velocity change ``push_m_s`` given to the whole robot at ``push_time_s``
(every body's velocity changes by the same vector: MuJoCo Playground's base-velocity kick, but
exact for the COM) or a block of ``block_mass_kg`` thrown at ``block_speed_m_s`` at a height.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from biped.control.distribution import QPWeights
from biped.control.limits import TorqueLimits
from biped.control.setpoint import Gains, Target
from biped.control.workspace import WorkspaceController
from biped.errors import ScenarioError
from biped.models.robot import (
    COLLISION_GROUP,
    RobotDescription,
    leg_torque_limits,
    plant_model,
    plant_spec,
    robot_soles,
    robot_tree,
)
from biped.sim.early_stop import AT_REST
from biped.sim.perturbations.platform import PLATFORM, PLATFORM_JOINT, add_platform
from biped.sim.robot_rest import BLOCK, BLOCK_JOINT, FLOOR, RobotRest
from biped.spatial import rot_to_quat

#: W Alg. 3's big-base factor on the robots: W's own. (It was 1e2 while robots stood on their
#: keyframes' straight knees, where the legs' Jacobians are singular and 1e6 threw them at once;
#: :mod:`biped.models.robot_pose` now crouches such legs; docs/robots.md.)
ROBOT_BIG_BASE = 1e6
#: W's push moved onto a robot (:func:`block_for`): W's block (1.8 kg, 4.5 m/s, 0.2 m/s up,
#: 1.2 m high against W's central-body COM at 1.035 m, 0.5 m from it), its mass scaled by the
#: robot's mass over W's biped's (73.06 kg), its height by the central-body COM heights.
W_BLOCK = {"mass_kg": 1.8, "speed_m_s": 4.5, "vz_m_s": 0.2, "height_m": 1.2, "com_m": 1.035, "gap_m": 0.5}


@dataclass(frozen=True)
class RobotRun:
    """One run: times (n,) [s], central-body COM (n, 3) [m], robot COM (n, 3) [m], leg torques
    (n, 12) [N m] as commanded (before the actuators' clamp), the limits (12,) [N m], whether it
    fell (central-body COM more than ``fall_drop_m`` below its set point) and when."""

    t: np.ndarray
    central_com: np.ndarray
    com: np.ndarray
    torques: np.ndarray
    limits: np.ndarray
    fell: bool
    fall_time_s: float | None
    target_com: np.ndarray
    mass: float
    #: the block's COM velocity (n, 3) [m/s] after each step (None: no block)
    block_velocity: np.ndarray | None = None
    #: the force pulse's impulse as applied (3,) [N s] (zeros: no pulse)
    force_impulse_n_s: np.ndarray | None = None
    #: why the run ended before ``seconds``: "fell", "at_rest" (``early_stop``), or None
    stop_reason: str | None = None
    #: the plant's qpos (n, nq) after each step (``record_qpos``; :func:`robot_plant`'s layout)
    qpos: np.ndarray | None = None
    #: with stepping: the steps taken (:attr:`biped.control.stepping.SteppingController.steps`)
    steps: list | None = None

    @property
    def max_torque_fraction(self) -> float:
        """Largest |commanded torque| / limit over the run (<= 1 when the QP respects them)."""
        return float(np.max(np.abs(self.torques) / self.limits))

    @property
    def final_offset_m(self) -> float:
        """Horizontal distance of the central-body COM from its set point at the end [m]."""
        return float(np.linalg.norm(self.central_com[-1, :2] - self.target_com[:2]))


@dataclass(frozen=True)
class Block:
    """A thrown cube: start position (3,) [m], velocity (3,) [m/s], mass [kg], edge [m]."""

    position_m: tuple
    velocity_m_s: tuple
    mass_kg: float
    size_m: float = 0.1


def block_for(
    desc: RobotDescription, w_biped_mass_kg: float, ctrl: WorkspaceController | None = None
) -> Block:
    """W's block moved onto the robot (:data:`W_BLOCK`), thrown from behind (-x: the robots
    face +x) at the central body's COM line."""
    ctrl = ctrl or robot_controller(desc, "statics", "none")
    c = ctrl.link_poses(standing_qpos(desc, ctrl))[0][:3, 3]
    w = W_BLOCK
    z = w["height_m"] / w["com_m"] * c[2]
    return Block(
        (float(c[0] - w["gap_m"]), float(c[1]), float(z)),
        (w["speed_m_s"], 0.0, w["vz_m_s"]),
        w["mass_kg"] * desc.mass / w_biped_mass_kg,
    )


@dataclass(frozen=True)
class ForcePulse:
    """A force ``force_n`` (3,) [N, world] from ``start_s`` for ``duration_s`` (whole physics
    steps), ``shape`` "rectangular" or "half-sine", at the midpoint of the two hip joints (W's
    "pelvis" point) on the floating body: MuJoCo's ``xfrc_applied`` of that body, the force at its
    COM plus the moment of the point's offset, recomputed every physics step."""

    force_n: tuple
    start_s: float
    duration_s: float
    shape: str = "rectangular"


@dataclass(frozen=True)
class PlatformMove:
    """The floor under the robot moves by ``displacement_m`` (x, y) [m] along the trapezoidal
    ramp-and-hold of :func:`biped.sim.perturbations.platform.profile`, from ``start_s`` for
    ``duration_s``: W's platform (:mod:`biped.sim.perturbations.platform`, the same slab, servo
    and feed-forward) under the robot's feet, the controller's set point riding with it."""

    displacement_m: tuple
    start_s: float
    duration_s: float

    @property
    def distance_m(self) -> float:
        return float(np.hypot(*self.displacement_m))

    @property
    def axis(self) -> tuple:
        d = np.array([*self.displacement_m, 0.0])
        n = float(np.linalg.norm(d))
        return tuple(d / n) if n > 0 else (1.0, 0.0, 0.0)


@dataclass(frozen=True)
class PullMove:
    """W's waist pull (:mod:`biped.sim.perturbations.pull`: a stiff, pull-only cable from a motor
    travelling ``displacement_m`` (x, y) [m] at a peak ``velocity_m_s`` from ``start_s``, then let
    go) fixed at the midpoint of the robot's hip joints on its floating body."""

    displacement_m: tuple
    velocity_m_s: float
    start_s: float


#: The plant's physics step: the file's, at most this [s] (the controller runs every step).
MAX_TIMESTEP_S = 0.002


def _pair_colliders(spec: mujoco.MjSpec, desc: RobotDescription, block: bool, floor: str = FLOOR) -> None:
    """Geoms that collide only through explicit pairs (:data:`~biped.models.robot.COLLISION_GROUP`,
    contype and conaffinity 0) get pairs with the floor (the feet's; ``floor``, the platform's slab
    when it is the floor) and the block (all)."""
    m = plant_model(desc)  # the file's geoms (the floor and block are added by name)
    pair_only = [
        g
        for g in range(m.ngeom)
        if m.geom_group[g] == COLLISION_GROUP and not (m.geom_contype[g] or m.geom_conaffinity[g])
    ]
    if not pair_only:
        return
    feet = {m.body(f).id for f in desc.feet}
    for g in pair_only:
        name = m.geom(g).name
        if not name:  # a pair needs names; unnamed pair-only geoms stay inert
            continue
        if m.geom_bodyid[g] in feet:
            spec.add_pair(geomname1=name, geomname2=floor, condim=3)
        if block:
            spec.add_pair(geomname1=name, geomname2=BLOCK, condim=3)


def robot_plant(
    desc: RobotDescription,
    block: Block | None = None,
    timestep_s: float | None = None,
    platform_axis: tuple | None = None,
):
    """The compiled plant of :func:`robot_push`: the robot's model edited at load
    (:func:`~biped.models.robot.plant_spec`), a floor plane, ``block`` (a free cube) if any, and
    W's platform sliding along ``platform_axis`` (3,) if given; the robot's qpos first, then the
    block's, then the platform's. Kept per process (:data:`_PLANTS`): loading a
    robot's file and meshes costs ~0.1 s, more than a second of its simulation; a plant is only
    read (each run makes its own ``MjData``)."""
    key = (
        str(desc.path),
        desc.path.stat().st_mtime_ns,
        desc.root,
        desc.feet,
        desc.leg_joints,
        desc.held_joints,
        None if block is None else (block.mass_kg, block.size_m),
        timestep_s,
        platform_axis,
    )
    m = _PLANTS.get(key)
    if m is None:
        if len(_PLANTS) >= 8:
            _PLANTS.clear()
        m = _PLANTS[key] = _compile_plant(desc, block, timestep_s, platform_axis)
    return m


#: Compiled plants by what they are made of (:func:`robot_plant`), a few per process.
_PLANTS: dict[tuple, mujoco.MjModel] = {}


def _compile_plant(
    desc: RobotDescription, block: Block | None, timestep_s: float | None, platform_axis: tuple | None
) -> mujoco.MjModel:
    spec = plant_spec(desc)
    floor = spec.worldbody.add_geom(name=FLOOR, type=mujoco.mjtGeom.mjGEOM_PLANE, size=[10, 10, 0.1])
    if block is not None:
        b = spec.worldbody.add_body(name=BLOCK, pos=list(block.position_m))
        b.add_freejoint(name=BLOCK_JOINT)
        b.add_geom(
            name=BLOCK, type=mujoco.mjtGeom.mjGEOM_BOX, size=[block.size_m / 2] * 3, mass=block.mass_kg
        )
    if platform_axis is not None:
        add_platform(spec, floor, platform_axis)
    _pair_colliders(spec, desc, block is not None, FLOOR if platform_axis is None else PLATFORM)
    spec.option.timestep = timestep_s or min(spec.option.timestep, MAX_TIMESTEP_S)
    return spec.compile()


def robot_controller(desc: RobotDescription, distribution: str = "qp", torque_limits: str = "model", **kw):
    """W's controller on the robot's folded tree; ``torque_limits`` "model" (the joints'
    ``actuatorfrcrange`` inside the QP) or "none"."""
    tree = robot_tree(desc)
    kw.setdefault("gains", Gains())
    return WorkspaceController(
        tree,
        distribution=distribution,
        torque_limits=robot_torque_limits(desc, tree, torque_limits),
        soles=robot_soles(desc),
        **kw,
    )


def robot_qp_weights(distribution: str, floor_friction: bool) -> QPWeights | None:
    """The QP's weights on a robot: W's, with the friction pyramid on the floor's axes
    (``floor_friction``: W's scenario key ``qp_floor_friction``) or the sole's; None without
    the QP. The one rule of :func:`robot_push`'s controller and the stepping controller's
    feet-in-place QP (:func:`biped.sim.robot_stepping.robot_stepper`)."""
    return QPWeights(floor_friction=floor_friction) if distribution == "qp" else None


def robot_torque_limits(desc: RobotDescription, tree, torque_limits: str) -> TorqueLimits | None:
    """The legs' torque limits of ``torque_limits``: "model" (the joints' ``actuatorfrcrange``,
    in ``tree``'s joint order) or "none" (None); anything else is refused."""
    if torque_limits == "model":
        lo, hi = leg_torque_limits(desc).T
        return TorqueLimits("model", tree.joint_names, lo, hi)
    if torque_limits != "none":
        raise ScenarioError(f"unknown torque_limits {torque_limits!r} for a robot; valid: 'model', 'none'")
    return None


def _actuator(m: mujoco.MjModel, joint: str) -> int:
    j = m.joint(joint).id
    return int(next(a for a in range(m.nu) if m.actuator_trnid[a, 0] == j))


def standing_qpos(desc: RobotDescription, ctrl: WorkspaceController) -> np.ndarray:
    """The keyframe's qpos with the robot moved vertically so that its lowest sole corner is on z = 0."""
    q = desc.key_qpos.copy()
    g = ctrl.link_poses(q)
    soles = robot_soles(desc)
    corners = [
        (g[f] @ s.g_foot_sole @ np.array([i * s.half_length, j * s.half_width, 0.0, 1.0]))[2]
        for f, s in zip(ctrl.tree.feet, soles, strict=True)
        for i in (-1, 1)
        for j in (-1, 1)
    ]
    z = min(corners)
    q[ctrl.tree.qpos_adr[0] + 2] -= z
    return q


def robot_push(
    desc: RobotDescription,
    seconds: float = 3.0,
    *,
    push_m_s: tuple[float, float, float] = (0.0, 0.0, 0.0),
    push_time_s: float = 0.5,
    distribution: str = "qp",
    torque_limits: str = "model",
    fall_drop_m: float = 0.15,
    timestep_s: float | None = None,
    big_base: float = ROBOT_BIG_BASE,
    block: Block | None = None,
    force: ForcePulse | None = None,
    early_stop: bool = False,
    record_qpos: bool = False,
    platform: PlatformMove | None = None,
    pull: PullMove | None = None,
    stepping=None,
    release=None,
    qp_floor_friction: bool = False,
) -> RobotRun:
    """Stand the robot for ``seconds`` under W's controller, kicked by ``push_m_s`` of COM
    velocity change at ``push_time_s`` (zero: no push) and/or hit by ``block`` (thrown at t = 0)
    and/or carried by the floor's ``platform`` move;
    stops early when it falls, and with ``early_stop`` when it is at rest (:class:`RobotRest`);
    ``record_qpos``: keep the plant's qpos after every step (:attr:`RobotRun.qpos`, for replays);
    ``stepping`` (a :class:`~biped.control.stepping_config.SteppingConfig`): capture-point steps
    (:mod:`biped.sim.robot_stepping`), the run judged against the set point moved with the feet;
    ``release`` (a :class:`~biped.sim.robot_release.ReleaseLean`): W's lean-and-release, the run
    starting leaned and tethered (:mod:`biped.sim.robot_release`); ``qp_floor_friction``: the
    QP's friction pyramid on the floor's axes (W's scenario key, ``QPWeights.floor_friction``)."""
    qp = robot_qp_weights(distribution, qp_floor_friction)
    ctrl = robot_controller(desc, distribution, torque_limits, big_base=big_base, qp_weights=qp)
    q0 = standing_qpos(desc, ctrl)
    g = ctrl.link_poses(q0)[0]
    ctrl.target = Target(com=tuple(g[:3, 3]), quat=tuple(rot_to_quat(np.ascontiguousarray(g[:3, :3]))))
    m = robot_plant(desc, block, timestep_s, None if platform is None else platform.axis)
    d = mujoco.MjData(m)
    tree = ctrl.tree
    if m.nq != tree.nq + (7 if block is not None else 0) + (1 if platform is not None else 0):
        raise ScenarioError("internal: the plant's qpos layout differs from the file's")
    d.qpos[: tree.nq] = q0
    if block is not None:
        bj = m.joint(BLOCK_JOINT)
        d.qpos[bj.qposadr[0] : bj.qposadr[0] + 7] = [*block.position_m, 1, 0, 0, 0]
        d.qvel[bj.dofadr[0] : bj.dofadr[0] + 3] = block.velocity_m_s
    legs = np.array([_actuator(m, j) for j in tree.joint_names])
    for j in desc.held_joints:
        d.ctrl[_actuator(m, j)] = q0[m.jnt_qposadr[m.joint(j).id]]
    lim = np.array([m.actuator_ctrlrange[a, 1] for a in legs])
    n = int(round(seconds / m.opt.timestep))
    t, cc, com, tau = np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 12))
    qpos = np.zeros((n, m.nq)) if record_qpos else None
    bv = np.zeros((n, 3)) if block is not None else None
    bq = m.joint(BLOCK_JOINT).dofadr[0] if block is not None else 0
    root_v = tree.dof_adr[0]
    kick = int(round(push_time_s / m.opt.timestep))
    rb = m.body(desc.root).id
    hips = [m.joint(tree.joint_names[k]).id for k in range(12) if tree.parent[k + 1] == 0]
    f0 = f1 = -1
    impulse = np.zeros(3)
    if force is not None:
        f0 = int(round(force.start_s / m.opt.timestep))
        f1 = f0 + max(1, int(round(force.duration_s / m.opt.timestep)))
    target = g[:3, 3].copy()  # where the run is judged: the set point, moved with the platform
    drive = _platform_drive(m, ctrl, platform) if platform is not None else None
    if platform is not None:
        target[:2] += platform.distance_m * np.asarray(platform.axis)[:2]
    fell_at = None
    others = [int(m.jnt_dofadr[m.joint(PLATFORM_JOINT).id])] if platform is not None else []
    rest = RobotRest(m, desc, block is not None, target, others) if early_stop else None
    cable = _cable(m, d, rb, hips, pull) if pull is not None else None
    stepper: Any = None
    feet: Any = None
    floor_z = g[2, 3]  # a fall: the central-body COM fall_drop_m below this (lowered while stepping)
    if stepping is not None:
        if platform is not None:
            raise ScenarioError("stepping on a moving platform is not available on robots yet")
        from biped.sim.robot_stepping import FootContacts, robot_stepper, set_point_height

        stepper = robot_stepper(
            desc, q0, ctrl.target, stepping, distribution, torque_limits, big_base, qp_floor_friction, tree
        )
        feet = FootContacts(m, desc, FLOOR)
    lean = None
    if release is not None:  # the leaned, tethered start; the set point upright at the release
        from biped.sim.robot_release import release_driver

        lean = release_driver(desc, m, d, ctrl, q0, release, n, m.geom(FLOOR).id, stepper)
        floor_z = min(floor_z, float(lean.hold["hold_com"][2]))
    ends = (kick if np.any(push_m_s) else 0, f1 + 1, drive.last + 1 if drive is not None else 0)
    over = max(*ends, cable.k1 + 1 if cable is not None else 0, lean.k_sense + 1 if lean is not None else 0)
    stopped = None
    for i in range(n):
        if i == kick and np.any(push_m_s):
            # free joint linear velocity is in the world frame in MuJoCo: every body gets +dv
            d.qvel[root_v : root_v + 3] += np.asarray(push_m_s, float)
        if force is not None and f0 <= i <= f1:
            d.xfrc_applied[rb] = 0.0
            if i < f1:
                w = 1.0 if force.shape == "rectangular" else np.sin(np.pi * (i - f0 + 0.5) / (f1 - f0))
                f = w * np.asarray(force.force_n, float)
                p = d.xanchor[hips].mean(axis=0)  # the hip joints' midpoint, world [m]
                d.xfrc_applied[rb, :3] = f
                d.xfrc_applied[rb, 3:] = np.cross(p - d.xipos[rb], f)
                impulse += f * m.opt.timestep
        if cable is not None:  # the cable's tension at the hips' midpoint (held over the step)
            cable.apply(i, float(d.time), d)
        if drive is not None:  # the platform's servo references; the set point rides with it
            drive.apply(i, d.qpos, d.ctrl)
        if lean is not None:  # the tether and the held set point; both gone at the release
            lean.apply(i, float(d.time), d)
        if stepper is not None:  # the robot's own layout comes first
            u = stepper(float(d.time), d.qpos[: tree.nq], d.qvel[: tree.nv], feet(d))
            target[:2] = stepper.target.com[:2]  # the set point moved with the feet
            floor_z = set_point_height(stepper)
            if rest is not None:
                rest.target[:] = target[:2]
        else:
            u = ctrl.torques(d.qpos[: tree.nq], d.qvel[: tree.nv])
        tau[i] = u
        d.ctrl[legs] = u
        mujoco.mj_step(m, d)
        t[i] = d.time
        if qpos is not None:
            qpos[i] = d.qpos
        if bv is not None:
            bv[i] = d.qvel[bq : bq + 3]
        cc[i] = ctrl.link_poses(d.qpos[: tree.nq])[0][:3, 3] if i % 10 == 0 or i == n - 1 else cc[i - 1]
        com[i] = d.subtree_com[m.body(desc.root).id]
        if cc[i, 2] < floor_z - fall_drop_m:
            fell_at = float(d.time)
        elif rest is not None and rest.update(d, cc[i], i >= over):
            stopped = AT_REST
        if fell_at is not None or stopped is not None:
            t, cc, com, tau = t[: i + 1], cc[: i + 1], com[: i + 1], tau[: i + 1]
            bv = bv[: i + 1] if bv is not None else None
            break
    reason = "fell" if fell_at is not None else stopped
    if qpos is not None:
        qpos = qpos[: len(t)]
    return RobotRun(
        t,
        cc,
        com,
        tau,
        lim,
        fell_at is not None,
        fell_at,
        target,
        desc.mass,
        bv,
        impulse if cable is None else cable.impulse.copy(),
        reason,
        qpos,
        None if stepper is None else [dict(s) for s in stepper.steps],
    )


def _keys(m: mujoco.MjModel, **keys):
    """The scenario keys a W perturbation driver reads, its control period the plant's physics
    step (the robot's controller runs every step)."""
    from types import SimpleNamespace

    return SimpleNamespace(control_rate_hz=1.0 / float(m.opt.timestep), **keys)


def _platform_drive(m: mujoco.MjModel, ctrl: WorkspaceController, platform: PlatformMove):
    """W's platform schedule (:class:`~biped.sim.perturbations.platform.PlatformDriver`): the
    servo's references each step of the ramp, the controller's set point (``ctrl.target``, the
    standing one at offset 0) riding with the slab."""
    from biped.sim.perturbations.platform import PlatformDriver

    keys = _keys(
        m,
        platform_displacement_m=tuple(platform.displacement_m),
        platform_start_s=float(platform.start_s),
        platform_duration_s=float(platform.duration_s),
    )
    schedule = PlatformDriver(keys, m, ctrl).schedule
    assert schedule is not None
    schedule.base[:] = ctrl.target.array[:3]
    return schedule


def _cable(m: mujoco.MjModel, d: mujoco.MjData, body: int, hips: list, pull: PullMove):
    """W's pull driver (:class:`~biped.sim.perturbations.pull.PullDriver`) on the robot, its pelvis
    point the hips' midpoint in the floating body's frame at the start."""
    from biped.sim.perturbations.pull import PullDriver

    mujoco.mj_kinematics(m, d)
    mid = d.xanchor[hips].mean(axis=0)
    point = d.xmat[body].reshape(3, 3).T @ (mid - d.xpos[body])
    keys = _keys(
        m,
        pull_displacement_m=tuple(pull.displacement_m),
        pull_velocity_m_s=float(pull.velocity_m_s),
        pull_start_s=float(pull.start_s),
    )
    return PullDriver(keys, m, body, point, None)
