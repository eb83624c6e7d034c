"""What the push loop records of each row for the response measures (:mod:`biped.sim.response`),
read from MuJoCo's own forward pass while the loop runs instead of a second pass afterwards.

The first physics step of control period k (``mj_step``: the forward pass at row k's state, then
Euler's integration, which leaves the forward pass's outputs in place) has computed everything
the response needs of row k: the whole-body COM (``subtree_com``), the bodies' velocities
(``cvel``, from which ``mj_subtreeVel`` gives the whole-body COM velocity), the contacts and their
constraint forces (``mj_contactForce``), the bodies' poses. After that step the loop (the compiled
one, :mod:`biped.sim.fused`, through libmujoco's C functions; the Python one through the
bindings) writes one row of :data:`NCOL` numbers (the column slices below). A row no step follows
(the last, a fall's, one a stop left) is filled afterwards by ``mj_forward`` at its state
(:func:`fill_rows`), as :func:`biped.sim.measure.measure_rows` does every row.

The numbers are MuJoCo's, as :func:`~biped.sim.measure.measure_rows` gives them: the COM, its
velocity and the body poses are the same functions of the same state; the contact forces are the
constraint solution the simulation itself used, where ``measure_rows`` solves the same problem
again from another warm start, so the two agree to the solver's tolerance
(``tests/test_loop_measures.py``). It costs a few microseconds a row, against ~0.5 ms a row for
``measure_rows`` (a forward pass and Python per row).
"""

from __future__ import annotations

import threading
import weakref
from dataclasses import dataclass

import mujoco
import numpy as np
from numba import njit

__all__ = ["NCOL", "LoopRows", "fill_rows", "loop_rows", "record_python", "record_row", "row_spec"]

#: columns of a row: whole-body COM (3), its velocity (3), the floor's force on each foot
#: (left, right: 3 each), each foot's centre of pressure (x, y; NaN without vertical load), the
#: frame origins of the left and right ankle_1 and hip_1 bodies (3 each) and the central body's
#: z axis (3), all world frame
WCOM, WVEL, GRF, COP, LIMBS, TRUNK = (
    slice(0, 3),
    slice(3, 6),
    slice(6, 12),
    slice(12, 16),
    slice(16, 28),
    slice(28, 31),
)
NCOL = 31
#: the bodies whose frame origins fill LIMBS, in order
LIMB_BODIES = ("left_ankle_1", "right_ankle_1", "left_hip_1", "right_hip_1")


@dataclass(frozen=True)
class RowSpec:
    """What :func:`record_row` needs of a scene: the central body, the floor geom, each geom's foot
    (0 left, 1 right, -1 none: the foot body or a body below it) and the :data:`LIMB_BODIES`."""

    central_body: int
    floor: int
    foot_of_geom: np.ndarray  # (ngeom,) int64
    limbs: np.ndarray  # (4,) int64


_SPECS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # model -> RowSpec
_LOCAL = threading.local()  # .data: model -> an MjData for fill_rows, one a thread (~1 ms to make)


def row_spec(scene) -> RowSpec:
    """The :class:`RowSpec` of a :class:`~biped.sim.scene.Scene` (once a model)."""
    found = _SPECS.get(scene.model)
    if found is not None and (found.central_body, found.floor) == (scene.central_body, scene.floor_geom):
        return found
    from biped.sim.measure import foot_bodies

    m = scene.model
    foot_of_body = np.full(m.nbody, -1, dtype=np.int64)
    for i, ids in enumerate(foot_bodies(m)):
        foot_of_body[ids] = i
    spec = RowSpec(
        central_body=int(scene.central_body),
        floor=int(scene.floor_geom),
        foot_of_geom=np.ascontiguousarray(foot_of_body[m.geom_bodyid]),
        limbs=np.array([m.body(b).id for b in LIMB_BODIES], dtype=np.int64),
    )
    _SPECS[m] = spec
    return spec


@njit(cache=True)
def _feet_forces(ncon, geom, cpos, frames, f6s, foot_of_geom, floor, out):  # pragma: no cover - compiled
    """GRF and CoP columns of ``out`` from the ``ncon`` contacts (geom pairs, positions, frames)
    and their forces in the contact frame ``f6s`` (ncon, 6) (biped.sim.measure.measure_rows'
    rules: a contact of the floor and a geom of a foot; the force on the foot; the CoP on z = 0)."""
    # the two feet's sums as scalars (no array to allocate, a row costs ~1 us)
    lfx = lfy = lfz = lmx = lmy = 0.0
    rfx = rfy = rfz = rmx = rmy = 0.0
    for c in range(ncon):
        g0, g1 = geom[c, 0], geom[c, 1]
        if g0 == floor:
            other, sign = g1, 1.0
        elif g1 == floor:
            other, sign = g0, -1.0
        else:
            continue
        i = foot_of_geom[other]
        if i < 0:
            continue
        a, b, e = f6s[c, 0], f6s[c, 1], f6s[c, 2]  # frame rows: normal, tangents; on geom2
        f0 = sign * (frames[c, 0] * a + frames[c, 3] * b + frames[c, 6] * e)
        f1 = sign * (frames[c, 1] * a + frames[c, 4] * b + frames[c, 7] * e)
        f2 = sign * (frames[c, 2] * a + frames[c, 5] * b + frames[c, 8] * e)
        x, y, z = cpos[c, 0], cpos[c, 1], cpos[c, 2]
        if i == 0:
            lfx += f0
            lfy += f1
            lfz += f2
            lmx += y * f2 - z * f1
            lmy += z * f0 - x * f2
        else:
            rfx += f0
            rfy += f1
            rfz += f2
            rmx += y * f2 - z * f1
            rmy += z * f0 - x * f2
    _put_foot(out, 0, lfx, lfy, lfz, lmx, lmy)
    _put_foot(out, 1, rfx, rfy, rfz, rmx, rmy)


@njit(cache=True)
def _put_foot(out, i, fx, fy, fz, mx, my):  # pragma: no cover - compiled
    out[6 + 3 * i] = fx
    out[7 + 3 * i] = fy
    out[8 + 3 * i] = fz
    if fz > 0.0:
        out[12 + 2 * i] = -my / fz
        out[13 + 2 * i] = mx / fz
    else:
        out[12 + 2 * i] = np.nan
        out[13 + 2 * i] = np.nan


@njit(cache=True)
def _bodies(cb, limbs, xpos, xmat, scom, slin, out):  # pragma: no cover - compiled
    for j in range(3):
        out[j] = scom[cb, j]
        out[3 + j] = slin[cb, j]
        out[28 + j] = xmat[cb, 2 + 3 * j]  # the z axis: xmat's third column
        for b in range(4):
            out[16 + 3 * b + j] = xpos[limbs[b], j]


@njit(cache=True)
def record_row(
    subtree_vel,
    contact_force,
    m,
    d,
    ncon,
    geom,
    cpos,
    frames,
    f6s,
    foot_of_geom,
    floor,
    cb,
    limbs,
    xpos,
    xmat,
    scom,
    slin,
    out,
):  # pragma: no cover - compiled (the Python loop's record_python is its twin)
    """One row (``out``, :data:`NCOL`) after the step's forward pass, in compiled code: libmujoco's
    ``mj_subtreeVel`` (``subtree_vel``) and ``mj_contactForce`` (``contact_force``) on the model and
    data at addresses ``m``, ``d``; ``f6s`` (capacity, 6) scratch for the contact forces."""  # fmt: skip
    subtree_vel(m, d)
    _bodies(cb, limbs, xpos, xmat, scom, slin, out)
    n = min(ncon, f6s.shape[0])
    for c in range(n):
        if geom[c, 0] == floor or geom[c, 1] == floor:
            contact_force(m, d, np.int32(c), f6s[c].ctypes.data)
    _feet_forces(n, geom, cpos, frames, f6s, foot_of_geom, floor, out)


def record_python(m, d, spec: RowSpec, out: np.ndarray, f6: np.ndarray) -> None:
    """:func:`record_row` through the bindings, in Python (the Python loop and :func:`fill_rows`;
    nothing to compile): the same operations in the same order on the same doubles, so the same
    numbers bit for bit (``tests/test_sim_fused.py``). ``f6`` (6,) scratch."""
    mujoco.mj_subtreeVel(m, d)
    cb = spec.central_body
    out[WCOM] = d.subtree_com[cb]
    out[WVEL] = d.subtree_linvel[cb]
    out[LIMBS] = d.xpos[spec.limbs].ravel()
    out[TRUNK] = d.xmat[cb, 2::3]  # the z axis: xmat's third column
    fx, fy, fz, mx, my = [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]
    n = d.ncon
    if n:
        con = d.contact
        geom, pos, frames = con.geom.tolist(), con.pos.tolist(), con.frame.tolist()
        floor, foot_of = spec.floor, spec.foot_of_geom
        for c in range(n):
            g0, g1 = geom[c]
            if g0 == floor:
                other, sign = g1, 1.0
            elif g1 == floor:
                other, sign = g0, -1.0
            else:
                continue
            i = int(foot_of[other])
            if i < 0:
                continue
            mujoco.mj_contactForce(m, d, c, f6)
            a, b, e = float(f6[0]), float(f6[1]), float(f6[2])
            fr = frames[c]
            f = [sign * (fr[j] * a + fr[3 + j] * b + fr[6 + j] * e) for j in range(3)]
            x, y, z = pos[c]
            fx[i] += f[0]
            fy[i] += f[1]
            fz[i] += f[2]
            mx[i] += y * f[2] - z * f[1]
            my[i] += z * f[0] - x * f[2]
    for i in range(2):
        out[6 + 3 * i : 9 + 3 * i] = fx[i], fy[i], fz[i]
        if fz[i] > 0.0:
            out[12 + 2 * i : 14 + 2 * i] = -my[i] / fz[i], mx[i] / fz[i]
        else:
            out[12 + 2 * i : 14 + 2 * i] = np.nan


def fill_rows(scene, qpos, qvel, torques, inputs, rows, out: np.ndarray) -> None:
    """Rows ``rows`` of ``out`` by ``mj_forward`` at their recorded state with their torques and
    the perturbation's ``inputs`` (``PushResult.extra["inputs"]``, or None), as
    :func:`biped.sim.measure.measure_rows` evaluates a row: for the rows no physics step followed."""
    if not len(rows):
        return
    m = scene.model
    spec = row_spec(scene)
    datas = _LOCAL.__dict__.setdefault("data", weakref.WeakKeyDictionary())
    d = datas.get(m)
    if d is None:
        d = datas[m] = mujoco.MjData(m)
    f6 = np.zeros(6)
    for k in rows:
        mujoco.mj_resetData(m, d)  # as a new MjData: no warm start, no state of another run
        d.qpos[:] = qpos[k]
        d.qvel[:] = qvel[k]
        d.ctrl[:] = 0.0
        d.xfrc_applied[:] = 0.0
        if inputs is not None:
            j = int(np.searchsorted(inputs["rows"], k, side="right")) - 1
            if j >= 0:
                d.ctrl[:] = inputs["ctrl"][j]
                d.xfrc_applied[:] = inputs["xfrc"][j]
        d.ctrl[scene.actuator_index] = torques[k]
        mujoco.mj_forward(m, d)
        record_python(m, d, spec, out[k], f6)


@dataclass(frozen=True, eq=False)
class LoopRows:
    """The response's rows (n rows, world frame, SI units) from a run's loop records: the fields
    of :class:`biped.sim.measure.RowMeasurements` that :func:`biped.sim.response.measure_response`
    reads, and ``limbs`` (n, 4, 3) the :data:`LIMB_BODIES` frame origins and ``trunk_z`` (n, 3)
    the central body's z axis (for :func:`biped.sim.response.body_angles`)."""

    whole_body_com: np.ndarray
    whole_body_com_vel: np.ndarray
    grf: np.ndarray
    cop: np.ndarray
    gravity: np.ndarray
    limbs: np.ndarray
    trunk_z: np.ndarray


def loop_rows(scene, result) -> LoopRows | None:
    """The :class:`LoopRows` of ``result`` (its ``loop_measures``), or None if it has none."""
    rec = getattr(result, "loop_measures", None)
    if rec is None:
        return None
    n = len(rec)
    return LoopRows(
        whole_body_com=rec[:, WCOM],
        whole_body_com_vel=rec[:, WVEL],
        grf=rec[:, GRF].reshape(n, 2, 3),
        cop=rec[:, COP].reshape(n, 2, 2),
        gravity=np.array(scene.model.opt.gravity),
        limbs=rec[:, LIMBS].reshape(n, 4, 3),
        trunk_z=rec[:, TRUNK],
    )
