"""What the stepping controller (:mod:`biped.control.stepping`) needs of a biped's structure, read
from the controller's model description instead of W's body and joint names.

A :class:`SteppingBody` holds, for the two legs (left, right): the foot bodies, each leg's 6
hinges in order (hip to ankle, the controller's joint names), the hip body (the body of the
leg's 3rd hinge, whose origin is the point the swing foot's reach is measured from), the shank
body (the 4th hinge's: the knee), the sole rectangles, the sign of the ankle-inversion axis (the
5th hinge's x component, used by W's swing law), the central body (the floating body), the model
the stepping controller reads (whole-body COM, mass matrix, bias forces), the set point's maker
``target(com, tilt_deg)``, the swing law and the leg length.

**Leg length** (:func:`leg_length`): ``|hip - knee| + |knee - ankle|`` at the standing pose: the
hip body's origin, the anchors of the 4th hinge (knee) and the 5th (the first ankle hinge) (W's
biped: left_thigh, whose origin is where its three hip axes meet, the knee and ankle: 0.826 m,
the figure :class:`~biped.control.stepping_config.SteppingConfig`'s reach was chosen for).

:func:`w_body` is W's structure (W's biped and ``biped model`` subjects): the same bodies,
joints, soles and sign the stepping controller looked up by name before (a test compares
them), W's set point (:meth:`~biped.control.setpoint.Target.wendlandt`) and W's swing law
(:func:`biped.control.swing.swing_leg_torques`). A robot's (:mod:`biped.sim.robot_stepping`)
adds what W's structure takes for granted: the sole's axes in the foot frame, the foot's
standing orientation, the direction the robot faces, the robot's soles and big base for its
controllers.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from biped.errors import ModelError
from biped.model import TreeModel, sole_rectangles

__all__ = [
    "LEG_JOINTS",
    "SteppingBody",
    "ankle_axis_along_sole",
    "ankle_reaches",
    "facing_rotation",
    "leg_chains",
    "leg_length",
    "sole_pose",
    "w_body",
]

#: Hinges a leg must have for the stepping controller: 3 at the hip, the knee, 2 at the ankle.
LEG_JOINTS = 6


@dataclass(frozen=True, eq=False)
class SteppingBody:
    """A biped's structure as the stepping controller uses it (the module's docstring).

    model: the MuJoCo model the stepping controller runs ``mj_forward`` on (the plant's qpos
    layout); root, feet, hips, shanks: body ids in it; leg_joints: (left, right) 6 joint names
    each, hip to ankle; soles: (left, right) (sole centre in the foot body's frame (3,), half
    length, half width) [m]; inversion_sign: (left, right) the sign of the 5th hinge's axis x;
    leg_length_m; target(com, tilt_deg) -> Target: the set point with the COM ``com``, upright
    but for a forward tilt; swing(ctl, i, pd, vd, ad) -> (6,) torques of the swing leg.

    Robots only (None on W's structure, whose conventions they are): sole_axes (left, right) the
    sole's axes in the foot body's frame (3, 3); foot_rotation (left, right) the foot's world
    orientation at the standing pose (the swing lands it so; W: the identity); facing (2, 2) the
    rotation of the floor's (x, y) that turns the biped to face -x as W's does (the landing
    limits' "back" is W's +x); controller_soles: the soles the workspace controllers take;
    big_base: their W Alg. 3 factor (None: the controller's default).
    """

    model: mujoco.MjModel
    root: int
    feet: tuple[int, int]
    hips: tuple[int, int]
    shanks: tuple[int, int]
    leg_joints: tuple[tuple[str, ...], tuple[str, ...]]
    soles: tuple[tuple[np.ndarray, float, float], tuple[np.ndarray, float, float]]
    inversion_sign: tuple[float, float]
    leg_length_m: float
    target: Callable[..., Any]
    swing: Callable[..., np.ndarray]
    sole_axes: tuple[np.ndarray, np.ndarray] | None = None
    foot_rotation: tuple[np.ndarray, np.ndarray] | None = None
    facing: np.ndarray | None = None
    controller_soles: tuple | None = None
    big_base: float | None = None


def leg_chains(tree: TreeModel) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(left, right) the hinges of each leg in the tree's order (root to foot), checked to be
    :data:`LEG_JOINTS` each (a clear error names what the legs have)."""
    legs = tuple(
        tuple(tree.joint_names[k - 1] for k in range(1, tree.n_links) if tree.leg[k] == side)
        for side in (0, 1)
    )
    if any(len(leg) != LEG_JOINTS for leg in legs):
        raise ModelError(
            f"stepping needs {LEG_JOINTS} hinges in each leg (3 at the hip, the knee, 2 at the ankle: "
            f"the swing leg's hip, knee and ankle are found by their place); the legs have "
            f"{len(legs[0])} {list(legs[0])} and {len(legs[1])} {list(legs[1])}"
        )
    return legs[0], legs[1]


def _leg_bodies(m: mujoco.MjModel, leg: tuple[str, ...]) -> list[int]:
    try:
        return [int(m.jnt_bodyid[m.joint(j).id]) for j in leg]
    except KeyError as exc:
        raise ModelError(f"stepping: the stepping model has no leg joint {exc}") from None


def leg_length(m: mujoco.MjModel, d: mujoco.MjData, leg: tuple[str, ...], hip: int) -> float:
    """``|hip - knee| + |knee - ankle|`` [m]: the origin of the body ``hip``, the anchors of the
    leg's 4th and 5th hinges in ``d`` (kinematics computed)."""
    _leg_bodies(m, leg)
    knee, ankle = d.xanchor[m.joint(leg[3]).id], d.xanchor[m.joint(leg[4]).id]
    return float(np.linalg.norm(d.xpos[hip] - knee) + np.linalg.norm(knee - ankle))


def facing_rotation(left_xy, right_xy) -> np.ndarray | None:
    """The (2, 2) rotation of the floor that turns a biped whose left foot is at ``left_xy`` and
    right foot at ``right_xy`` to W's facing (-x; the left foot on -y), or None when it already
    faces so (within 1e-9 rad)."""
    v = np.asarray(left_xy, float)[:2] - np.asarray(right_xy, float)[:2]
    n = float(np.linalg.norm(v))
    if n < 1e-6:
        raise ModelError(
            "stepping: the feet are at one point on the floor; which way the biped faces is unknown"
        )
    a = np.arctan2(-1.0, 0.0) - np.arctan2(v[1], v[0])  # turn "left" onto -y
    a = float((a + np.pi) % (2 * np.pi) - np.pi)
    if abs(a) < 1e-9:
        return None
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s], [s, c]])


def sole_pose(body: SteppingBody, d: mujoco.MjData, i: int) -> tuple[np.ndarray, float]:
    """(foot ``i``'s sole centre (3,) [m], the yaw of the sole's length [rad]) in ``d``, MuJoCo's
    data of ``body.model`` after kinematics."""
    b = body.feet[i]
    R = d.xmat[b].reshape(3, 3)
    Rs = R if body.sole_axes is None else R @ body.sole_axes[i]  # the sole's axes
    return d.xpos[b] + R @ body.soles[i][0], math.atan2(Rs[1, 0], Rs[0, 0])


def ankle_reaches(body: SteppingBody, limits, joint_names) -> list[tuple[int, float]]:
    """Per leg: (its 5th hinge's joint id in ``body.model``, the reach [m]): the largest CoP offset
    along the sole from that ankle hinge's axis its torque limit holds with the whole weight on the
    foot, ``min(|lower|, upper) / (m g)``; ``limits`` the torque limits (lower and upper set) in
    ``joint_names`` order."""
    m = body.model
    weight = float(np.sum(m.body_mass)) * float(-m.opt.gravity[2])
    names = list(joint_names)
    out = []
    for leg in body.leg_joints:
        k = names.index(leg[4])
        tau = min(-float(limits.lower[k]), float(limits.upper[k]))
        out.append((int(m.joint(leg[4]).id), tau / weight))
    return out


def ankle_axis_along_sole(d: mujoco.MjData, joint: int, centre, yaw: float) -> float:
    """Where the ankle hinge ``joint``'s axis crosses a sole's length [m, from the sole centre
    ``centre``, along the yaw ``yaw`` of :func:`sole_pose`] in ``d`` (kinematics computed)."""
    u = np.array([math.cos(yaw), math.sin(yaw)])
    return float(u @ (d.xanchor[joint][:2] - centre[:2]))


def w_body(model: mujoco.MjModel, tree: TreeModel) -> SteppingBody:
    """W's structure (W's biped, ``biped model`` subjects): the bodies and joints by their place
    in the legs of ``tree`` (the controller's), the soles of :func:`biped.model.sole_rectangles`,
    W's set point and swing law."""
    from biped.control.setpoint import Target
    from biped.control.swing import swing_leg_torques

    m = model
    legs = leg_chains(tree)
    feet_names = tuple(tree.body_names[f] for f in tree.feet)
    bodies = [_leg_bodies(m, leg) for leg in legs]
    feet = (bodies[0][5], bodies[1][5])
    if tuple(m.body(b).name for b in feet) != feet_names:
        raise ModelError(
            f"stepping: the legs end at {[m.body(b).name for b in feet]}, not the feet {feet_names}"
        )
    soles = []
    for b, s in zip(feet, sole_rectangles(m, feet_names), strict=True):
        g_bi = np.eye(4)
        mujoco.mju_quat2Mat(g_bi[:3, :3].reshape(-1), m.body_iquat[b])
        g_bi[:3, 3] = m.body_ipos[b]
        soles.append(((g_bi @ s.g_foot_sole)[:3, 3].copy(), s.half_length, s.half_width))
    d = mujoco.MjData(m)
    if m.nkey:
        d.qpos[:] = m.key_qpos[0]
    mujoco.mj_kinematics(m, d)
    return SteppingBody(
        model=m,
        root=int(m.jnt_bodyid[0]),  # the central body (the free joint's)
        feet=feet,
        hips=(bodies[0][2], bodies[1][2]),
        shanks=(bodies[0][3], bodies[1][3]),
        leg_joints=legs,
        soles=(soles[0], soles[1]),
        inversion_sign=tuple(float(np.sign(m.jnt_axis[m.joint(leg[4]).id][0])) for leg in legs),  # type: ignore[arg-type]
        leg_length_m=leg_length(m, d, legs[0], bodies[0][2]),
        target=lambda com, tilt_deg: Target.wendlandt(com=com, tilt_deg=tilt_deg),
        swing=swing_leg_torques,
    )
