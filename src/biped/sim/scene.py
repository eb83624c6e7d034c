"""The push scene: W's biped (the scenario's ``model`` MJCF, untouched) + a floor + the thrown block.

Built with :class:`mujoco.MjSpec` from the shipped model file, to which the floor and the block are
added; no copy of the biped's XML exists anywhere. Every qpos/qvel/actuator index the simulation
needs is resolved *by name* here, once (:class:`Scene`), so the controller reads exactly the
biped's own ``(19,)`` qpos and ``(18,)`` qvel layout whatever else the scene contains.

Contact parameters (see :mod:`biped.sim.contact`): every geom of the scene gets the scenario's
friction (MuJoCo combines two geoms' frictions by their maximum, so both sides are set) and the
calibrated ``solref``/``solimp`` for the scenario's restitution. Friction cones are elliptic so
the Coulomb limit is the same in every sliding direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import mujoco
import numpy as np

from biped.errors import ModelError, unknown_name
from biped.models import JOINT_NAMES
from biped.sim import perturbations
from biped.sim.contact import CONTACT_SOLIMP, SOLE_GEOMS, contact_solref
from biped.sim.scenario import Scenario
from biped.spatial import axis_angle_quat

BIPED_MODEL = "wendlandt"
CENTRAL_BODY = "central_body"
ROOT_JOINT = "root"
FLOOR, BLOCK, BLOCK_JOINT = "floor", "block", "block_root"

_NQ = {
    int(mujoco.mjtJoint.mjJNT_FREE): 7,
    int(mujoco.mjtJoint.mjJNT_BALL): 4,
    int(mujoco.mjtJoint.mjJNT_SLIDE): 1,
    int(mujoco.mjtJoint.mjJNT_HINGE): 1,
}
_NV = {
    int(mujoco.mjtJoint.mjJNT_FREE): 6,
    int(mujoco.mjtJoint.mjJNT_BALL): 3,
    int(mujoco.mjtJoint.mjJNT_SLIDE): 1,
    int(mujoco.mjtJoint.mjJNT_HINGE): 1,
}


@dataclass(frozen=True, eq=False)
class Scene:
    """A compiled push scene and its name-resolved indices.

    ``biped_qpos_index`` (19,) / ``biped_qvel_index`` (18,): scene qpos/qvel index of each entry of
    the biped model's own layout, so ``data.qpos[scene.biped_qpos_index]`` is the biped's qpos.
    ``actuator_index`` (12,): scene actuator of each joint of ``joint_names``.
    ``joint_qpos_index`` (12,): scene qpos index of each joint of ``joint_names`` [rad].
    """

    model: mujoco.MjModel
    biped_model: mujoco.MjModel
    joint_names: tuple
    biped_qpos_index: np.ndarray
    biped_qvel_index: np.ndarray
    actuator_index: np.ndarray
    joint_qpos_index: np.ndarray
    block_qpos_index: np.ndarray
    block_qvel_index: np.ndarray
    central_body: int
    block_body: int
    floor_geom: int
    block_geom: int
    sole_geoms: tuple
    biped_geoms: tuple
    solref: tuple = field(default=(0.02, 1.0))
    #: ``((geom, foot, seam_m, heel_side), ...)``: the collision box of each foot whose heel and
    #: toe collide as one (``scenario.sole_box``), its foot (0 left, 1 right), the heel/toe seam
    #: on the box's x axis [m] and the side of it the heel lies on (+1 or -1); empty otherwise.
    sole_boxes: tuple = ()


def biped_spec(model: str = BIPED_MODEL) -> mujoco.MjSpec:
    """The biped MJCF (a shipped model's name or a checked MJCF path, the scenario's ``model``)
    as an editable spec."""
    from biped.models.subject import resolve

    return mujoco.MjSpec.from_file(str(resolve(model)))


def scene_spec(scenario: Scenario) -> mujoco.MjSpec:
    """Spec of the scene: the biped + floor (z = 0 plane) + block at ``block_position_m``.

    Physics: the biped model's own gravity (9.81 m/s^2 along -z), ``physics_timestep_s``,
    elliptic friction cones, friction ``scenario.friction`` and the restitution-calibrated solref
    on every geom, passive damping ``scenario.joint_damping_n_m_s`` on every hinge (replacing the
    MJCF's); MuJoCo's sleep flag when ``scenario.sleep`` (``physics = "fast"``): a tree at rest
    stops being simulated until something touches it. Only the block can sleep: MuJoCo never lets
    an actuated tree (the biped) sleep.

    ``scenario.sole_box`` (``physics = "fast"`` on W's biped, feet in place): each foot whose
    heel and toe boxes are flush (same body, orientation, width and height, touching end to end)
    collides as one box, their union (geom ``<foot>_sole_box``, collision only: group 3,
    transparent, massless); the heel and toe boxes stay for the eye and stop colliding. A box on
    a plane gives MuJoCo 4 corner contacts: the two boxes gave 8, two pairs of them on the same
    points of the seam, and a third of a step's cost is these contacts. The support polygon is
    the same; the contact monitor tells the heel's corners from the toe's by the side of the seam
    they lie on.
    """
    spec = biped_spec(scenario.model)
    if scenario.sole_box:
        _add_sole_boxes(spec, biped_spec(scenario.model).compile())
    spec.modelname = "push_scene"
    spec.option.timestep = scenario.physics_timestep_s
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    if scenario.sleep:
        spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    solref = contact_solref(scenario.restitution, scenario.contact_timeconst_s, scenario.physics_timestep_s)

    tex = spec.add_texture(
        name="grid",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        width=300,
        height=300,
        rgb1=[0.82, 0.84, 0.86],
        rgb2=[0.62, 0.65, 0.68],
    )
    mat = spec.add_material(name="grid", texrepeat=[10, 10], reflectance=0.05)
    mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = tex.name
    spec.worldbody.add_light(name="sun", pos=[0, 0, 4], dir=[0, 0, -1], diffuse=[0.7, 0.7, 0.7])
    spec.worldbody.add_geom(
        name=FLOOR,
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[10, 10, 0.1],
        material="grid",
        contype=1,
        conaffinity=1,
    )
    block = spec.worldbody.add_body(name=BLOCK, pos=list(scenario.block_position_m))
    block.add_freejoint(name=BLOCK_JOINT)
    block.add_geom(
        name=BLOCK,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[s / 2 for s in scenario.block_size_m],
        mass=scenario.block_mass_kg,
        rgba=[0.9, 0.6, 0.1, 1.0],
        contype=1,
        conaffinity=1,
    )
    for j in spec.joints:  # the plant's passive damping (the controller does not model it)
        if j.type == mujoco.mjtJoint.mjJNT_HINGE:
            j.damping = [scenario.joint_damping_n_m_s, *list(j.damping)[1:]]
    if scenario.ankle_only:
        _lock_hips_and_knees(spec, scenario)
    for g in spec.geoms:
        g.friction = [scenario.friction, g.friction[1], g.friction[2]]
        g.solref = list(solref)
        g.solimp = list(CONTACT_SOLIMP)
        g.solmix = 1.0
    perturbations.of(scenario).edit_spec(spec)  # after the contact parameters: a platform gets its own
    return spec


#: ``ankle_only``: the stiffness [N m/rad] and damping [N m s/rad] of the springs that hold every
#: hip and knee joint at its initial angle (the controller's torques still act on them).
LOCK_STIFFNESS_N_M_RAD = 5000.0
LOCK_DAMPING_N_M_S = 100.0


def _lock_hips_and_knees(spec: mujoco.MjSpec, scenario: Scenario) -> None:
    """``ankle_only``: a stiff spring-damper at every hip and knee hinge, at rest at the
    scenario's initial angle (co-contracted muscle's intrinsic stiffness: no delay), so the body
    above the ankles moves as one: B's inverted pendulum on the feet, balanced by the ankles."""
    angles = dict(zip(JOINT_NAMES, scenario.initial_joint_angles_deg, strict=True))
    for j in spec.joints:
        if j.type == mujoco.mjtJoint.mjJNT_HINGE and j.name in angles and "ankle" not in j.name:
            j.stiffness = [LOCK_STIFFNESS_N_M_RAD, *list(j.stiffness)[1:]]
            j.springref = math.radians(angles[j.name])
            j.damping = [LOCK_DAMPING_N_M_S, *list(j.damping)[1:]]


SOLE_BOX = "{foot}_sole_box"


class SoleUnion(NamedTuple):
    """The box that is the union of a foot's flush heel and toe boxes (:func:`sole_union`)."""

    heel: int  # geom ids of the two boxes
    toe: int
    pos: np.ndarray  # (3,) its centre in the foot body's frame [m]
    quat: np.ndarray  # (4,) its orientation there (the two boxes')
    size: np.ndarray  # (3,) its half-sizes [m]
    seam: float  # where the heel meets the toe on its x axis [m]
    side: float  # +1 if the heel lies on the +x side of the seam, else -1


def sole_union(m: mujoco.MjModel, foot: str) -> SoleUnion | None:
    """The union of ``foot``'s heel and toe boxes (geoms ``<foot>_heel``, ``<foot>_toe``) in
    model ``m``, or None when they are not two flush boxes (same body, orientation, width and
    height, touching end to end along their x axis)."""
    try:
        h, t = m.geom(f"{foot}_heel").id, m.geom(f"{foot}_toe").id
    except KeyError:
        return None
    box = int(mujoco.mjtGeom.mjGEOM_BOX)
    if m.geom_type[h] != box or m.geom_type[t] != box or m.geom_bodyid[h] != m.geom_bodyid[t]:
        return None
    if not np.allclose(m.geom_quat[h], m.geom_quat[t], atol=1e-12):
        return None
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, m.geom_quat[h])
    dx = R.reshape(3, 3).T @ (m.geom_pos[h] - m.geom_pos[t])  # heel centre in the toe box's axes
    sh, st = m.geom_size[h], m.geom_size[t]
    tol = 1e-6  # [m]: the shipped model's sizes are printed to 0.1 um
    if abs(dx[1]) > tol or abs(dx[2]) > tol or np.abs(sh[1:] - st[1:]).max() > tol:
        return None
    if abs(abs(dx[0]) - (sh[0] + st[0])) > tol:
        return None
    side = float(np.sign(dx[0]))  # the heel's side of the toe
    half = 0.5 * (abs(dx[0]) + sh[0] + st[0])  # from the toe's outer end to the heel's
    mid = m.geom_pos[t] + R.reshape(3, 3)[:, 0] * 0.5 * (dx[0] + side * (sh[0] - st[0]))
    seam = side * (half - 2.0 * sh[0])  # the heel's outer end less its length
    return SoleUnion(h, t, mid, m.geom_quat[h].copy(), np.array([half, sh[1], sh[2]]), float(seam), side)


def _add_sole_boxes(spec: mujoco.MjSpec, bm: mujoco.MjModel) -> None:
    """Give each foot of ``spec`` whose heel and toe are flush boxes (:func:`sole_union` on its
    compiled model ``bm``) one collision box, their union; the heel and toe stop colliding."""
    for foot in ("left", "right"):
        u = sole_union(bm, foot)
        if u is None:
            continue
        body = spec.body(bm.body(bm.geom_bodyid[u.heel]).name)
        body.add_geom(
            name=SOLE_BOX.format(foot=foot),
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=list(u.pos),
            quat=list(u.quat),
            size=list(u.size),
            contype=int(bm.geom_contype[u.heel]),
            conaffinity=int(bm.geom_conaffinity[u.heel]),
            condim=int(bm.geom_condim[u.heel]),
            group=3,
            rgba=[0.0, 0.0, 0.0, 0.0],
            mass=0.0,
        )
        for g in (spec.geom(f"{foot}_heel"), spec.geom(f"{foot}_toe")):
            g.contype, g.conaffinity = 0, 0


def _sole_boxes(model: mujoco.MjModel) -> tuple:
    """:attr:`Scene.sole_boxes` of a compiled scene."""
    out = []
    for i, foot in enumerate(("left", "right")):
        try:
            b = model.geom(SOLE_BOX.format(foot=foot)).id
        except KeyError:
            continue
        u = sole_union(model, foot)
        assert u is not None  # the scene added the box because the parts are flush
        out.append((b, i, u.seam, u.side))
    return tuple(out)


def _index_of(model, obj, name, kind):
    try:
        return getattr(model, obj)(name).id
    except KeyError:
        valid = [getattr(model, obj)(i).name for i in range(getattr(model, f"n{obj}"))]
        raise ModelError(unknown_name(kind, name, valid)) from None


def build_scene(scenario: Scenario) -> Scene:
    """Compile :func:`scene_spec` and resolve every index by name (see :class:`Scene`)."""
    spec = scene_spec(scenario)
    model = spec.compile()
    bm = biped_spec(scenario.model).compile()
    qpos_index = np.full(bm.nq, -1, dtype=np.int64)
    qvel_index = np.full(bm.nv, -1, dtype=np.int64)
    for j in range(bm.njnt):
        name, jtype = bm.joint(j).name, int(bm.jnt_type[j])
        sj = _index_of(model, "joint", name, "joint")
        if model.jnt_type[sj] != jtype:
            raise ModelError(f"joint {name!r} changed type between the biped and the scene")
        qpos_index[bm.jnt_qposadr[j] : bm.jnt_qposadr[j] + _NQ[jtype]] = model.jnt_qposadr[sj] + np.arange(
            _NQ[jtype]
        )
        qvel_index[bm.jnt_dofadr[j] : bm.jnt_dofadr[j] + _NV[jtype]] = model.jnt_dofadr[sj] + np.arange(
            _NV[jtype]
        )
    assert (qpos_index >= 0).all() and (qvel_index >= 0).all()
    hinges = [bm.joint(j).name for j in range(bm.njnt) if bm.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    if sorted(hinges) != sorted(JOINT_NAMES):
        raise ModelError(f"the biped's hinges {hinges} are not W's 12 joints {list(JOINT_NAMES)}")
    joint_names = tuple(JOINT_NAMES)
    act_of_joint = {model.joint(model.actuator_trnid[a, 0]).name: a for a in range(model.nu)}
    missing = [n for n in joint_names if n not in act_of_joint]
    if missing:
        raise ModelError(f"joints without a motor in the biped model: {missing}")
    actuator_index = np.array([act_of_joint[n] for n in joint_names], dtype=np.int64)
    joint_qpos_index = np.array(
        [model.jnt_qposadr[_index_of(model, "joint", n, "joint")] for n in joint_names], dtype=np.int64
    )
    bj = _index_of(model, "joint", BLOCK_JOINT, "joint")
    central = _index_of(model, "body", CENTRAL_BODY, "body")
    if np.any(np.abs(model.body_ipos[central]) > 1e-12):
        raise ModelError(f"{CENTRAL_BODY!r} frame origin must be its COM (W's body frame)")
    block_body = _index_of(model, "body", BLOCK, "body")
    biped_bodies = {bm.body(b).name for b in range(1, bm.nbody)}
    biped_geoms = tuple(
        g for g in range(model.ngeom) if model.body(model.geom_bodyid[g]).name in biped_bodies
    )
    sole_geoms = tuple(_index_of(model, "geom", f"{foot}_{part}", "geom") for foot, part in SOLE_GEOMS)
    return Scene(
        model=model,
        biped_model=bm,
        joint_names=joint_names,
        biped_qpos_index=qpos_index,
        biped_qvel_index=qvel_index,
        actuator_index=actuator_index,
        joint_qpos_index=joint_qpos_index,
        block_qpos_index=model.jnt_qposadr[bj] + np.arange(7),
        block_qvel_index=model.jnt_dofadr[bj] + np.arange(6),
        central_body=central,
        block_body=block_body,
        floor_geom=_index_of(model, "geom", getattr(perturbations.of(scenario), "floor_geom", FLOOR), "geom"),
        block_geom=_index_of(model, "geom", BLOCK, "geom"),
        sole_geoms=sole_geoms,
        biped_geoms=biped_geoms,
        solref=tuple(float(x) for x in model.geom_solref[0]),
        sole_boxes=_sole_boxes(model),
    )


def tilt_quat(axis: str, tilt_deg: float) -> np.ndarray:
    """(4,) quaternion (w, x, y, z) of a rotation of ``tilt_deg`` about ``"-y"`` or ``"-x"``."""
    axes = {"-y": (0.0, -1.0, 0.0), "-x": (-1.0, 0.0, 0.0)}
    return axis_angle_quat(np.array(axes[axis]), np.radians(tilt_deg))


def initial_state(scene: Scene, scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """Scene ``(qpos (nq,), qvel (nv,))`` of the initial state of ``scenario``: W's
    (:func:`w_initial_state`), then its perturbation's (the block parked, the lean of ``release``;
    :meth:`biped.sim.perturbations.Perturbation.initial_state`)."""
    qpos, qvel = w_initial_state(scene, scenario)
    perturbations.of(scenario).initial_state(scene, qpos, qvel)
    return qpos, qvel


def w_initial_state(scene: Scene, scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """Scene ``(qpos (nq,), qvel (nv,))`` of W's initial state for ``scenario``.

    Central-body COM at ``initial_com_m`` turned ``initial_tilt_deg`` about -y, joint angles
    ``initial_joint_angles_deg`` (+ ``joint_noise_deg`` Gaussian noise from ``seed``), zero
    velocity; block at ``block_position_m`` moving at ``block_velocity_m_s``, not rotating.
    """
    m = scene.model
    qpos = m.qpos0.copy()
    qvel = np.zeros(m.nv)
    root = scene.biped_qpos_index[:7]
    qpos[root[:3]] = scenario.initial_com_m
    qpos[root[3:]] = tilt_quat("-y", scenario.initial_tilt_deg)
    angles = np.radians(np.array(scenario.initial_joint_angles_deg))
    if scenario.joint_noise_deg > 0:
        rng = np.random.default_rng(scenario.seed)
        angles = angles + np.radians(scenario.joint_noise_deg) * rng.standard_normal(12)
    qpos[scene.joint_qpos_index] = angles
    qpos[scene.block_qpos_index] = [*scenario.block_position_m, 1.0, 0.0, 0.0, 0.0]
    qvel[scene.block_qvel_index[:3]] = scenario.block_velocity_m_s
    return qpos, qvel
