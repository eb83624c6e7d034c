"""Files of a kinematic walk: trajectory.csv, the 3D replay, the figure's MJCF trajectory for video.

Each function is a function of (motion, ...) and writes or returns one product; ``biped walk``
calls them in turn.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from biped.kinematic.figure import JOINT_NAMES, figure_mjcf, replay_geoms

__all__ = ["CSV_COLUMNS", "build_replay", "figure_model", "figure_qpos", "write_trajectory_csv"]

_POINTS = ("left_heel", "left_toe", "right_heel", "right_toe")
#: Columns of trajectory.csv: time [s], the 12 joint angles [rad], the pelvis (mid-hip point) and
#: the sole points [m, world], and whether each foot bears weight (0/1).
CSV_COLUMNS = (("time",) + JOINT_NAMES + ("pelvis_x", "pelvis_y", "pelvis_z")
               + tuple(f"{p}_{a}" for p in _POINTS for a in "xyz") + ("left_stance", "right_stance"))


def write_trajectory_csv(motion, landmarks: dict, path) -> Path:
    """trajectory.csv: one row per sample, columns :data:`CSV_COLUMNS` (SI units, rad)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    cols = [motion.times[:, None], motion.angles, motion.pelvis_pos]
    cols += [landmarks[p] for p in _POINTS]
    cols.append(motion.stance.astype(float))
    table = np.hstack(cols)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(CSV_COLUMNS)
        for row in table:
            w.writerow([f"{v:.9g}" for v in row])
    return path


def build_replay(motion, title: str, info: dict | None = None, rate: float = 60.0):
    """The motion as a :class:`biped.viz.replay.Replay`: the 15 parts at their world poses, the
    floor and the stairs (static), gait changes as markers; at most ``rate`` frames per second."""
    from biped.viz.replay import Replay, ReplayGeom

    t = motion.times
    n = max(2, math.floor((t[-1] - t[0]) * rate) + 1)
    idx = np.unique(np.clip(np.searchsorted(t, t[0] + np.arange(n) / rate - 1e-9), 0, t.size - 1))
    if idx[-1] != t.size - 1:
        idx = np.append(idx, t.size - 1)
    poses = motion.poses()
    sub = type(poses)(poses.pos[idx], poses.rot[idx])
    geoms, pos, quat = replay_geoms(motion.dims, sub)
    statics = [ReplayGeom("floor", "plane", (0.0, 0.0), (0.85, 0.85, 0.85, 1.0))]
    spos, squat = [np.zeros(3)], [np.array([1.0, 0.0, 0.0, 0.0])]
    for k, (c, h) in enumerate(motion.plan.terrain.boxes(width=1.2)):
        statics.append(ReplayGeom(f"stair{k + 1}", "box", h, (0.62, 0.6, 0.55, 1.0)))
        spos.append(np.asarray(c))
        squat.append(np.array([1.0, 0.0, 0.0, 0.0]))
    T = idx.size
    pos = np.concatenate([pos, np.broadcast_to(np.array(spos), (T, len(spos), 3))], axis=1)
    quat = np.concatenate([quat, np.broadcast_to(np.array(squat), (T, len(squat), 4))], axis=1)
    return Replay(geoms=tuple(geoms) + tuple(statics), times=t[idx], pos=pos, quat=quat, title=title,
                  info=dict(info or {}), markers=tuple(motion.plan.markers))


def figure_model(motion):
    """``mujoco.MjModel`` of the figure on its terrain (:func:`~biped.kinematic.figure.figure_mjcf`)."""
    import mujoco

    return mujoco.MjModel.from_xml_string(figure_mjcf(motion.dims, motion.plan.terrain.boxes(width=1.2)))


def figure_qpos(model, motion) -> np.ndarray:
    """(T, nq) qpos of :func:`figure_model` for the motion, joints addressed by name."""
    from biped.spatial import rot_to_quat

    T = motion.times.size
    q = np.zeros((T, model.nq))
    root = model.joint("pelvis").qposadr[0]
    q[:, root:root + 3] = motion.pelvis_pos
    prev = None
    for t in range(T):
        qt = rot_to_quat(np.ascontiguousarray(motion.pelvis_rot[t]))
        if prev is not None and float(qt @ prev) < 0:
            qt = -qt
        q[t, root + 3:root + 7] = prev = qt
    for j, name in enumerate(JOINT_NAMES):
        q[:, model.joint(name).qposadr[0]] = motion.angles[:, j]
    return q
