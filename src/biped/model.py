"""A tree multibody model built from an MJCF file through ``mujoco.MjModel``.

This is the controller's view of a biped: the topology (parent array), each hinge's twist ``H_k``
in its outboard link frame, the fixed transforms between link frames at zero joint angles, and
the spatial inertias ``M_k = diag(m_k I3, diag(I_k))``. Link frames are MuJoCo's *inertial*
frames (``body_ipos``, ``body_iquat``): at the COM, on principal axes, as W requires (W eq. 3.9).

The MJCF is the single source of truth: the simulator (MuJoCo) and the controller read the same
file, so they cannot disagree about masses, lengths or axes.

Supported trees: one floating root body (a ``free`` joint) and, on every other body, exactly one
``hinge`` joint; two named feet that descend from the root on different branches, every jointed
body on one of the two legs (root to foot) or beyond a foot (W's controller actuates the legs
only: a third leg or an arm would get no torque). Anything else raises
:class:`biped.errors.ModelError` naming the problem and the valid choices.
"""

from __future__ import annotations

from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from biped.errors import ModelError, unknown_name
from biped.spatial import adjoint, inverse, quat_to_rot, transform

DEFAULT_FEET = ("left_foot", "right_foot")

_JOINT_TYPE_NAMES = {
    int(mujoco.mjtJoint.mjJNT_FREE): "free",
    int(mujoco.mjtJoint.mjJNT_BALL): "ball",
    int(mujoco.mjtJoint.mjJNT_SLIDE): "slide",
    int(mujoco.mjtJoint.mjJNT_HINGE): "hinge",
}


@dataclass(frozen=True, eq=False)
class TreeModel:
    """Immutable tree multibody model (link 0 = the floating root, W's link 1).

    Attributes (``n`` links, link ``k >= 1`` is the outboard link of joint ``k``):
        body_names: (n,) MuJoCo body names.
        joint_names: (n - 1,) hinge names; ``joint_names[k - 1]`` is joint ``k``.
        parent: (n,) int, ``parent[k]`` = W's ``k.i`` for joint k; ``parent[0] = -1``.
        H: (n, 6) joint twist ``[v; w]`` of joint k in link k's frame (W's ``H_k``); ``H[0] = 0``.
        G0: (n, 4, 4) ``g_{parent(k), k}`` at zero joint angle (inertial frames); ``G0[0]`` is
            ``g_{root body frame, root inertial frame}``.
        mass: (n,) [kg]; inertia: (n, 3) principal moments [kg m^2] about the link frame axes.
        qpos_adr, dof_adr: (n,) addresses of each link's joint in MuJoCo's qpos / qvel.
        qpos_ref: (n,) hinge angle offsets (MuJoCo's ``qpos0``): joint angle = qpos - qpos_ref.
        feet: (2,) link indices of the (left, right) feet.
        leg: (n,) 0 / 1 for links on the path root -> left / right foot (feet included), else -1.
        beyond_foot: (n,) bool, links strictly outboard of a foot (ignored by the big-base
            approximation and given zero torque).
        gravity: (3,) [m/s^2] in the world frame.
        nq, nv: sizes of MuJoCo's qpos and qvel for this model.
    """

    body_names: tuple[str, ...]
    joint_names: tuple[str, ...]
    parent: np.ndarray
    H: np.ndarray
    G0: np.ndarray
    mass: np.ndarray
    inertia: np.ndarray
    qpos_adr: np.ndarray
    dof_adr: np.ndarray
    qpos_ref: np.ndarray
    feet: np.ndarray
    leg: np.ndarray
    beyond_foot: np.ndarray
    gravity: np.ndarray
    nq: int
    nv: int
    source: str = ""

    @property
    def n_links(self) -> int:
        return len(self.body_names)

    @property
    def spatial_inertia(self) -> np.ndarray:
        """(n, 6, 6) ``M_k = diag(m I3, I_k)`` in link frames (W eq. 3.9) [kg, kg m^2]."""
        out = np.zeros((self.n_links, 6, 6))
        for k in range(self.n_links):
            out[k] = np.diag(np.concatenate([np.full(3, self.mass[k]), self.inertia[k]]))
        return out

    def link(self, name: str) -> int:
        """Link index of a body name; unknown names raise with the list of valid ones."""
        try:
            return self.body_names.index(name)
        except ValueError:
            raise ModelError(unknown_name("body", name, self.body_names)) from None

    @classmethod
    def from_mjcf(cls, source: Any, feet: tuple[str, str] = DEFAULT_FEET) -> TreeModel:
        """Build from an MJCF path, an XML string or a compiled ``mujoco.MjModel``."""
        model, label = _load(source)
        return _build(model, (feet[0], feet[1]), label)


def _load(source):
    if isinstance(source, mujoco.MjModel):
        return source, "<MjModel>"
    if isinstance(source, (str, PathLike)) and not str(source).strip():
        raise ModelError(
            f"empty model source {str(source)!r}: expected an MJCF file path, MJCF XML "
            f"text or a mujoco.MjModel"
        )
    if isinstance(source, (str, PathLike)) and not str(source).lstrip().startswith("<"):
        path = Path(source)
        if path.is_dir():
            raise ModelError(f"model file {str(path)!r} is a folder; give an MJCF (.xml) file")
        if not path.is_file():
            raise ModelError(f"model file {str(path)!r} does not exist")
        try:
            return mujoco.MjModel.from_xml_path(str(path)), str(path)
        except ValueError as exc:
            raise ModelError(f"malformed model file {str(path)!r}: {exc}") from None
    if isinstance(source, str):
        try:
            return mujoco.MjModel.from_xml_string(source), "<xml string>"
        except ValueError as exc:
            raise ModelError(f"malformed MJCF text: {exc}") from None
    raise ModelError(f"expected an MJCF path, XML text or mujoco.MjModel, got {type(source).__name__}")


def _name(model, obj, i) -> str:
    return mujoco.mj_id2name(model, obj, i) or f"#{i}"


def _build(model: mujoco.MjModel, feet: tuple[str, str], label: str) -> TreeModel:
    nb = model.nbody
    body_names_all = [_name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(nb)]
    # --- floating roots: bodies whose parent is the world and that move
    roots = [b for b in range(1, nb) if model.body_parentid[b] == 0 and model.body_jntnum[b] > 0]
    if len(roots) != 1:
        raise ModelError(
            f"expected exactly one floating tree (one body with a free joint under the world), found "
            f"{len(roots)}: {[body_names_all[b] for b in roots]}; give the controller the biped's own "
            f"model, without floors' free objects"
        )
    root = roots[0]
    bodies = [b for b in range(1, nb) if model.body_rootid[b] == root]
    fixed = [b for b in range(1, nb) if model.body_rootid[b] != root and model.body_jntnum[b] == 0]
    del fixed  # static bodies welded to the world (scenery) are ignored
    # --- joints
    for b in bodies:
        nj = model.body_jntnum[b]
        types = [_JOINT_TYPE_NAMES[int(model.jnt_type[model.body_jntadr[b] + i])] for i in range(nj)]
        if b == root:
            if types != ["free"]:
                raise ModelError(
                    f"root body {body_names_all[b]!r} must have exactly one free joint, has {types}"
                )
            continue
        if nj != 1 or types[0] != "hinge":
            raise ModelError(
                f"body {body_names_all[b]!r} has joints {types}; every body below the root must have "
                f"exactly one hinge joint (valid: one 'hinge'; model ball joints as three hinges "
                f"with massless intermediate bodies, as W does, and fold welded bodies into their parent)"
            )
    # --- feet
    names = [body_names_all[b] for b in bodies]
    for f in feet:
        if f not in names:
            raise ModelError(unknown_name("foot body", f, names))
    if len(feet) != 2 or feet[0] == feet[1]:
        raise ModelError(f"need two different feet (left, right), got {feet}")
    for f in feet:
        if f == names[0]:
            raise ModelError(
                f"foot {f!r} is the floating root (the central body); the feet must be "
                f"bodies below it, one at the end of each leg"
            )
    index = {b: i for i, b in enumerate(bodies)}
    n = len(bodies)
    parent = np.full(n, -1, dtype=np.int64)
    for b in bodies[1:]:
        parent[index[b]] = index[model.body_parentid[b]]
    foot_idx = np.array([names.index(f) for f in feet], dtype=np.int64)
    leg = np.full(n, -1, dtype=np.int64)
    for side, f in enumerate(foot_idx):
        k = f
        while k > 0:
            if leg[k] >= 0:
                raise ModelError(
                    f"feet {feet[0]!r} and {feet[1]!r} share the link {names[k]!r}: each foot must end "
                    f"its own leg"
                )
            leg[k] = side
            k = parent[k]
    beyond = np.zeros(n, dtype=bool)
    for k in range(1, n):
        p = parent[k]
        beyond[k] = beyond[p] or (p in foot_idx)
    off_legs = [names[k] for k in range(1, n) if leg[k] < 0 and not beyond[k]]
    if off_legs:
        raise ModelError(
            f"bodies {off_legs} are on neither leg ({names[0]!r} to {feet[0]!r}, {names[0]!r} to "
            f"{feet[1]!r}) nor beyond a foot: W's controller actuates only the two legs, so their "
            f"joints would get no torque; valid models have two legs (a third leg or arms are not "
            f"supported: weld them into the central body)"
        )

    # --- geometry and inertia (MuJoCo body frames -> inertial frames)
    def body_to_inertial(b):
        return transform(quat_to_rot(model.body_iquat[b]), model.body_ipos[b])

    H = np.zeros((n, 6))
    G0 = np.zeros((n, 4, 4))
    qadr = np.zeros(n, dtype=np.int64)
    dadr = np.zeros(n, dtype=np.int64)
    qref = np.zeros(n)
    joint_names = []
    for i, b in enumerate(bodies):
        g_bi = body_to_inertial(b)
        j = model.body_jntadr[b]
        qadr[i] = model.jnt_qposadr[j]
        dadr[i] = model.jnt_dofadr[j]
        if i == 0:
            G0[0] = g_bi
            continue
        joint_names.append(_name(model, mujoco.mjtObj.mjOBJ_JOINT, j))
        p = model.body_parentid[b]
        g_pb_cb = transform(quat_to_rot(model.body_quat[b]), model.body_pos[b])
        G0[i] = inverse(body_to_inertial(p)) @ g_pb_cb @ g_bi
        a, q = model.jnt_axis[j], model.jnt_pos[j]
        xi_body = np.concatenate([np.cross(q, a), a])  # revolute twist [-w x q; w] in body frame
        g_ib = inverse(g_bi)
        H[i] = adjoint(g_ib[:3, :3], g_ib[:3, 3]) @ xi_body
        qref[i] = model.qpos0[qadr[i]]
    return TreeModel(
        body_names=tuple(names),
        joint_names=tuple(joint_names),
        parent=parent,
        H=H,
        G0=G0,
        mass=model.body_mass[bodies].copy(),
        inertia=model.body_inertia[bodies].copy(),
        qpos_adr=qadr,
        dof_adr=dadr,
        qpos_ref=qref,
        feet=foot_idx,
        leg=leg,
        beyond_foot=beyond,
        gravity=model.opt.gravity.copy(),
        nq=model.nq,
        nv=model.nv,
        source=label,
    )


@dataclass(frozen=True)
class SoleRectangle:
    """The rectangular sole of a foot, read from the MJCF's box geoms on the foot body.

    ``g_foot_sole`` (4, 4): pose of the sole frame in the foot's COM principal (inertial) frame;
    the sole frame sits at the centre of the rectangle, on its bottom face, its z axis the outward
    normal reversed (pointing up into the foot), x and y along the rectangle's edges (the foot
    body's axes). ``half_length`` (along the sole's x) and ``half_width`` (along y) [m].
    """

    g_foot_sole: np.ndarray
    half_length: float
    half_width: float


def sole_rectangles(source: Any, feet: tuple[str, str] = DEFAULT_FEET) -> tuple[SoleRectangle, SoleRectangle]:
    """(left, right) :class:`SoleRectangle` of ``feet`` in an MJCF (path, XML text or MjModel):
    the bounding rectangle of the bottom faces of the box geoms attached to each foot body (boxes
    axis-aligned with the foot body; W's model: a heel and a toe box)."""
    model, _ = _load(source)
    out = []
    for foot in feet:
        try:
            b = model.body(foot).id
        except KeyError:
            raise ModelError(
                unknown_name("foot body", foot, [model.body(i).name for i in range(model.nbody)])
            ) from None
        boxes = [
            g
            for g in range(model.ngeom)
            if model.geom_bodyid[g] == b and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
        ]
        if not boxes:
            raise ModelError(
                f"foot body {foot!r} has no box geoms: the sole rectangle is read from "
                f"them (give each foot one or more axis-aligned box geoms)"
            )
        corners = []
        for g in boxes:
            R = quat_to_rot(model.geom_quat[g])
            if not np.allclose(np.abs(R), np.eye(3), atol=1e-9):
                raise ModelError(
                    f"sole geom {_name(model, mujoco.mjtObj.mjOBJ_GEOM, g)!r} is not "
                    f"axis-aligned with the foot body {foot!r}"
                )
            s = model.geom_size[g]
            lo, hi = model.geom_pos[g] - np.abs(R) @ s, model.geom_pos[g] + np.abs(R) @ s
            corners.append((lo, hi))
        z = min(lo[2] for lo, _ in corners)
        bottom = [(lo, hi) for lo, hi in corners if abs(lo[2] - z) < 1e-9]
        x0, x1 = min(lo[0] for lo, _ in bottom), max(hi[0] for _, hi in bottom)
        y0, y1 = min(lo[1] for lo, _ in bottom), max(hi[1] for _, hi in bottom)
        g_body_sole = transform(np.eye(3), np.array([(x0 + x1) / 2, (y0 + y1) / 2, z]))
        g_body_inertial = transform(quat_to_rot(model.body_iquat[b]), model.body_ipos[b])
        out.append(
            SoleRectangle(inverse(g_body_inertial) @ g_body_sole, float(x1 - x0) / 2, float(y1 - y0) / 2)
        )
    return out[0], out[1]
