"""What a push run's recorded states imply, row by row, from MuJoCo: the whole-body COM and its
velocity, the central body's velocities, and each foot's ground reaction force and centre of
pressure (W section 4's outputs, and what a biomechanics lab measures with force plates).

>>> from biped.sim import Scenario, simulate, build_scene
>>> from biped.sim.measure import measure_rows
>>> scenario = Scenario(duration_s=0.05)       # before the block hits (0.082 s)
>>> scene = build_scene(scenario)
>>> result = simulate(scenario, scene=scene)
>>> rows = measure_rows(scene, result)
>>> rows.grf.shape                              # (n rows, left/right, xyz) ground forces [N]
(26, 2, 3)

On a run with a hit, ``block_separation(result, rows).momentum`` is the block's momentum when it
leaves the body and ``foot_drift(result)`` how far the feet moved from the hit to the end.

``biped.outputs.push`` writes these as trajectory.csv's columns (tests/test_outputs_push.py
checks them against MuJoCo and closed forms).

Each row k is re-evaluated with ``mj_forward`` at the recorded state (qpos_k, qvel_k) with the
torques of that row (those held on [t_k, t_k+1)) applied, and a perturbation's applied forces and
platform servo inputs of that row (``result.extra["inputs"]``), so every quantity is at exactly t_k:
the contact forces are MuJoCo's constraint forces (``mj_contactForce``) of the first physics
step of that control period, to the solver's tolerance.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from biped.sim.scene import Scene

__all__ = [
    "FEET",
    "BlockSeparation",
    "RowMeasurements",
    "block_separation",
    "centre_of_pressure",
    "foot_bodies",
    "foot_drift",
    "measure_rows",
    "subtree",
]

#: The two feet, in the order of every (n, 2, ...) array.
FEET = ("left", "right")


@dataclass(frozen=True, eq=False)
class RowMeasurements:
    """Per control-period row (n rows), world frame, SI units.

    central_body_com (n, 3) [m]: the central body's COM (= its frame origin in this model).
    central_body_com_vel (n, 3) [m/s]; central_body_angvel (n, 3) [rad/s]: its angular velocity
        in the world frame.
    whole_body_com (n, 3) [m] and whole_body_com_vel (n, 3) [m/s]: the biped's (block excluded).
    biped_mass_kg: the biped's total mass; gravity (3,) [m/s^2]: the scene's.
    grf (n, 2, 3) [N]: the force the floor exerts on each foot (left, right): the sum over the
        contacts between the floor and the foot's geoms.
    cop (n, 2, 2) [m]: each foot's centre of pressure on the floor plane z = 0 (x, y); NaN when
        the foot carries no vertical load.
    block_touches_biped (n,) bool: a contact between the block and any biped geom at t_k.
    """

    central_body_com: np.ndarray
    central_body_com_vel: np.ndarray
    central_body_angvel: np.ndarray
    whole_body_com: np.ndarray
    whole_body_com_vel: np.ndarray
    grf: np.ndarray
    cop: np.ndarray
    block_touches_biped: np.ndarray
    biped_mass_kg: float
    gravity: np.ndarray


def foot_bodies(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """(left, right): the body ids of each foot (``<side>_foot``) and of every body below it."""
    left, right = (subtree(model, model.body(f"{side}_foot").id) for side in FEET)
    return left, right


def subtree(model: mujoco.MjModel, root: int) -> np.ndarray:
    """The ids of body ``root`` and of every body below it, ascending (int64)."""
    return np.array([b for b in range(model.nbody) if _below(model, b, root)], dtype=np.int64)


def _below(model, body: int, root: int) -> bool:
    while body > 0:
        if body == root:
            return True
        body = model.body_parentid[body]
    return False


def centre_of_pressure(points: np.ndarray, forces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Total force (3,) and centre of pressure (2,) on the plane z = 0 of point forces
    ``forces`` (k, 3) [N] applied at ``points`` (k, 3) [m]: the point of the plane about which
    the forces' moment has no horizontal part, ``x = -M_y / F_z``, ``y = M_x / F_z`` (a force
    plate's formula). CoP is NaN when F_z <= 0."""
    f = forces.sum(axis=0)
    if f[2] <= 0.0:
        return f, np.full(2, np.nan)
    x, y, z = points.T
    fx, fy, fz = forces.T
    m_x = float(np.dot(y, fz) - np.dot(z, fy))  # sum of (p x f), written out (np.cross is slow)
    m_y = float(np.dot(z, fx) - np.dot(x, fz))
    return f, np.array([-m_y / f[2], m_x / f[2]])


def measure_rows(scene: Scene, result) -> RowMeasurements:
    """:class:`RowMeasurements` of a :class:`~biped.sim.push.PushResult` run on ``scene``."""
    m = scene.model
    d = mujoco.MjData(m)
    n = len(result.times)
    iv = scene.biped_qvel_index
    cb = scene.central_body
    foot_of_body = np.full(m.nbody, -1, dtype=np.int64)
    for i, ids in enumerate(foot_bodies(m)):
        foot_of_body[ids] = i
    floor, block = scene.floor_geom, scene.block_geom
    biped_geoms = np.zeros(m.ngeom, dtype=bool)
    biped_geoms[list(scene.biped_geoms)] = True
    com = np.zeros((n, 3))
    com_vel = np.zeros((n, 3))
    angvel = np.zeros((n, 3))
    wcom = np.zeros((n, 3))
    wcom_vel = np.zeros((n, 3))
    grf = np.zeros((n, 2, 3))
    cop = np.full((n, 2, 2), np.nan)
    touch = np.zeros(n, dtype=bool)
    f6 = np.zeros(6)
    inputs = getattr(result, "extra", {}).get("inputs")  # a perturbation's forces and actuators
    for k in range(n):
        d.qpos[:] = result.qpos[k]
        d.qvel[:] = result.qvel[k]
        d.ctrl[:] = 0.0
        if inputs is not None:
            j = int(np.searchsorted(inputs["rows"], k, side="right")) - 1
            if j >= 0:
                d.ctrl[:] = inputs["ctrl"][j]
                d.xfrc_applied[:] = inputs["xfrc"][j]
        d.ctrl[scene.actuator_index] = result.torques[k]
        mujoco.mj_forward(m, d)
        mujoco.mj_subtreeVel(m, d)
        d.qacc_warmstart[:] = d.qacc
        com[k] = d.xipos[cb]
        wcom[k] = d.subtree_com[cb]
        wcom_vel[k] = d.subtree_linvel[cb]
        # free joint: qvel[0:3] is the frame origin's world velocity, qvel[3:6] the angular
        # velocity in the body frame; the central body's frame origin is its COM (Scene checks)
        com_vel[k] = d.qvel[iv[:3]]
        angvel[k] = d.xmat[cb].reshape(3, 3) @ d.qvel[iv[3:6]]
        nc = d.ncon
        if nc == 0:
            continue
        geom = d.contact.geom[:nc]
        is_floor = geom == floor
        on_floor = is_floor.any(axis=1)
        other = np.where(is_floor[:, 0], geom[:, 1], geom[:, 0])
        side = np.where(on_floor, foot_of_body[m.geom_bodyid[other]], -1)
        is_block = (geom == block).any(axis=1)
        touch[k] = bool((is_block & biped_geoms[geom].any(axis=1)).any())
        if not (side >= 0).any():
            continue
        frames = d.contact.frame[:nc].reshape(nc, 3, 3)
        pos = d.contact.pos[:nc]
        f_world = np.zeros((nc, 3))
        for c in np.flatnonzero(side >= 0):
            mujoco.mj_contactForce(m, d, int(c), f6)
            # contact frame rows: the normal (from geom1 to geom2), then two tangents; the force
            # in that frame acts on geom2 (its opposite on geom1)
            f = frames[c].T @ f6[:3]
            f_world[c] = f if other[c] == geom[c, 1] else -f
        for i in range(2):
            sel = side == i
            if sel.any():
                grf[k, i], cop[k, i] = centre_of_pressure(pos[sel], f_world[sel])
    biped_mass = float(m.body_subtreemass[cb])
    return RowMeasurements(
        central_body_com=com,
        central_body_com_vel=com_vel,
        central_body_angvel=angvel,
        whole_body_com=wcom,
        whole_body_com_vel=wcom_vel,
        grf=grf,
        cop=cop,
        block_touches_biped=touch,
        biped_mass_kg=biped_mass,
        gravity=np.array(m.opt.gravity),
    )


@dataclass(frozen=True)
class BlockSeparation:
    """The end of the block's first contact with the biped.

    contact_time_s: the first row with a block-biped contact (None: no hit); time_s: the first
    row after it without one (None: still touching at the end); momentum (3,) [kg m/s]: the
    block's momentum at ``time_s`` (NaN when it never left); row: its row index (or None)."""

    contact_time_s: float | None
    time_s: float | None
    momentum: np.ndarray
    row: int | None


def block_separation(result, rows: RowMeasurements, block_mass_kg: float | None = None) -> BlockSeparation:
    """When the block leaves the body after its first hit, and its momentum then: the first row
    after the first block-biped contact (``rows.block_touches_biped``, MuJoCo's contacts at the
    row's state) with no such contact. ``block_mass_kg`` defaults to the scenario's."""
    mass = result.scenario.block_mass_kg if block_mass_kg is None else block_mass_kg
    touch = np.asarray(rows.block_touches_biped, dtype=bool)
    hit = np.flatnonzero(touch)
    if hit.size == 0:
        return BlockSeparation(None, None, np.full(3, np.nan), None)
    k0 = int(hit[0])
    free = np.flatnonzero(~touch[k0:])
    t0 = float(result.times[k0])
    if free.size == 0:
        return BlockSeparation(t0, None, np.full(3, np.nan), None)
    k = k0 + int(free[0])
    return BlockSeparation(t0, float(result.times[k]), mass * np.asarray(result.block_velocity[k]), k)


def foot_drift(result) -> dict | None:
    """How far each foot moved on the floor between the block's hit and the end of the run:
    ``{"from_s": t_hit, "to_s": t_end, "left": [dx, dy, dz], "right": [...]}`` [m], the foot
    frames' displacement (MuJoCo kinematics of the recorded qpos). Without a hit the reference is
    the first row where both feet are flat (heel and toe on the floor); None if there is none.
    The same numbers are the differences of trajectory.csv's ``<foot>_foot_x/y/z`` at those
    two times."""
    n = len(result.times)
    if result.feet_pos is None or n == 0:
        return None
    if result.block_contact_time_s is not None:
        k = int(np.argmin(np.abs(result.times - result.block_contact_time_s)))
    else:
        flat = np.flatnonzero(np.asarray(result.contacts).all(axis=1))
        if flat.size == 0:
            return None
        k = int(flat[0])
    d = result.feet_pos[-1] - result.feet_pos[k]
    return {
        "from_s": float(result.times[k]),
        "to_s": float(result.times[-1]),
        **{foot: d[i].tolist() for i, foot in enumerate(FEET)},
    }
