"""Stepping on a robot's own MJCF: the capture-point stepping controller
(:class:`biped.control.stepping.SteppingController`) with the robot's structure
(:func:`robot_stepping_body`), W's stepping parameters scaled to its legs
(:func:`scaled_stepping`), and the plant's contact flags per foot (:class:`FootContacts`).

**Structure.** The stepping model is the robot's file as loaded (the plant's qpos layout, held
joints included: the whole-body COM, mass matrix and bias forces are the plant's). Legs, feet,
shank (4th hinge's body) and leg length by :mod:`biped.control.stepping_body`'s place rules; the
hip point is the origin of the leg's *first* hinge's body (a robot's hip hinges are spread along
its thigh: G1's yaw hinge is 13 cm below its pitch hinge; W's three meet at one point); the
soles are the robot's (:func:`biped.models.robot.robot_soles`, their axes in the foot frame
kept: Berkeley Humanoid's foot frame is turned 90 deg from its sole); the set point the standing
one, tilted about the robot's left axis; the swing law the 6-dof task of
:func:`biped.control.swing_task.swing_pose_torques` (the foot landing at its standing
orientation); the landing limits applied in W's facing (the robots face +x, W's biped -x).

**Scaling rule** (:func:`scaled_stepping`; one set of parameters, W's, for every robot). With
``s = L / L_W`` (leg lengths by :func:`biped.control.stepping_body.leg_length`, W's 0.826 m) and
``w = B / B_W`` (the stance width: the horizontal distance between the feet bodies' origins at
the standing pose, W's 0.168 m):

- lengths along the body and vertical scale by s: the trigger's and dwell's margins, offset_m,
  apex_m, reach_m, the swing and post-step height drops, the landing limits' max_back, the
  crossover's clearance crossover_clear_m;
- but the reach is at least the hip-to-foot distance D at the standing pose (W stands at 83 % of
  its reach; G1, crouched only off the singularity, beyond 0.944 L), and while a foot swings the
  stance hip is lowered at least to W's standing crouch, ``D - (D_W / L_W) L`` (W: D_W / L_W =
  0.78; G1 stands at 0.99 L: with only s x 0.08 m its swing foot, pulled back within the reach,
  hung 2 cm over the floor past the swing time while the capture point ran sideways), and so is
  the set point after the step (T1 stands at 0.96 L: with only s x 0.08 m, holding the height
  with its trunk pitched forward straightened the front leg into its singularity);
- lengths across the body by w: min_width, max_width of both limits, lateral_margin_m,
  lateral_offset_m, side_margin_m; a limit's max_step keeps its split, ``sqrt((s f)^2 + (w B_W)^2)`` with ``f =
  sqrt(max_step^2 - B_W^2)`` W's forward step at its stance width;
- times and speeds by sqrt(s), gains (1/s^2, 1/s) by 1/s and 1/sqrt(s): dynamic similarity
  (equal Froude numbers): swing times, refractory, settle and dwell times, the descent and
  settle speeds, the swing foot's and the post-step gains. W's controller's own gains stay W's.

A biped of W's size (s = w = 1, D = D_W) gets W's numbers.

**Robots' rules** (docs/robots.md, "Stepping on a robot"; W's stepping keeps both off):

- ``ROBOT_ANKLE_POLYGON``: the trigger judges the capture point against the CoPs the ankles'
  torque limits hold (``SteppingConfig.ankle_limited_polygon``), the region the QP with those
  limits can give: each sole cut along its length to within ``tau_max / (w m g)`` of its 5th
  hinge's axis when it carries the share w of the weight, both feet's shares summing to 1. T1's
  ankle pitch (20 N m) holds its 31.6 kg only 6.5 cm ahead of its axis with all the weight on
  one foot, short of its toes: after its first step it stood with the capture point inside the
  geometric sole, its front ankle at the limit and its trunk pitching, and stepped again too
  late. With both feet side by side the two ankles hold 2 x 6.5 cm (the first slice cut each
  sole to the whole weight's reach there too, and T1's diagonal steps started early and fell).
- ``ROBOT_ANKLE_RANGE_DROPS``: a robot whose ankles' joint ranges cannot take the scaled
  post-step height drop (:func:`biped.models.robot_pose.ankle_crouch_m`: the standing pose's
  crouch, knee 2a, hip and ankle -a, until an ankle hinge reaches its range's end) keeps its
  standing height after a step. Berkeley Humanoid's ankle pitch stands 10 deg from its range's
  end (3.7 cm of crouch against the 5.0 cm drop): after a backward step, crouched with the foot
  behind, its ankle sat at the end of its range, the foot off flat, and every backward step fell
  (docs/robots.md, "Why Berkeley Humanoid's steps fail"). G1's, T1's and Apollo's ankles take
  14-63 cm: their parameters are unchanged.
- ``ROBOT_ANKLE_LIMITED_RULES``: a robot whose ankle holds the CoP, with the whole weight on the
  foot, more than the trigger's re-arm margin short of its sole's toe or heel
  (:func:`ankle_limited`: T1, 5.8 cm short of its toes; G1, Berkeley Humanoid and Apollo reach
  theirs, Apollo's toe within 4 mm) falls back on the hip strategy after a step, its trunk
  pitching: it keeps the swing's crouch after the step while its COM moves, rising to the rule's
  drop as the COM comes to rest (``SteppingConfig.post_step_rest_drop_m``; T1 stands at 0.96 of
  its leg, and holding the height with its trunk pitched straightened its front leg into the
  knee's singularity), and its stance takes the swing leg's reaction of the torques the actuators
  give (``SteppingConfig.swing_reaction``, clipped to the limits as the plant gets them: T1's swing
  torques run at 50-80 % of its limits, median per step). On G1 and Apollo the crouch and the
  reaction lowered envelope cells (G1 45 deg 63 -> 62 %, Apollo from behind 96 -> 91 %).
"""

from __future__ import annotations

import functools
import math
from dataclasses import replace

import mujoco
import numpy as np

from biped.control import capture as cp
from biped.control.policy import PolicyConfig
from biped.control.setpoint import Target
from biped.control.stepping import SteppingConfig, SteppingController
from biped.control.stepping_body import (
    SteppingBody,
    ankle_axis_along_sole,
    ankle_reaches,
    facing_rotation,
    leg_chains,
    leg_length,
    sole_pose,
    w_body,
)
from biped.control.stepping_config import QP_MAX_BACK_M
from biped.control.swing_task import swing_pose_torques
from biped.errors import ModelError
from biped.model import TreeModel
from biped.models.robot import RobotDescription, plant_model, robot_soles, robot_tree
from biped.sim.measure import subtree
from biped.spatial import axis_angle_quat, quat_mul, quat_to_rot, transform

__all__ = [
    "ROBOT_ANKLE_POLYGON",
    "ROBOT_ANKLE_LIMITED_RULES",
    "ROBOT_ANKLE_RANGE_DROPS",
    "ankle_range_drops",
    "ankle_limited",
    "FootContacts",
    "robot_stepper",
    "robot_stepping_body",
    "scaled_stepping",
    "set_point_height",
    "w_size",
]


#: The robots' backward landing limit with W's "qp" set, before scaling [m]: the 0.40 m they were
#: measured with (W's biped and subjects step back up to ``QP_MAX_BACK_M`` since the knee-carried
#: drop; the robots, with their own crouch and no knee-carried drop, were not re-measured).
ROBOT_QP_MAX_BACK_M = 0.40

#: A robot's step trigger judges the capture point against the CoPs its ankles' torque limits can
#: hold, the weight shared between the feet in any way (``SteppingConfig.ankle_limited_polygon``;
#: module docstring, "Robots' rules").
ROBOT_ANKLE_POLYGON = True
#: A robot whose ankles' joint ranges cannot take its post-step height drop with the feet flat
#: keeps its standing height after a step (:func:`ankle_range_drops`; module docstring, "Robots'
#: rules").
ROBOT_ANKLE_RANGE_DROPS = True
#: A robot whose ankles cannot hold its CoP at its toes (:func:`ankle_limited`) keeps the crouch
#: after a step while its COM moves and feeds the swing leg's reaction (of the torques its
#: actuators give) to its stance (module docstring, "Robots' rules").
ROBOT_ANKLE_LIMITED_RULES = True


def ankle_range_drops(config: SteppingConfig, body: SteppingBody, qpos: np.ndarray) -> SteppingConfig:
    """``config`` with its post-step height drop set to 0 when it is deeper than the crouch the
    ankles' joint ranges take at the standing pose ``qpos``
    (:func:`biped.models.robot_pose.ankle_crouch_m`: the standing pose's crouch, the feet flat;
    module docstring, "Robots' rules"). The swing's drop is kept (with it 0 as well Berkeley
    Humanoid's diagonal and sideways envelopes lost 1-6 % of J_max; docs/robots.md)."""
    from biped.models.robot_pose import ankle_crouch_m

    m = body.model
    joints = [int(m.joint(j).id) for leg in body.leg_joints for j in leg]
    if config.post_step_height_drop_m <= ankle_crouch_m(m, qpos, body.feet, joints):
        return config
    return replace(config, post_step_height_drop_m=0.0)


def ankle_limited(body: SteppingBody, d: mujoco.MjData, lim, joint_names, tolerance_m: float) -> bool:
    """Whether a foot's ankle (its 5th hinge's torque limit, the whole weight on the foot) holds
    the CoP more than ``tolerance_m`` short of where the sole reaches ahead of or behind the
    hinge's axis, at the pose of ``d`` (MuJoCo's data of ``body.model``, after kinematics);
    ``lim`` the legs' torque limits in ``joint_names`` order (the stepping controller's
    ``ankle_limited_polygon`` measures the same reach and hinge axis)."""
    for k, (joint, reach) in enumerate(ankle_reaches(body, lim, joint_names)):
        centre, yaw = sole_pose(body, d, k)
        ax, hl = ankle_axis_along_sole(d, joint, centre, yaw), body.soles[k][1]
        if reach < max(hl - ax, hl + ax) - tolerance_m:
            return True
    return False


@functools.cache
def w_size() -> tuple[float, float, float]:
    """(leg length, stance width, hip-to-foot distance standing) [m] of W's biped by the rules of
    :func:`scaled_stepping`."""
    from biped import models
    from biped.model import TreeModel

    m = mujoco.MjModel.from_xml_path(str(models.path("wendlandt")))
    body = w_body(m, TreeModel.from_mjcf(m))
    d = mujoco.MjData(m)
    d.qpos[:] = m.key_qpos[0]
    mujoco.mj_kinematics(m, d)
    stand = float(np.linalg.norm(d.xpos[body.hips[0]] - d.xpos[body.feet[0]]))
    return body.leg_length_m, _hip_width(d, body.feet), stand


def _hip_width(d: mujoco.MjData, hips) -> float:
    return float(np.linalg.norm(d.xpos[hips[0]][:2] - d.xpos[hips[1]][:2]))


def _limits(lim: cp.StepLimits, s: float, w: float, width_w: float) -> cp.StepLimits:
    f = math.sqrt(max(lim.max_step**2 - width_w**2, 0.0))
    return cp.StepLimits(
        max_step=math.hypot(s * f, w * width_w),
        min_width=w * lim.min_width,
        max_width=w * lim.max_width,
        max_back=s * lim.max_back,
    )


def scaled_stepping(
    config: SteppingConfig, leg_length_m: float, hip_width_m: float, stance_reach_m: float = 0.0
) -> SteppingConfig:
    """W's stepping parameters ``config`` for a biped of leg length ``leg_length_m``, stance
    width ``hip_width_m`` and hip-to-foot distance ``stance_reach_m`` standing (the module's rule)."""
    L_w, B_w, D_w = w_size()
    s, w = leg_length_m / L_w, hip_width_m / B_w
    r = math.sqrt(s)
    crouch = stance_reach_m - D_w / L_w * leg_length_m  # the drop to W's standing crouch [m]
    if not (s > 0 and w > 0):
        raise ModelError(f"stepping: leg length {leg_length_m} m and hip width {hip_width_m} m must be > 0")
    return replace(
        config,
        margin_m=s * config.margin_m,
        rearm_margin_m=s * config.rearm_margin_m,
        dwell_margin_m=s * config.dwell_margin_m,
        offset_m=s * config.offset_m,
        apex_m=s * config.apex_m,
        reach_m=max(s * config.reach_m, stance_reach_m),
        swing_height_drop_m=max(s * config.swing_height_drop_m, crouch),
        post_step_height_drop_m=s * config.post_step_height_drop_m,
        post_step_rest_drop_m=None
        if config.post_step_rest_drop_m is None
        else s * config.post_step_rest_drop_m,
        lateral_margin_m=w * config.lateral_margin_m,
        lateral_offset_m=w * config.lateral_offset_m,
        side_margin_m=w * config.side_margin_m,
        crossover_clear_m=s * config.crossover_clear_m,
        limits=_limits(config.limits, s, w, B_w),
        lateral_limits=_limits(config.lateral_limits, s, w, B_w),
        # dynamic similarity (equal Froude numbers): times and speeds by sqrt(s), gains by 1 / s
        swing_time_s=r * config.swing_time_s,
        lateral_swing_time_s=r * config.lateral_swing_time_s,
        refractory_s=r * config.refractory_s,
        settle_after_s=None if config.settle_after_s is None else r * config.settle_after_s,
        dwell_s=None if config.dwell_s is None else r * config.dwell_s,
        descent_m_s=r * config.descent_m_s,
        settle_speed_m_s=r * config.settle_speed_m_s,
        trigger_rate_m_s=None if config.trigger_rate_m_s is None else r * config.trigger_rate_m_s,
        kp_pos=config.kp_pos / s,
        kv_pos=config.kv_pos / r,
        kp_rot=config.kp_rot / s,
        kv_rot=config.kv_rot / r,
        post_step_kp_xy=config.post_step_kp_xy / s,
        post_step_kv_xy=config.post_step_kv_xy / r,
    )


def robot_stepping_body(
    desc: RobotDescription, qpos: np.ndarray, target: Target, tree: TreeModel | None = None
) -> SteppingBody:
    """The stepping controller's structure of the robot ``desc`` (the module's rules), at its
    standing pose ``qpos`` (the plant's layout) with the standing set point ``target``; ``tree``:
    the robot's :func:`~biped.models.robot.robot_tree` if already built."""
    from biped.sim.robot import ROBOT_BIG_BASE

    tree = robot_tree(desc) if tree is None else tree
    legs = leg_chains(tree)
    m = plant_model(desc)
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    bodies = [[int(m.jnt_bodyid[m.joint(j).id]) for j in leg] for leg in legs]
    feet = (bodies[0][5], bodies[1][5])
    if tuple(m.body(b).name for b in feet) != tuple(desc.feet):
        raise ModelError(
            f"stepping: the legs end at {[m.body(b).name for b in feet]}, not the feet {desc.feet}"
        )
    from biped.models.robot import controller_model

    cm = controller_model(desc)  # the soles are in its (fused) foot's inertial frame
    rects = robot_soles(desc)
    soles, axes, rots = [], [], []
    for b, s in zip(feet, rects, strict=True):
        cb = cm.body(m.body(b).name).id
        g = (
            transform(quat_to_rot(cm.body_iquat[cb]), cm.body_ipos[cb]) @ s.g_foot_sole
        )  # sole in the body frame
        soles.append((g[:3, 3].copy(), float(s.half_length), float(s.half_width)))
        axes.append(g[:3, :3].copy())
        rots.append(d.xmat[b].reshape(3, 3).copy())
    centres = [d.xpos[b] + R @ c[0] for b, R, c in zip(feet, rots, soles, strict=True)]
    facing = facing_rotation(centres[0][:2], centres[1][:2])
    left = centres[0] - centres[1]
    left[2] = 0.0
    left /= np.linalg.norm(left)  # forward tilt: about the left axis

    def make_target(com, tilt_deg: float) -> Target:
        if tilt_deg == 0.0:
            return replace(target, com=tuple(com))
        q = quat_mul(axis_angle_quat(left, math.radians(tilt_deg)), np.asarray(target.quat, float))
        return replace(target, com=tuple(com), quat=tuple(q))

    lengths = [leg_length(m, d, leg, b[0]) for leg, b in zip(legs, bodies, strict=True)]
    return SteppingBody(
        model=m,
        root=int(m.body(desc.root).id),
        feet=feet,
        hips=(bodies[0][0], bodies[1][0]),
        shanks=(bodies[0][3], bodies[1][3]),
        leg_joints=legs,
        soles=(soles[0], soles[1]),
        inversion_sign=(0.0, 0.0),  # W's swing law only
        leg_length_m=0.5 * (lengths[0] + lengths[1]),
        target=make_target,
        swing=swing_pose_torques,
        sole_axes=(axes[0], axes[1]),
        foot_rotation=(rots[0], rots[1]),
        facing=facing,
        controller_soles=rects,
        big_base=ROBOT_BIG_BASE,
    )


def robot_stepper(
    desc: RobotDescription,
    qpos: np.ndarray,
    target: Target,
    stepping: SteppingConfig,
    distribution: str = "qp",
    torque_limits: str = "model",
    big_base: float | None = None,
    floor_friction: bool = False,
    tree: TreeModel | None = None,
) -> SteppingController:
    """The stepping controller on the robot: W's controller and QP with the robot's soles and
    ``torque_limits`` ("model": the joints' ``actuatorfrcrange``), ``stepping`` scaled
    (:func:`scaled_stepping`), its set point ``target`` at the standing pose ``qpos``;
    ``floor_friction``: the feet-in-place QP's (before the first step) friction pyramid on the
    floor's axes (W's ``qp_floor_friction``; the stepping QP's is ``stepping.floor_friction``);
    ``tree``: the robot's :func:`~biped.models.robot.robot_tree` if already built (the plant
    controller's: it is immutable)."""
    tree = robot_tree(desc) if tree is None else tree
    body = robot_stepping_body(desc, qpos, target, tree)
    if big_base is not None:
        body = replace(body, big_base=big_base)
    from biped.sim.robot import robot_qp_weights, robot_torque_limits  # (robot.py imports this module)

    lim = robot_torque_limits(desc, tree, torque_limits)
    d = mujoco.MjData(body.model)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(body.model, d)
    config = PolicyConfig(
        target=target,
        torque_limits=lim,
        distribution=distribution,
        qp_weights=robot_qp_weights(distribution, floor_friction),
        model_path=str(desc.path),
    )
    stand = max(
        float(np.linalg.norm(d.xpos[h] - d.xpos[f])) for h, f in zip(body.hips, body.feet, strict=True)
    )
    if stepping.limits.max_back == QP_MAX_BACK_M:  # W's "qp" set: the robots' earlier backward limit
        stepping = replace(stepping, limits=replace(stepping.limits, max_back=ROBOT_QP_MAX_BACK_M))
    scaled = scaled_stepping(stepping, body.leg_length_m, _hip_width(d, body.feet), stand)
    # the robots keep their own crouch (the drops above, the rules below: off their straight knees)
    scaled = replace(scaled, knee_carried_drop=False)
    if ROBOT_ANKLE_RANGE_DROPS:  # a post-step crouch the ankles' joint ranges cannot take: none
        scaled = ankle_range_drops(scaled, body, qpos)
    if ROBOT_ANKLE_POLYGON and lim is not None:
        scaled = replace(scaled, ankle_limited_polygon=True)
    if (
        ROBOT_ANKLE_LIMITED_RULES
        and lim is not None
        and ankle_limited(body, d, lim, tree.joint_names, scaled.rearm_margin_m)
    ):
        # the ankles, not the soles, bound the CoP: the crouch after a step while the COM moves
        # (back to the rule's drop at rest) and the swing leg's reaction (module docstring)
        scaled = replace(
            scaled,
            post_step_height_drop_m=max(scaled.post_step_height_drop_m, scaled.swing_height_drop_m),
            post_step_rest_drop_m=scaled.post_step_height_drop_m,
            swing_reaction=True,
        )
    from biped.control.setpoint import Gains

    config = replace(config, gains=Gains())  # the robots' gains (W's, as robot_controller takes)
    return SteppingController(config, scaled, tree.joint_names, tree=tree, body=body)


class FootContacts:
    """``(left, right)``: whether each foot touches the floor in the plant's ``MjData``: a
    contact between the floor geom ``floor`` and a geom of the foot body or of a body fused
    into it (its subtree in the plant: the feet are the legs' last jointed bodies)."""

    def __init__(self, m: mujoco.MjModel, desc: RobotDescription, floor: str):
        self.floor = int(m.geom(floor).id)
        self.geom_foot = np.full(m.ngeom, -1, dtype=int)
        for k, name in enumerate(desc.feet):
            self.geom_foot[np.isin(m.geom_bodyid, subtree(m, m.body(name).id))] = k

    def __call__(self, d: mujoco.MjData) -> tuple[bool, bool]:
        out = [False, False]
        for c in range(d.ncon):
            g1, g2 = d.contact.geom1[c], d.contact.geom2[c]
            other = g2 if g1 == self.floor else g1 if g2 == self.floor else -1
            if other >= 0 and self.geom_foot[other] >= 0:
                out[self.geom_foot[other]] = True
        return out[0], out[1]


def set_point_height(stepper: SteppingController) -> float:
    """The central-body COM height [m] the stepping controller holds now: its set point's, lowered
    by the swing's height drop while a foot swings (a robot's run falls 0.15 m below it)."""
    z = float(stepper.target.com[2])
    return z - stepper.stepping.swing_height_drop_m if stepper.phase == "swing" else z
