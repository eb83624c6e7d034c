"""Bediz's 15-part kinematic human figure ("Dynaman", B IV-B-2, Fig. 13 and 15).

B hangs every body part on a Dynamic Coordinate System (DCS) node of an IRIS Performer tree and
drives the tree with *joint angles* (his point against Frey's per-segment Euler angles): rotating
the thigh carries the shank and the foot. This module is that tree, with simple shapes in place
of B's polygon files.

The 15 parts and their parents (B Fig. 15; B splits the torso into two halves that always turn
together and hangs the arms on the root; here the root carries a pelvis part and the arms hang on
the torso, so they follow its roll):

    pelvis (root, free pose)
    +- torso          joints torso_roll (about +x), torso_pitch (about +y, forward lean > 0)
    |  +- head
    |  +- {left,right}_upper_arm   joint *_shoulder_flexion (forward swing > 0)
    |     +- *_lower_arm           joint *_elbow_flexion
    |        +- *_hand
    +- {left,right}_thigh          joint *_hip_flexion (forward swing > 0)
       +- *_shank                  joint *_knee (> 0 = extension; a bent human knee is < 0)
          +- *_foot                joint *_ankle_dorsiflexion (toes up > 0)

Frames: the figure faces +x, its left side is +y, z is up. The pelvis frame sits at the mid-hip
point (de Leva's MIDH); every limb frame sits at its proximal joint, its segment pointing down -z at
zero angles. Sagittal joints turn about -y (B's leg-frame angles of :mod:`biped.kinematic.ik`),
the torso pitch about +y.

Proportions: de Leva (1996) segment lengths at the stature of the project's 3D biped, taken from
:mod:`biped.models.anthropometry` (the same numbers the ``wendlandt`` MJCF is built from), so that
the figure's leg angles drive the biped's hips, knees and ankles with its feet landing where the
figure's feet land. Stature 1.680 m: thigh 0.407 m, shank 0.419 m, foot 0.249 m (ankle 0.2 of it
from the heel), ankle height 0.066 m, hips 0.168 m apart, shoulders 0.336 m apart.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from biped.errors import ModelError, StateError, unknown_name

__all__ = [
    "JOINT_NAMES",
    "PARTS",
    "FigureDims",
    "FigurePoses",
    "figure_mjcf",
    "landmarks",
    "part_geoms",
    "part_poses",
]

#: The 12 joint angles that drive the hierarchy, in the column order of every angle array.
JOINT_NAMES = (
    "torso_roll",
    "torso_pitch",
    "left_hip_flexion",
    "left_knee",
    "left_ankle_dorsiflexion",
    "right_hip_flexion",
    "right_knee",
    "right_ankle_dorsiflexion",
    "left_shoulder_flexion",
    "left_elbow_flexion",
    "right_shoulder_flexion",
    "right_elbow_flexion",
)
_J = {n: i for i, n in enumerate(JOINT_NAMES)}

_MY = (0.0, -1.0, 0.0)  # sagittal flexion axis (B's leg-frame angles)


@dataclass(frozen=True)
class FigureDims:
    """Lengths of the figure [m]. Build with :meth:`from_anthropometry` (the default figure).

    Attributes:
        thigh, shank: l1, l2 of B's leg (hip-knee, knee-ankle).
        foot: heel-to-toe length; ``heel_back`` of it lies behind the ankle.
        ankle_height: ankle above the sole.
        foot_width: sole width.
        hip_half_width: lateral offset of each hip joint from the mid-hip point.
        lumbar: height of the torso joint above the mid-hip point.
        trunk: mid-hip to the base of the neck (de Leva's MIDH-CERV).
        head: head length (CERV-VERT).
        shoulder_height, shoulder_half_width: shoulder joints above the mid-hip point and sideways.
        upper_arm, forearm, hand: arm segment lengths.
        scale: stature scale factor of de Leva's 1.741 m (thicknesses scale with it).
    """

    thigh: float
    shank: float
    foot: float
    heel_back: float
    ankle_height: float
    foot_width: float
    hip_half_width: float
    lumbar: float
    trunk: float
    head: float
    shoulder_height: float
    shoulder_half_width: float
    upper_arm: float
    forearm: float
    hand: float
    scale: float = 1.0

    def __post_init__(self):
        for k, v in self.__dict__.items():
            if not (np.isfinite(v) and v > 0):
                raise ModelError(f"FigureDims.{k} must be finite and positive (m), got {v!r}")
        if self.heel_back >= self.foot:
            raise ModelError(f"heel_back ({self.heel_back} m) must be shorter than the foot ({self.foot} m)")

    @property
    def leg(self) -> float:
        """P1 = l1 + l2, B's straight-leg length [m]."""
        return self.thigh + self.shank

    @property
    def toe_front(self) -> float:
        """Distance from the ankle forward to the toe tip [m]."""
        return self.foot - self.heel_back

    @classmethod
    def from_anthropometry(cls) -> FigureDims:
        """The figure with the proportions of the project's ``wendlandt`` biped (de Leva 1996)."""
        from biped.models import anthropometry as a

        s = a.solve_scale()
        H = a.DE_LEVA_STATURE * s
        A = a.ASSUMPTIONS
        _, _, _, d = a.central_body(s, A["body_mass_kg"])
        L = {k: v[0] * s for k, v in a.DE_LEVA_MALE.items()}
        return cls(
            thigh=L["thigh"],
            shank=L["shank"],
            foot=L["foot"],
            heel_back=A["heel_to_ankle_fraction_of_foot"] * L["foot"],
            ankle_height=A["ankle_height_fraction_of_stature"] * H,
            foot_width=0.055 * H,
            hip_half_width=A["hip_half_width_fraction_of_stature"] * H,
            lumbar=0.15 * d["trunk"],
            trunk=d["trunk"],
            head=d["head"],
            shoulder_height=d["shoulder_z"],
            shoulder_half_width=d["shoulder_y"],
            upper_arm=d["upper_arm"],
            forearm=d["forearm"],
            hand=d["hand"],
            scale=s,
        )

    @classmethod
    def from_mjcf(cls, model: Any) -> FigureDims:
        """The figure of another biped model (a shipped name or an MJCF path with W's structure,
        e.g. written by ``biped model``): legs and feet exactly as in the file (hip spacing, thigh,
        shank, ankle height and the heel/toe sole boxes); the upper body, which the figure shows
        but the inverse dynamics does not use, is the default figure's scaled by the ratio of leg
        lengths."""
        import mujoco

        from biped.kinematic.dynamics import body_of_joint
        from biped.models.subject import resolve

        m = mujoco.MjModel.from_xml_path(str(resolve(model)))
        heel, toe = m.geom("left_heel"), m.geom("left_toe")
        xb = float(heel.pos[0] + heel.size[0])  # back of the heel, ankle at x = 0
        xf = float(toe.pos[0] - toe.size[0])  # toe tip (the biped faces -x)

        thigh = -float(body_of_joint(m, "left_knee").pos[2])
        shank = -float(body_of_joint(m, "left_ankle_inversion").pos[2])
        d = cls.from_anthropometry()
        k = (thigh + shank) / d.leg
        return cls(
            thigh=thigh,
            shank=shank,
            foot=xb - xf,
            heel_back=xb,
            ankle_height=-float(heel.pos[2] - heel.size[2]),
            foot_width=2.0 * float(heel.size[1]),
            hip_half_width=-float(body_of_joint(m, "left_hip_abduction").pos[1]),
            lumbar=d.lumbar * k,
            trunk=d.trunk * k,
            head=d.head * k,
            shoulder_height=d.shoulder_height * k,
            shoulder_half_width=d.shoulder_half_width * k,
            upper_arm=d.upper_arm * k,
            forearm=d.forearm * k,
            hand=d.hand * k,
            scale=d.scale * k,
        )


@dataclass(frozen=True)
class Part:
    """One body part: its frame in the tree and its shape (MuJoCo size semantics, part frame)."""

    name: str
    parent: str | None
    joints: tuple  # ((joint name, axis), ...) applied in order at the frame origin
    kind: str
    rgba: tuple = field(default=(0.8, 0.65, 0.55, 1.0))


_SKIN = (0.85, 0.68, 0.55, 1.0)
_SHIRT = (0.75, 0.3, 0.25, 1.0)
_TROUSERS = (0.3, 0.4, 0.6, 1.0)
_SHOE = (0.2, 0.2, 0.2, 1.0)

#: The 15 parts in tree order (a parent before its children).
PARTS = (
    Part("pelvis", None, (), "box", _TROUSERS),
    Part(
        "torso", "pelvis", (("torso_roll", (1.0, 0.0, 0.0)), ("torso_pitch", (0.0, 1.0, 0.0))), "box", _SHIRT
    ),
    Part("head", "torso", (), "sphere", _SKIN),
    *(
        p
        for side in ("left", "right")
        for p in (
            Part(f"{side}_thigh", "pelvis", ((f"{side}_hip_flexion", _MY),), "capsule", _TROUSERS),
            Part(f"{side}_shank", f"{side}_thigh", ((f"{side}_knee", _MY),), "capsule", _TROUSERS),
            Part(f"{side}_foot", f"{side}_shank", ((f"{side}_ankle_dorsiflexion", _MY),), "box", _SHOE),
        )
    ),
    *(
        p
        for side in ("left", "right")
        for p in (
            Part(f"{side}_upper_arm", "torso", ((f"{side}_shoulder_flexion", _MY),), "capsule", _SHIRT),
            Part(
                f"{side}_lower_arm", f"{side}_upper_arm", ((f"{side}_elbow_flexion", _MY),), "capsule", _SKIN
            ),
            Part(f"{side}_hand", f"{side}_lower_arm", (), "ellipsoid", _SKIN),
        )
    ),
)
_P = {p.name: i for i, p in enumerate(PARTS)}


def _offset(dims: FigureDims, name: str) -> np.ndarray:
    """Origin of part ``name`` in its parent's frame at zero angles [m]."""
    d = dims
    sgn = 1.0 if name.startswith("left") else -1.0
    base = name.split("_", 1)[1] if name.startswith(("left_", "right_")) else name
    return np.array(
        {
            "pelvis": (0.0, 0.0, 0.0),
            "torso": (0.0, 0.0, d.lumbar),
            "head": (0.0, 0.0, d.trunk - d.lumbar),
            "thigh": (0.0, sgn * d.hip_half_width, 0.0),
            "shank": (0.0, 0.0, -d.thigh),
            "foot": (0.0, 0.0, -d.shank),
            "upper_arm": (0.0, sgn * d.shoulder_half_width, d.shoulder_height - d.lumbar),
            "lower_arm": (0.0, 0.0, -d.upper_arm),
            "hand": (0.0, 0.0, -d.forearm),
        }[base],
        dtype=float,
    )


def part_geoms(dims: FigureDims) -> dict:
    """Shape of every part: name -> (kind, size (MuJoCo semantics), centre in the part frame) [m]."""
    d, s = dims, dims.scale
    out: dict[str, tuple[str, tuple[float, ...], tuple[float, float, float]]] = {}

    def capsule(length, r):
        return "capsule", (r, max(length / 2 - r, 1e-3)), (0.0, 0.0, -length / 2)

    out["pelvis"] = (
        "box",
        (0.09 * s, d.hip_half_width + 0.04 * s, (d.lumbar + 0.08 * s) / 2),
        (0.0, 0.0, (d.lumbar - 0.08 * s) / 2),
    )
    torso_len = d.trunk - d.lumbar
    out["torso"] = ("box", (0.1 * s, 0.17 * s, torso_len / 2), (0.0, 0.0, torso_len / 2))
    out["head"] = ("sphere", (0.1 * s,), (0.0, 0.0, 0.5 * d.head))
    hz = 0.3 * d.ankle_height
    for side in ("left", "right"):
        out[f"{side}_thigh"] = capsule(d.thigh, 0.065 * s)
        out[f"{side}_shank"] = capsule(d.shank, 0.048 * s)
        out[f"{side}_foot"] = (
            "box",
            (d.foot / 2, d.foot_width / 2, hz),
            (d.foot / 2 - d.heel_back, 0.0, -d.ankle_height + hz),
        )
        out[f"{side}_upper_arm"] = capsule(d.upper_arm, 0.045 * s)
        out[f"{side}_lower_arm"] = capsule(d.forearm, 0.038 * s)
        out[f"{side}_hand"] = ("ellipsoid", (0.025 * s, 0.045 * s, d.hand / 2), (0.0, 0.0, -d.hand / 2))
    return out


def _axis_rot(axis, q: np.ndarray) -> np.ndarray:
    """(T,) angles about a unit axis -> (T, 3, 3) rotation matrices (Rodrigues)."""
    a = np.asarray(axis, dtype=float)
    K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    s, c = np.sin(q)[:, None, None], np.cos(q)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


@dataclass(frozen=True)
class FigurePoses:
    """World frames of the 15 parts over time.

    Attributes:
        pos: (T, 15, 3) part frame origins (the proximal joints) in the world [m].
        rot: (T, 15, 3, 3) part frame orientations (columns = part axes in world coordinates).
    """

    pos: np.ndarray
    rot: np.ndarray

    def part(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """``(pos (T, 3), rot (T, 3, 3))`` of part ``name``."""
        if name not in _P:
            raise ModelError(unknown_name("part", name, _P))
        i = _P[name]
        return self.pos[:, i], self.rot[:, i]


def part_poses(
    dims: FigureDims, pelvis_pos: ArrayLike, pelvis_rot: ArrayLike, angles: ArrayLike
) -> FigurePoses:
    """Forward kinematics of the DCS tree: the world frame of every part (B IV-B-2).

    Args:
        dims: the figure's lengths.
        pelvis_pos: (T, 3) mid-hip point in the world [m].
        pelvis_rot: (T, 3, 3) pelvis orientation (world <- pelvis).
        angles: (T, 12) joint angles [rad] in :data:`JOINT_NAMES` order.

    Returns:
        :class:`FigurePoses`.
    """
    pelvis_pos = np.asarray(pelvis_pos, dtype=float)
    pelvis_rot = np.asarray(pelvis_rot, dtype=float)
    angles = np.asarray(angles, dtype=float)
    T = pelvis_pos.shape[0] if pelvis_pos.ndim == 2 else -1
    if pelvis_pos.shape != (T, 3) or pelvis_rot.shape != (T, 3, 3) or angles.shape != (T, len(JOINT_NAMES)):
        raise StateError(
            f"need pelvis_pos (T, 3), pelvis_rot (T, 3, 3) and angles (T, {len(JOINT_NAMES)}); got "
            f"{pelvis_pos.shape}, {pelvis_rot.shape}, {angles.shape}"
        )
    pos = np.empty((T, len(PARTS), 3))
    rot = np.empty((T, len(PARTS), 3, 3))
    for i, p in enumerate(PARTS):
        if p.parent is None:
            P, R = pelvis_pos, pelvis_rot
        else:
            j = _P[p.parent]
            P = pos[:, j] + np.einsum("tij,j->ti", rot[:, j], _offset(dims, p.name))
            R = rot[:, j]
        for jname, axis in p.joints:
            R = R @ _axis_rot(axis, angles[:, _J[jname]])
        pos[:, i], rot[:, i] = P, R
    return FigurePoses(pos, rot)


def landmarks(dims: FigureDims, poses: FigurePoses) -> dict:
    """Sole points and joints in the world: name -> (T, 3) [m].

    ``{left,right}_heel`` and ``_toe`` are the back and front ends of the sole's centre line (the
    sole is ``ankle_height`` below the ankle); ``_ankle``, ``_hip`` are the joint centres.
    """
    out = {}
    for side in ("left", "right"):
        p, R = poses.part(f"{side}_foot")
        out[f"{side}_ankle"] = p
        out[f"{side}_heel"] = p + np.einsum("tij,j->ti", R, [-dims.heel_back, 0.0, -dims.ankle_height])
        out[f"{side}_toe"] = p + np.einsum("tij,j->ti", R, [dims.toe_front, 0.0, -dims.ankle_height])
        out[f"{side}_hip"] = poses.part(f"{side}_thigh")[0]
    return out


def _f(v) -> str:
    return " ".join(repr(float(x)) for x in np.atleast_1d(v))


def figure_mjcf(dims: FigureDims, terrain_boxes: Iterable = (), floor: bool = True) -> str:
    """MJCF of the figure (for MuJoCo's kinematics and video): a free pelvis and hinge joints
    named as :data:`JOINT_NAMES`, each body frame equal to the part frame of :func:`part_poses`.

    Args:
        dims: the figure's lengths.
        terrain_boxes: static boxes ``(centre (3,), half sizes (3,))`` [m] drawn in the world.
        floor: add a floor plane at z = 0.

    The model is kinematic: it has nominal masses (so MuJoCo compiles it) and no contacts.
    """
    shapes = part_geoms(dims)
    children = {p.name: [c for c in PARTS if c.parent == p.name] for p in PARTS}

    def body(p: Part, indent: str) -> str:
        kind, size, centre = shapes[p.name]
        lines = [f'{indent}<body name="{p.name}" pos="{_f(_offset(dims, p.name))}">']
        if p.parent is None:
            lines.append(f'{indent}  <freejoint name="pelvis"/>')
        for jname, axis in p.joints:
            lines.append(f'{indent}  <joint name="{jname}" type="hinge" axis="{_f(axis)}"/>')
        lines.append(
            f'{indent}  <geom name="{p.name}" type="{kind}" size="{_f(size)}" pos="{_f(centre)}" '
            f'rgba="{_f(p.rgba)}" mass="1"/>'
        )
        for c in children[p.name]:
            lines.append(body(c, indent + "  "))
        lines.append(f"{indent}</body>")
        return "\n".join(lines)

    world = []
    if floor:
        world.append('    <geom name="floor" type="plane" size="0 0 0.05" material="grid"/>')
    for k, (c, h) in enumerate(terrain_boxes):
        world.append(
            f'    <geom name="stair{k}" type="box" pos="{_f(c)}" size="{_f(h)}" rgba="0.6 0.6 0.55 1"/>'
        )
    return f"""<mujoco model="dynaman">
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81">
    <flag contact="disable"/>
  </option>
  <visual><headlight ambient="0.4 0.4 0.4" diffuse="0.6 0.6 0.6"/></visual>
  <asset>
    <texture name="grid" type="2d" builtin="checker" rgb1="0.85 0.85 0.85" rgb2="0.7 0.7 0.7" width="256" height="256"/>
    <material name="grid" texture="grid" texrepeat="8 8"/>
  </asset>
  <worldbody>
    <light pos="0 0 4" dir="0 0 -1" directional="true"/>
{chr(10).join(world)}
{body(PARTS[0], "    ")}
  </worldbody>
</mujoco>
"""
