"""A :class:`~biped.viz.replay.Replay` from a MuJoCo model and a recorded ``qpos`` trajectory:
MuJoCo's forward kinematics gives every visible geom's world pose a frame; mesh geoms (a robot's
links) are drawn as their meshes, simplified to a face budget (:mod:`biped.viz.replay_mesh`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from biped.errors import BipedError, ModelError, StateError
from biped.viz.replay import Replay, ReplayGeom
from biped.viz.replay_arrow import arrow_edges, check_arrow
from biped.viz.replay_mesh import MAX_FACES, replay_meshes

if TYPE_CHECKING:  # pragma: no cover
    import mujoco

__all__ = ["replay_from_mujoco"]

# mjtGeom numbers (stable across MuJoCo versions): plane 0, hfield 1, sphere 2, capsule 3,
# ellipsoid 4, cylinder 5, box 6, mesh 7, sdf 8.
_MJ_KIND = {0: "plane", 2: "sphere", 3: "capsule", 4: "ellipsoid", 5: "cylinder", 6: "box"}
_MJ_DEFAULT_RGBA = (0.5, 0.5, 0.5, 1.0)


def _material_rgba(model, matid: int) -> tuple:
    """Colour of a material: its rgba times the mean colour of its first texture, if any (the
    page draws no textures; a checkered floor shows as its average grey)."""
    rgba = np.array(model.mat_rgba[matid], dtype=float)
    texids = np.atleast_1d(model.mat_texid[matid])
    texids = texids[texids >= 0]
    if texids.size:
        t = int(texids[0])
        n, adr = int(model.tex_nchannel[t]), int(model.tex_adr[t])
        size = int(model.tex_width[t]) * int(model.tex_height[t]) * n
        if n >= 3 and size > 0:
            pix = np.asarray(model.tex_data[adr : adr + size], dtype=float).reshape(-1, n)
            rgba[:3] *= pix[:, :3].mean(axis=0) / 255.0
    return tuple(float(c) for c in rgba)


def replay_from_mujoco(
    model: mujoco.MjModel,
    times,
    qpos,
    *,
    geom_groups=None,
    title: str = "biped replay",
    info: Mapping[str, Any] | None = None,
    markers: Iterable[Mapping] = (),
    follow: str | None = None,
    max_rate_hz: float | None = 100.0,
    arrow=None,
    max_mesh_faces: int = MAX_FACES,
) -> Replay:
    """Record the world pose of each visible geom of ``model`` along a trajectory.

    Runs ``mujoco.mj_kinematics`` on a fresh ``MjData`` for each row of ``qpos`` (the model is not
    modified) and reads ``geom_xpos`` / ``geom_xmat``.

    Args:
        model: a compiled ``mujoco.MjModel``.
        times: (T,) s, strictly increasing.
        qpos: (T, nq) generalized positions, MuJoCo's layout (free joints: position, then the
            quaternion (w, x, y, z)).
        geom_groups: the geom groups to draw (MuJoCo's ``group`` attribute); ``None`` draws groups
            0, 1 and 2, what MuJoCo's viewer shows by default. Fully transparent geoms
            (alpha 0) and height fields are always left out. Mesh geoms are drawn as their
            meshes (MuJoCo's compiled vertices, in the geom's frame).
        title, info, markers, follow: see :class:`Replay`.
        arrow: None, or (T, 2, 3) one arrow a sample of ``times`` (see :class:`Replay`); thinned
            with the frames, keeping too the samples on both sides of each moment an arrow appears
            or goes, so even a push shorter than a frame shows, and shows when it acts.
        max_rate_hz: keep samples at least ``1 / max_rate_hz`` s apart (plus the last one), so
            a 500 Hz control-rate trajectory makes a 100 frames/s replay (the page interpolates
            between frames); ``None`` keeps every sample. File size is about
            37 bytes x geoms x frames + 0.8 MB for three.js, plus 16 bytes a mesh vertex and
            16 a face.
        max_mesh_faces: the meshes' faces together are simplified to at most this many
            (:func:`biped.viz.replay_mesh.replay_meshes`; a robot's visual meshes hold up to
            1.4 million).

    Returns:
        a :class:`Replay` with one :class:`ReplayGeom` per drawn geom, named after the MJCF
        (``geom<i>`` for unnamed geoms).

    Raises:
        StateError: ``times`` / ``qpos`` of the wrong shape or with non-finite entries.
        ModelError: ``model`` is not an ``MjModel`` or no geom is left to draw.
    """
    import mujoco

    if not isinstance(model, mujoco.MjModel):
        raise ModelError(f"model must be a mujoco.MjModel, got {type(model).__name__}")
    times = np.asarray(times, dtype=float)
    qpos = np.asarray(qpos, dtype=float)
    if times.ndim != 1:
        raise StateError(f"times must have shape (T,), got {times.shape}")
    if qpos.shape != (times.size, model.nq):
        raise StateError(
            f"qpos must have shape (T, nq) = ({times.size}, {model.nq}) to match times and the "
            f"model, got {qpos.shape}"
        )
    if not np.all(np.isfinite(qpos)):
        bad = np.argwhere(~np.isfinite(qpos))[0]
        raise StateError(f"qpos contains a non-finite entry at frame {bad[0]}, coordinate {bad[1]}")

    if arrow is not None:
        arrow = check_arrow(arrow, times.size)
    if max_rate_hz is not None:
        if not (isinstance(max_rate_hz, (int, float)) and max_rate_hz > 0):
            raise BipedError(
                f"max_rate_hz must be a positive number of frames per second or None, got {max_rate_hz!r}"
            )
        keep = _thin(times, 1.0 / float(max_rate_hz))
        if arrow is not None:  # the samples where an arrow appears or goes, kept too
            keep = np.union1d(keep, arrow_edges(arrow))
            arrow = arrow[keep]
        times, qpos = times[keep], qpos[keep]

    groups = {0, 1, 2} if geom_groups is None else {int(g) for g in geom_groups}
    ids, geoms, offsets = [], [], []
    mesh_ids: dict[int, int] = {}  # MuJoCo mesh id -> index in the replay's meshes
    for i in range(model.ngeom):
        gtype = int(model.geom_type[i])
        if int(model.geom_group[i]) not in groups:
            continue
        rgba = tuple(float(c) for c in model.geom_rgba[i])
        matid = int(model.geom_matid[i])
        if matid >= 0 and np.allclose(rgba, _MJ_DEFAULT_RGBA):
            rgba = _material_rgba(model, matid)
        if rgba[3] <= 0.0:
            continue
        name = model.geom(i).name or f"geom{i}"
        size = model.geom_size[i]
        mesh = -1
        offset = np.zeros(3)
        if gtype in _MJ_KIND:
            kind = _MJ_KIND[gtype]
            size = {"sphere": size[:1], "capsule": size[:2], "cylinder": size[:2], "plane": size[:2]}.get(
                kind, size[:3]
            )
        elif gtype == 7:  # mesh: its vertices are in the geom's frame; size: its box's half sizes
            kind = "mesh"
            size = model.geom_aabb[i, 3:6]
            mesh = mesh_ids.setdefault(int(model.geom_dataid[i]), len(mesh_ids))
        else:
            continue
        ids.append(i)
        offsets.append(offset)
        geoms.append(
            ReplayGeom(
                name=name,
                kind=kind,
                size=tuple(np.abs(size)),
                rgba=tuple(min(max(c, 0.0), 1.0) for c in rgba),
                mesh=mesh,
            )
        )
    if not ids:
        raise ModelError(
            f"no geom to draw: the model's geoms are in groups "
            f"{sorted(set(map(int, model.geom_group)))}, geom_groups asked for {sorted(groups)}"
        )

    data = mujoco.MjData(model)
    T, G = times.size, len(ids)
    pos = np.empty((T, G, 3))
    quat = np.empty((T, G, 4))
    ids_arr = np.asarray(ids)
    offsets_arr = np.asarray(offsets)
    has_offset = bool(np.any(offsets_arr))
    for t in range(T):
        data.qpos[:] = qpos[t]
        mujoco.mj_kinematics(model, data)
        xmat = data.geom_xmat[ids_arr].reshape(G, 3, 3)
        pos[t] = data.geom_xpos[ids_arr]
        if has_offset:
            pos[t] += np.einsum("gij,gj->gi", xmat, offsets_arr)
        for g in range(G):
            mujoco.mju_mat2Quat(quat[t, g], data.geom_xmat[ids_arr[g]])
    return Replay(
        geoms=tuple(geoms),
        times=times,
        pos=pos,
        quat=quat,
        title=title,
        info=dict(info or {}),
        markers=tuple(markers),
        follow=follow,
        arrow=arrow,
        meshes=replay_meshes(model, list(mesh_ids), max_mesh_faces),
    )


def _thin(times: np.ndarray, dt: float) -> np.ndarray:
    """Indices of the samples of ``times`` (T,) at least ``dt`` s apart, first and last kept."""
    keep, last = [0], times[0] if times.size else 0.0
    for k in range(1, times.size):
        if times[k] - last >= dt * (1 - 1e-6):
            keep.append(k)
            last = times[k]
    if times.size > 1 and keep[-1] != times.size - 1:
        keep.append(times.size - 1)
    return np.asarray(keep, dtype=int)
