"""The files of a push run (W section 4): summary.json, trajectory.csv, scenario.toml, figures/,
video.mp4 and replay.html.

>>> import tempfile
>>> from biped.sim import Scenario, simulate
>>> from biped.outputs.push import write_outputs
>>> result = simulate(Scenario(duration_s=0.1))
>>> sorted(write_outputs(result, tempfile.mkdtemp(), figures=False, video=False, replay=False))
['scenario', 'summary', 'trajectory']
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from biped.sim.contact import SOLE_GEOMS
from biped.sim.push import PushResult
from biped.sim.scene import Scene, build_scene
from biped.viz.push_figures import plot_push
from biped.viz.replay import replay_from_mujoco, write_replay
from biped.viz.video import render_video

__all__ = [
    "summary_dict",
    "trajectory_columns",
    "write_outputs",
    "write_summary",
    "write_trajectory_csv",
]


def _fmt(x: float) -> str:
    return repr(float(x))


def trajectory_columns(joint_names) -> list[str]:
    cols = ["time", "com_x", "com_y", "com_z", "quat_w", "quat_x", "quat_y", "quat_z"]
    cols += [f"q_{n}" for n in joint_names] + [f"tau_{n}" for n in joint_names]
    cols += ["block_x", "block_y", "block_z", "left_contact", "right_contact"]
    cols += [f"{foot}_{part}_contact" for foot, part in SOLE_GEOMS]
    return cols


def write_trajectory_csv(result: PushResult, path: str | Path) -> Path:
    """``trajectory.csv``: one row per control period (columns: :func:`trajectory_columns`;
    angles [rad], torques [N m], positions [m]). Floats are written with ``repr`` (shortest
    round-trip form), so equal runs give byte-identical files."""
    path = Path(path)
    lines = [",".join(trajectory_columns(result.joint_names))]
    lc, rc = result.left_contact, result.right_contact
    for k in range(len(result.times)):
        vals = [_fmt(result.times[k]), *map(_fmt, result.com[k]), *map(_fmt, result.quat[k]),
                *map(_fmt, result.joint_angles[k]), *map(_fmt, result.torques[k]),
                *map(_fmt, result.block[k]), str(int(lc[k])), str(int(rc[k])),
                *(str(int(c)) for c in result.contacts[k])]
        lines.append(",".join(vals))
    tmp = path.with_suffix(".csv.part")
    tmp.write_text("\n".join(lines) + "\n")
    tmp.replace(path)
    return path


def _num(x):
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def summary_dict(result: PushResult) -> dict:
    """The content of ``summary.json``."""
    s = result.scenario
    return {
        "recovered": result.recovered,
        "fell": result.fell,
        "fall_time_s": _num(result.fall_time_s),
        "fall_reason": result.fall_reason,
        "interrupted": result.interrupted,
        "controller_error": result.controller_error,
        "diverged": result.diverged,
        "simulated_time_s": _num(result.times[-1]) if len(result.times) else 0.0,
        "final_com_error_m": _num(result.final_com_error_m),
        "final_orientation_error_deg": _num(result.final_orientation_error_deg),
        "final_com_m": result.com[-1].tolist() if len(result.com) else None,
        "final_quat": result.quat[-1].tolist() if len(result.quat) else None,
        "target_com_m": result.target_com.tolist(),
        "target_quat": result.target_quat.tolist(),
        "block_contact_time_s": _num(result.block_contact_time_s),
        "block_momentum_before_kg_m_s": result.block_momentum_before.tolist(),
        "block_momentum_after_kg_m_s": result.block_momentum_after.tolist(),
        "events": [e.to_dict() for e in result.events],
        "wall_time_s": result.wall_time_s,
        "realtime_factor": _num(result.realtime_factor),
        "control_rate_hz": s.control_rate_hz,
        "physics_timestep_s": s.physics_timestep_s,
        "scenario": s.to_dict(),
    }


def write_summary(result: PushResult, path: str | Path, extra: dict | None = None) -> Path:
    path = Path(path)
    data = summary_dict(result)
    if extra:
        data.update(extra)
    tmp = path.with_suffix(".json.part")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    tmp.replace(path)
    return path


def _markers(result: PushResult) -> list[dict]:
    out = []
    if result.block_contact_time_s is not None:
        out.append({"time_s": result.block_contact_time_s, "label": "block hits the body"})
    for e in result.events:
        out.append({"time_s": e.time_s, "label": f"{e.foot} {e.part} {e.kind.replace('_', ' ')}"})
    if result.fall_time_s is not None:
        out.append({"time_s": result.fall_time_s, "label": f"fall: {result.fall_reason}"})
    return out


def write_outputs(result: PushResult, out_dir: str | Path, *, figures: bool = True,
                  video: bool = True, replay: bool = True, scene: Scene | None = None,
                  log: Callable[[str], None] = print) -> dict:
    """Write every output of a run into ``out_dir`` (created if needed); returns ``{name: path}``.

    Order: ``trajectory.csv`` and ``summary.json`` first (atomic writes), then ``scenario.toml``,
    ``figures/``, ``video.mp4``, ``replay.html``. A failing optional output (no OpenGL, no
    ffmpeg...) is reported through ``log`` in one line and never removes what was written.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: dict[str, Any] = {"trajectory": write_trajectory_csv(result, out / "trajectory.csv"),
               "summary": write_summary(result, out / "summary.json")}
    (out / "scenario.toml").write_text(result.scenario.to_toml())
    written["scenario"] = out / "scenario.toml"
    if figures:
        try:
            written["figures"] = plot_push(result, out / "figures")
        except Exception as exc:  # noqa: BLE001 - an optional output must not lose the run
            log(f"figures: not written ({type(exc).__name__}: {exc})")
    if video or replay:
        scene = scene or build_scene(result.scenario)
    if video:
        assert scene is not None
        try:
            res = render_video(scene.model, result.times, result.qpos, out / "video.mp4",
                               fps=30, track_body="central_body", distance=3.0)
            if res.path:
                written["video"] = Path(res.path)
            else:
                log(f"video: not written ({res.reason})")
        except Exception as exc:  # noqa: BLE001 - an optional output must not lose the run
            log(f"video: not written ({type(exc).__name__}: {exc})")
    if replay:
        assert scene is not None
        try:
            info = {"recovered": result.recovered, "fell": result.fell,
                    "final COM error [m]": round(result.final_com_error_m, 4),
                    "final orientation error [deg]": round(result.final_orientation_error_deg, 3)}
            rp = replay_from_mujoco(scene.model, result.times, result.qpos,
                                    title="W section 4: push recovery", info=info,
                                    markers=_markers(result), follow="trunk")
            written["replay"] = write_replay(rp, out / "replay.html") or out / "replay.html"
        except Exception as exc:  # noqa: BLE001
            log(f"replay: not written ({type(exc).__name__}: {exc})")
    return written
