"""The files of a push run (W section 4): summary.json, trajectory.csv (:mod:`.push_trajectory`,
whose names this module still offers), scenario.toml, figures/, video.mp4 and replay.html.

>>> import tempfile
>>> from biped.sim import Scenario, simulate
>>> from biped.outputs.push import write_outputs
>>> result = simulate(Scenario(duration_s=0.1))
>>> sorted(write_outputs(result, tempfile.mkdtemp(), figures=False, video=False, replay=False))
['columns', 'scenario', 'summary', 'trajectory']
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from biped import files
from biped.outputs._json import write_json
from biped.outputs.push_trajectory import column_dictionary, trajectory_columns, write_trajectory_csv
from biped.sim import perturbations
from biped.sim.measure import FEET, RowMeasurements, block_separation, foot_drift, measure_rows
from biped.sim.push import PushResult, orientation_error_deg
from biped.sim.response import measure_response
from biped.sim.scene import Scene, build_scene, tilt_quat
from biped.viz.footprints import with_footprints
from biped.viz.push_figures import plot_push
from biped.viz.push_video import render_push_video
from biped.viz.replay import write_replay
from biped.viz.replay_mujoco import replay_from_mujoco

__all__ = [
    "column_dictionary",
    "judged_set_point",
    "summary_dict",
    "trajectory_columns",
    "write_outputs",
    "write_summary",
    "write_trajectory_csv",
]


def _num(x):
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def judged_set_point(result: PushResult) -> dict:
    """The set point a run is judged against and the verdict: each controller against its own.

    W's workspace controller drives the central body to the scenario's set point
    (``target_com_m``, ``target_tilt_deg`` about ``target_axis``). The joint-PD baseline holds
    the initial joint angles, so it never tries to reach that set point: it is judged against the
    initial state it holds (COM at ``initial_com_m``, ``initial_tilt_deg`` about -y, the sweep's
    ``--task hold`` set point), with the same tolerances. ``recovered``: the run is complete, did
    not fall and ends within ``recovery_com_tol_m`` and ``recovery_orientation_tol_deg``."""
    s = result.scenario
    if s.controller != "joint-pd":
        return {
            "controller": s.controller,
            "set_point": "the scenario's (W's) set point",
            "com_m": result.target_com.tolist(),
            "quat": result.target_quat.tolist(),
            "final_com_error_m": _num(result.final_com_error_m),
            "final_orientation_error_deg": _num(result.final_orientation_error_deg),
            "recovered": bool(result.recovered),
        }
    com = np.array(s.initial_com_m, dtype=float)
    quat = tilt_quat("-y", s.initial_tilt_deg)
    n = len(result.times)
    com_err = float(np.linalg.norm(result.com[-1] - com)) if n else float("nan")
    ori_err = orientation_error_deg(result.quat[-1], quat) if n else float("nan")
    complete = (
        n == s.control_steps + 1
        and not result.interrupted
        and not result.fell
        and result.controller_error is None
        and result.diverged is None
    )
    ok = bool(complete and com_err < s.recovery_com_tol_m and ori_err < s.recovery_orientation_tol_deg)
    return {
        "controller": s.controller,
        "set_point": "its own: the initial state it holds (initial_com_m, initial_tilt_deg "
        "about -y), not W's set point",
        "com_m": com.tolist(),
        "quat": quat.tolist(),
        "final_com_error_m": _num(com_err),
        "final_orientation_error_deg": _num(ori_err),
        "recovered": ok,
    }


def summary_dict(result: PushResult, rows: RowMeasurements | None = None) -> dict:
    """The content of ``summary.json`` (``rows``: the run's :func:`~biped.sim.measure.measure_rows`,
    for the block's momentum when it leaves the body; without it that entry is null)."""
    s = result.scenario
    judged = judged_set_point(result)
    sep = block_separation(result, rows) if rows is not None else None
    p_end = (
        s.block_mass_kg * result.block_velocity[-1]
        if result.block_velocity is not None and len(result.times)
        else result.block_momentum_after
    )
    return {
        "recovered": judged["recovered"],
        "judged_against": judged,
        "scenario_set_point_reached": bool(result.recovered),
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
        "block_leaves_body_time_s": _num(sep.time_s) if sep is not None else None,
        "block_momentum_before_kg_m_s": result.block_momentum_before.tolist(),
        "block_momentum_after_kg_m_s": sep.momentum.tolist() if sep is not None else None,
        "block_momentum_end_kg_m_s": np.asarray(p_end).tolist(),
        "feet_drift_m": foot_drift(result),
        "events": [e.to_dict() for e in result.events],
        "steps": [dict(st) for st in result.extra.get("steps", ())],
        "wall_time_s": result.wall_time_s,
        "realtime_factor": _num(result.realtime_factor),
        "control_rate_hz": s.control_rate_hz,
        "physics_timestep_s": s.physics_timestep_s,
        "trajectory_columns": "columns.json",
        "scenario": s.to_dict(),
        # only with early_stop = true (biped.sim.early_stop), so W's default summary is unchanged
        **({"stop_reason": result.stop_reason} if result.stop_reason else {}),
    }


def response_entries(scene: Scene, result: PushResult, rows: RowMeasurements) -> dict:
    """``summary.json``'s ``perturbation`` (the paradigm, its size and what it measured of itself)
    and ``response`` (:func:`biped.sim.response.measure_response`: strategy, excursions, margin of
    stability, peak torques, time to rest, steps) entries; docs/perturbations.md."""
    size = perturbations.of(result.scenario).size(rows.biped_mass_kg)
    info = size.entry()
    info.update(result.extra.get("perturbation", {}))
    return {"perturbation": info, "response": measure_response(scene, result, rows).to_dict()}


def response_title(result: PushResult) -> str:
    """The response figure's title: the paradigm and its size."""
    size = perturbations.of(result.scenario).size(1.0)
    return f"{size.paradigm}: {size.magnitude:.4g} {size.unit} toward {size.direction_deg:.0f} deg"


def write_summary(
    result: PushResult, path: str | Path, extra: dict | None = None, *, rows: RowMeasurements | None = None
) -> Path:
    """``summary.json`` (:func:`summary_dict`, plus ``extra``): strict JSON, atomic."""
    data = summary_dict(result, rows)
    if extra:
        data.update(extra)
    return write_json(path, data)


def _markers(result: PushResult) -> list[dict]:
    end = result.times[-1] if len(result.times) else 0.0
    out = [{"time_s": t, "label": lab} for t, lab in perturbations.of(result.scenario).markers() if t <= end]
    if result.block_contact_time_s is not None:
        out.append({"time_s": result.block_contact_time_s, "label": "block hits the body"})
    for e in result.events:
        out.append({"time_s": e.time_s, "label": f"{e.foot} {e.part} {e.kind.replace('_', ' ')}"})
    for st in result.extra.get("steps", ()):
        out.append({"time_s": st["start_s"], "label": f"step: {st['foot']} foot swings"})
        if st.get("touch_down_s") is not None:
            p = st["position_m"]
            out.append(
                {
                    "time_s": st["touch_down_s"],
                    "label": f"step: {st['foot']} foot lands at ({p[0]:.2f}, {p[1]:.2f}) m",
                }
            )
    if result.fall_time_s is not None:
        out.append({"time_s": result.fall_time_s, "label": f"fall: {result.fall_reason}"})
    return out


def _footprints(scene: Scene, result: PushResult) -> list[dict]:
    """One footprint per landed step (stepping runs): the sole rectangle (MJCF sole boxes) at the
    recorded touchdown position, turned by the foot's yaw in the frame nearest the touchdown."""
    steps = [s for s in result.extra.get("steps", ()) if s.get("touch_down_s") is not None]
    if not steps or not len(result.times):
        return []
    import mujoco

    from biped.model import sole_rectangles

    m = scene.model
    soles = dict(zip(FEET, sole_rectangles(m, ("left_foot", "right_foot")), strict=True))
    d = mujoco.MjData(m)
    out = []
    for k, st in enumerate(steps):
        i = int(np.argmin(np.abs(result.times - st["touch_down_s"])))
        d.qpos[:] = result.qpos[i]
        mujoco.mj_kinematics(m, d)
        R = d.xmat[m.body(f"{st['foot']}_foot").id].reshape(3, 3)
        sole = soles[st["foot"]]
        out.append(
            {
                "time_s": st["touch_down_s"],
                "centre_m": st["position_m"][:2],
                "yaw_rad": math.atan2(R[1, 0], R[0, 0]),
                "half_length_m": sole.half_length,
                "half_width_m": sole.half_width,
                "name": f"footprint {k + 1} ({st['foot']})",
            }
        )
    return out


class _BackgroundVideo:
    """:func:`render_push_video` of the run (slow motion around the hit) in a thread, so that the
    child process that renders it runs while this process writes the figures and the replay
    (two cores: the video no longer adds its time to theirs). ``join(on_frame)`` waits for it,
    reporting ``on_frame(done, total)`` as frames arrive, and returns the ``VideoResult`` (or
    raises what the renderer raised); ``cancel()`` kills the renderer (Ctrl-C)."""

    def __init__(self, scene: Scene, result: PushResult, path: Path):
        import threading

        self._progress: tuple[int, int] | None = None
        self._result: Any = None
        self._error: BaseException | None = None
        self._cancel = threading.Event()
        self._changed = threading.Event()

        def progress(n: int, total: int) -> None:
            self._progress = (n, total)
            self._changed.set()

        def run() -> None:
            try:
                arrows = perturbations.of(result.scenario).arrows(scene, result)  # a push, the tether
                self._result = render_push_video(
                    scene.model, result, path, progress=progress, cancel=self._cancel, arrows=arrows
                )
            except BaseException as exc:  # noqa: BLE001 - handed to join()
                self._error = exc
            finally:
                self._changed.set()

        self._thread = threading.Thread(target=run, name="biped-video", daemon=True)
        self._thread.start()

    def cancel(self) -> None:
        self._cancel.set()
        self._thread.join(timeout=5)

    def join(self, on_frame: Callable[..., None]):
        said = None
        while True:
            alive = self._thread.is_alive()
            self._changed.wait(0.25)
            self._changed.clear()
            if self._progress is not None and self._progress != said:
                said = self._progress
                on_frame(*said)
            if not alive:
                break
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._result


def _frame_log(log: Callable[[str], None], step: float = 0.25):
    """``progress(n, N)`` of the video renderer that says ``rendering video n/N frames``
    through ``log`` at the start and at every ``step`` of the way."""
    said = [-1.0]

    def progress(n: int, total: int) -> None:
        frac = n / total if total else 1.0
        if n == 0 or n == total or frac >= said[0] + step:
            said[0] = frac
            log(f"video.mp4: rendering {n}/{total} frames")

    return progress


#: Errors an optional output does not swallow: a write that failed (full disk: exit 1, the
#: previous file kept) or a link where a file would go (refused).
_REFUSED = (files.WriteError, files.LinkError)


def write_outputs(
    result: PushResult,
    out_dir: str | Path,
    *,
    figures: bool = True,
    video: bool = True,
    replay: bool = True,
    scene: Scene | None = None,
    log: Callable[[str], None] = print,
    on_stage: Callable[[str], None] | None = None,
    on_frame: Callable[..., None] | None = None,
    on_figure: Callable[..., None] | None = None,
    figure_formats: tuple[str, ...] = ("png",),
) -> dict:
    """Write every output of a run into ``out_dir`` (created if needed); returns ``{name: path}``.

    ``video.mp4`` is rendered by a child process that starts first and runs while this one writes,
    in order, ``trajectory.csv`` and ``summary.json`` (atomic writes), ``scenario.toml``,
    ``figures/`` (PNG; ``figure_formats=("png", "svg")`` adds SVG) and ``replay.html``; then it
    waits for the video. A failing optional output (no OpenGL, no ffmpeg...) is reported through
    ``log`` in one line and never removes what was written; a write error (full disk) or a link
    where a file would go raises (:mod:`biped.files`). ``on_stage(name)`` is called before each
    product ("trajectory.csv", "figures", "replay.html", then "video.mp4" when it waits for
    the video); ``on_figure(done, total)`` after each figure; ``on_frame(done, total)`` with the
    video's frames (those rendered meanwhile at once, then as they come).
    """

    def stage(name: str) -> None:
        if on_stage is not None:
            on_stage(name)

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    scene = scene or build_scene(result.scenario)
    bg: _BackgroundVideo | None = None
    if video:  # rendered by a child process while this one writes the rest
        bg = _BackgroundVideo(scene, result, out / "video.mp4")
    try:
        written = _write_rest(result, out, scene, figures, replay, figure_formats, log, stage, on_figure)
        if bg is not None:
            stage("video.mp4")
            try:
                res = bg.join(on_frame if on_frame is not None else _frame_log(log))
                if res.path:
                    written["video"] = Path(res.path)
                else:
                    log(f"video: not written ({res.reason})")
            except _REFUSED:
                raise
            except Exception as exc:  # noqa: BLE001 - an optional output must not lose the run
                log(f"video: not written ({type(exc).__name__}: {exc})")
            bg = None
    finally:
        if bg is not None:  # interrupted while writing the rest: stop the renderer
            bg.cancel()
    return written


def _write_rest(result, out, scene, figures, replay, figure_formats, log, stage, on_figure) -> dict:
    """Everything but the video, in order (:func:`write_outputs`)."""
    stage("trajectory.csv")
    rows = measure_rows(scene, result)
    written: dict[str, Any] = {
        "trajectory": write_trajectory_csv(result, out / "trajectory.csv", rows=rows),
        "columns": write_json(out / "columns.json", column_dictionary(result.joint_names)),
        "summary": write_summary(
            result, out / "summary.json", response_entries(scene, result, rows), rows=rows
        ),
    }
    files.write_text(out / "scenario.toml", result.scenario.to_toml())
    written["scenario"] = out / "scenario.toml"
    if figures:
        stage("figures")
        try:
            written["figures"] = plot_push(
                result, out / "figures", formats=figure_formats, progress=on_figure
            )
            if result.scenario.perturbation != "block":  # the response against the base of support
                from biped.sim.response import traces
                from biped.viz.response_figure import plot_response

                size = response_title(result)
                written["figures"] += plot_response(
                    traces(scene, result, rows), out / "figures", title=size, formats=figure_formats
                )
        except _REFUSED:
            raise
        except Exception as exc:  # noqa: BLE001 - an optional output must not lose the run
            log(f"figures: not written ({type(exc).__name__}: {exc})")
    if replay:
        stage("replay.html")
        try:
            info = {
                "recovered": judged_set_point(result)["recovered"],
                "fell": result.fell,
                "final COM error [mm]": round(1000 * result.final_com_error_m, 3),  # as the terminal says
                "final orientation error [deg]": round(result.final_orientation_error_deg, 3),
            }
            rp = replay_from_mujoco(
                scene.model,
                result.times,
                result.qpos,
                title="W section 4: push recovery"
                if result.scenario.perturbation == "block"
                else f"perturbation: {result.scenario.perturbation}",
                info=info,
                markers=_markers(result),
                follow="trunk",
                arrow=perturbations.of(result.scenario).arrows(scene, result),  # as the video's
            )
            rp = with_footprints(rp, _footprints(scene, result))
            written["replay"] = write_replay(rp, out / "replay.html") or out / "replay.html"
        except _REFUSED:
            raise
        except Exception as exc:  # noqa: BLE001
            log(f"replay: not written ({type(exc).__name__}: {exc})")
    return written
