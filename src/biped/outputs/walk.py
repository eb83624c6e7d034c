"""Files of a kinematic walk (``biped walk``): trajectory.csv, summary.json, figures/,
replay.html and video.mp4 of Bediz's figure.

Each of :func:`write_trajectory_csv`, :func:`build_replay`, :func:`figure_model` and
:func:`figure_qpos` is a function of (motion, ...) and writes or returns one product;
:func:`write_walk` runs them in turn and writes the summary.
"""

from __future__ import annotations

import csv
import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from biped import files
from biped.kinematic.dynamics import InverseDynamics, inverse_dynamics, load_biped
from biped.kinematic.figure import (
    JOINT_NAMES,
    PARTS,
    FigureDims,
    FigurePoses,
    figure_mjcf,
    part_geoms,
)
from biped.kinematic.gaits import Motion, WalkMetrics, stair_geometry, walk_metrics
from biped.outputs._json import write_json
from biped.spatial import rot_to_quat
from biped.viz.replay import Replay, ReplayGeom, write_replay
from biped.viz.video import render_video
from biped.viz.walk_figures import plot_feet, plot_inverse_dynamics, plot_joint_angles

__all__ = [
    "CSV_COLUMNS",
    "build_replay",
    "figure_model",
    "figure_qpos",
    "inverse_dynamics_columns",
    "replay_geoms",
    "write_inverse_dynamics_csv",
    "write_trajectory_csv",
    "write_walk",
]

_POINTS = ("left_heel", "left_toe", "right_heel", "right_toe")
#: Columns of trajectory.csv: time [s], the 12 joint angles [rad], the pelvis (mid-hip point) and
#: the sole points [m, world], and whether each foot bears weight (0/1).
CSV_COLUMNS = (
    ("time",)
    + JOINT_NAMES
    + ("pelvis_x", "pelvis_y", "pelvis_z")
    + tuple(f"{p}_{a}" for p in _POINTS for a in "xyz")
    + ("left_stance", "right_stance")
)


def trajectory_column_units() -> dict[str, dict[str, str]]:
    """``{column: {"unit", "meaning"}}`` of trajectory.csv (:data:`CSV_COLUMNS`)."""
    out = {"time": {"unit": "s", "meaning": "time of the sample"}}
    for name in CSV_COLUMNS[1:]:
        if name in JOINT_NAMES:
            out[name] = {"unit": "rad", "meaning": f"the figure's joint angle {name}"}
        elif name.endswith("_stance"):
            out[name] = {"unit": "0/1", "meaning": f"the {name.split('_')[0]} foot bears weight"}
        elif name.startswith("pelvis_"):
            out[name] = {"unit": "m", "meaning": f"mid-hip point, world {name[-1]}"}
        else:
            point = name[:-2].replace("_", " ")
            out[name] = {"unit": "m", "meaning": f"{point} (end of the sole's centre line), world {name[-1]}"}
    return out


def write_trajectory_csv(motion, landmarks: dict, path) -> Path:
    """trajectory.csv: one row per sample, columns :data:`CSV_COLUMNS` (SI units, rad)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    cols = [motion.times[:, None], motion.angles, motion.pelvis_pos]
    cols += [landmarks[p] for p in _POINTS]
    cols.append(motion.stance.astype(float))
    table = np.hstack(cols)
    with files.atomic_open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(CSV_COLUMNS)
        for row in table:
            w.writerow([f"{v:.9g}" for v in row])
    return path


def inverse_dynamics_columns(joint_names) -> list[tuple[str, str, str]]:
    """(name, unit, meaning) of each column of inverse_dynamics.csv."""
    cols = [("time", "s", "time of the sample")]
    cols += [(f"tau_{j}", "N m", f"joint torque the motion needs at {j} (mj_inverse)") for j in joint_names]
    for side in ("left", "right"):
        cols += [(f"{side}_stance", "0/1", f"the {side} foot bears weight")]
        cols += [
            (
                f"{side}_grf_{a}",
                "N",
                (f"ground force on the {side} sole, world {a} (min-norm split with two feet down)"),
            )
            for a in "xyz"
        ]
        cols += [
            (f"{side}_grm_{a}", "N m", (f"ground moment on the {side} sole about its centre, world {a}"))
            for a in "xyz"
        ]
        cols += [
            (
                f"{side}_cop_{a}",
                "m",
                (f"{side} centre of pressure, world {a} (empty when the foot carries no load)"),
            )
            for a in "xyz"
        ]
    cols += [
        (f"residual_{a}", "N", "root force no foot can supply (flight), world frame")
        for a in ("fx", "fy", "fz")
    ]
    cols += [
        (f"residual_{a}", "N m", ("root torque no foot can supply (flight), central-body frame"))
        for a in ("mx", "my", "mz")
    ]
    return cols


def write_inverse_dynamics_csv(idyn, path) -> Path:
    """inverse_dynamics.csv: one row per sample of the inverse dynamics ``idyn``
    (:class:`~biped.kinematic.dynamics.InverseDynamics`), columns
    :func:`inverse_dynamics_columns` (SI units, world frame); empty fields are quantities that do
    not exist at that sample (the CoP of a foot in the air)."""
    path = Path(path)
    cols = [idyn.times[:, None], idyn.torques]
    for j in range(2):
        cols += [
            idyn.stance[:, j : j + 1].astype(float),
            idyn.grf[:, j],
            idyn.grf_moment[:, j],
            idyn.cop[:, j],
        ]
    cols.append(idyn.residual)
    table = np.hstack(cols)
    with files.atomic_open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow([c[0] for c in inverse_dynamics_columns(idyn.joint_names)])
        for row in table:
            w.writerow(["" if not np.isfinite(v) else f"{v:.9g}" for v in row])
    return path


def replay_geoms(dims: FigureDims, poses: FigurePoses):
    """The figure as :class:`biped.viz.replay.ReplayGeom` shapes with world poses.

    Returns ``(geoms (15,), pos (T, 15, 3), quat (T, 15, 4))``, quaternions (w, x, y, z).
    """
    shapes = part_geoms(dims)
    geoms, pos = [], np.empty_like(poses.pos)
    quat = np.empty(poses.pos.shape[:2] + (4,))
    for i, p in enumerate(PARTS):
        kind, size, centre = shapes[p.name]
        geoms.append(ReplayGeom(p.name, kind, size, p.rgba))
        pos[:, i] = poses.pos[:, i] + np.einsum("tij,j->ti", poses.rot[:, i], centre)
        for t in range(poses.pos.shape[0]):
            quat[t, i] = rot_to_quat(np.ascontiguousarray(poses.rot[t, i]))
    return tuple(geoms), pos, quat


def build_replay(motion, title: str, info: dict | None = None, rate: float = 60.0):
    """The motion as a :class:`biped.viz.replay.Replay`: the 15 parts at their world poses, the
    floor and the stairs (static), gait changes as markers; at most ``rate`` frames per second."""
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
    return Replay(
        geoms=tuple(geoms) + tuple(statics),
        times=t[idx],
        pos=pos,
        quat=quat,
        title=title,
        info=dict(info or {}),
        markers=tuple(motion.plan.markers),
    )


def figure_model(motion):
    """``mujoco.MjModel`` of the figure on its terrain (:func:`~biped.kinematic.figure.figure_mjcf`)."""
    return mujoco.MjModel.from_xml_string(figure_mjcf(motion.dims, motion.plan.terrain.boxes(width=1.2)))


def figure_qpos(model, motion) -> np.ndarray:
    """(T, nq) qpos of :func:`figure_model` for the motion, joints addressed by name."""
    T = motion.times.size
    q = np.zeros((T, model.nq))
    root = model.joint("pelvis").qposadr[0]
    q[:, root : root + 3] = motion.pelvis_pos
    prev = None
    for t in range(T):
        qt = rot_to_quat(np.ascontiguousarray(motion.pelvis_rot[t]))
        if prev is not None and float(qt @ prev) < 0:
            qt = -qt
        q[t, root + 3 : root + 7] = prev = qt
    for j, name in enumerate(JOINT_NAMES):
        q[:, model.joint(name).qposadr[0]] = motion.angles[:, j]
    return q


@dataclass(frozen=True)
class WalkRun:
    """What :func:`write_walk` computed and wrote: the sampled ``motion``, its ``metrics``
    (:func:`~biped.kinematic.walk_metrics`), the inverse dynamics ``idyn`` (None if skipped), the
    ``summary`` dict written to summary.json, and ``notes`` (why an output is missing)."""

    motion: Motion
    metrics: WalkMetrics
    idyn: InverseDynamics | None
    summary: dict
    notes: dict


def walk_stages(
    *, dynamics: bool = True, figures: bool = True, replay: bool = True, video: bool = True
) -> list[str]:
    """The stages :func:`write_walk` runs, in order."""
    return (
        ["motion", "trajectory.csv"]
        + (["dynamics"] if dynamics else [])
        + (["figures"] if figures else [])
        + (["replay.html"] if replay else [])
        + (["video.mp4"] if video else [])
    )


def write_walk(
    plan,
    out: Path,
    *,
    gait: str,
    speed: float,
    rate: float,
    stair_rise: float | None = None,
    stair_run: float | None = None,
    dynamics: bool = True,
    figures: bool = True,
    replay: bool = True,
    video: bool = True,
    on_stage: Callable[[str], None] | None = None,
    model: str | Path | None = None,
    on_frame: Callable[..., None] | None = None,
) -> WalkRun:
    """Sample ``plan`` at ``rate`` [Hz] and write the walk's files into ``out`` (created):
    trajectory.csv, then (unless switched off) the inverse dynamics, figures/, replay.html,
    video.mp4, and summary.json last. ``on_stage(name)`` is called before each of
    :func:`walk_stages`; ``gait``, ``speed``, ``stair_rise`` / ``stair_run`` are recorded in the
    summary (the stairs' geometry for the upstairs and demo gaits). ``model``: the MJCF biped
    whose inertias the inverse dynamics use (None: W's shipped biped), recorded in the summary.
    ``on_frame(done, total)`` reports the video's frames when the renderer takes a progress
    callback. The inverse dynamics stage also writes inverse_dynamics.csv."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths: dict[str, Any] = {}
    notes: dict[str, str | None] = {}
    idyn = None
    for stage in walk_stages(dynamics=dynamics, figures=figures, replay=replay, video=video):
        if on_stage is not None:
            on_stage(stage)
        if stage == "motion":
            motion = plan.sample(rate)
            lm = motion.landmarks()
            metrics = walk_metrics(motion, lm)
        elif stage == "trajectory.csv":
            paths["trajectory"] = str(write_trajectory_csv(motion, lm, out / "trajectory.csv"))
        elif stage == "dynamics":
            idyn = inverse_dynamics(motion, load_biped(model) if model else None)
            paths["inverse_dynamics"] = str(write_inverse_dynamics_csv(idyn, out / "inverse_dynamics.csv"))
        elif stage == "figures":
            figs = [
                plot_joint_angles(motion, out / "figures" / "joint_angles.png"),
                plot_feet(motion, lm, out / "figures" / "feet.png"),
            ]
            if idyn is not None:
                figs.append(
                    plot_inverse_dynamics(idyn, plan.markers, out / "figures" / "inverse_dynamics.png")
                )
            paths["figures"] = [str(f) for f in figs]
        elif stage == "replay.html":
            info = {  # what the replay's panel shows: words and units, rounded to what is meaningful
                "gait": gait,
                "distance walked [m]": round(metrics.distance_m, 3),
                "height climbed [m]": round(metrics.height_climbed_m, 3),
                "largest stance-foot slip [mm]": round(1000 * metrics.max_stance_slip_m, 3),
                "smallest swing-foot clearance [mm]": round(1000 * metrics.min_swing_clearance_m, 1),
            }
            rep = build_replay(motion, f"biped walk --gait {gait} (Bediz's kinematic figure)", info)
            paths["replay"] = str(write_replay(rep, out / "replay.html"))
        elif stage == "video.mp4":
            fig_model = figure_model(motion)  # not `model`: that is the biped of the summary
            kwargs = {}
            if on_frame is not None and "progress" in inspect.signature(render_video).parameters:
                kwargs["progress"] = on_frame
            res = render_video(
                fig_model,
                motion.times,
                figure_qpos(fig_model, motion),
                out / "video.mp4",
                track_body="pelvis",
                distance=4.0,
                azimuth=-125.0,
                elevation=-15.0,
                fps=25,
                width=480,
                height=360,
                **kwargs,
            )
            if res.path is None:
                notes["video"] = res.reason
            else:
                paths["video"] = str(res.path)
    summary = {
        "gait": gait,
        "speed_m_s": speed,
        "rate_hz": rate,
        "somersault": plan.params.somersault,
        **metrics.as_dict(),
        "step_length_m": plan.dims.leg * math.sin(2 * math.radians(plan.params.alpha)),
        "markers": list(plan.markers),
    }
    if gait in ("upstairs", "demo"):
        rise, run_, a_up = stair_geometry(plan.dims, plan.params, stair_rise, stair_run)
        summary["stairs"] = {
            "rise_m": rise,
            "run_m": run_,
            "alpha_up_deg": math.degrees(a_up),
            "alpha_down_deg": plan.params.alpha_down,
        }
    if idyn is not None:
        summary["inverse_dynamics"] = idyn.summary()
        summary["inverse_dynamics_columns"] = {
            name: {"unit": unit, "meaning": meaning}
            for name, unit, meaning in inverse_dynamics_columns(idyn.joint_names)
        }
    summary["trajectory_columns"] = trajectory_column_units()
    summary["model"] = str(Path(model).resolve()) if model else "wendlandt"
    summary["outputs"] = paths
    summary["notes"] = notes
    write_json(out / "summary.json", summary)  # strict JSON: NaN / Infinity become null
    return WalkRun(motion, metrics, idyn, summary, notes)
