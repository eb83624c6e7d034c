"""An MP4 video of a motion from MuJoCo's offscreen renderer, with a camera that follows the biped.

MuJoCo picks its OpenGL backend from the environment variable ``MUJOCO_GL`` once, when ``mujoco``
is first imported (and PyOpenGL picks its platform from ``PYOPENGL_PLATFORM`` when it is first
imported). By the time a simulation asks for a video, ``mujoco`` has long been imported, so this
module does not touch the running process's GL state: it renders in a child Python process
(:mod:`biped.viz.video_render` in a fresh ``python``) started with ``MUJOCO_GL`` and
``PYOPENGL_PLATFORM`` set to a backend that works. The model travels as a MuJoCo binary
(``mj_saveModel``), the trajectory as a ``.npy`` file. A side benefit: a broken GL driver that
crashes cannot take the caller down; it becomes a ``VideoResult`` with ``path=None`` and the
reason.

Backends tried, in order: the ``MUJOCO_GL`` of the environment if set, then ``egl``, then
``osmesa`` (then ``glfw`` if a ``DISPLAY`` is set). On Debian, ``egl`` needs ``libegl1`` (with
Mesa's ``libegl-mesa0`` and ``libgl1-mesa-dri`` it renders on the CPU), ``osmesa`` needs
``libosmesa6``. :func:`gl_available` probes them once per process (about 1 s); the video itself
first tries the first candidate unprobed and probes only when that fails.
"""

from __future__ import annotations

import errno
import functools
import json
import math
import os
import pathlib
import subprocess
import sys
import tempfile
from dataclasses import dataclass

import numpy as np

from biped import files
from biped.errors import ModelError, ScenarioError, StateError, unknown_name
from biped.viz.timeline import frame_indices

__all__ = ["VideoResult", "frame_indices", "gl_available", "render_video"]

_PROBE_TIMEOUT_S = 60.0
_BACKENDS = ("egl", "osmesa")


@dataclass(frozen=True)
class VideoResult:
    """What :func:`render_video` produced.

    Attributes:
        path: the MP4 file, or ``None`` when no video could be made.
        reason: ``None`` on success, else one line saying why there is no video.
        backend: the ``MUJOCO_GL`` backend that rendered it (``"egl"``, ``"osmesa"``...).
        frames: number of frames written.
    """

    path: pathlib.Path | None
    reason: str | None
    backend: str | None = None
    frames: int = 0


_CHILD = (
    "import pathlib, sys; from biped.viz.video_render import _preload, _render_job; "
    "waiting = sys.argv[1] == '-'; _preload() if waiting else None; "
    "job = sys.stdin.readline().strip() if waiting else sys.argv[1]; "
    "sys.exit(_render_job(pathlib.Path(job)) if job else 0)"
)

#: Renderer processes started ahead by :func:`prewarm`, by backend: each has imported MuJoCo,
#: Pillow and ffmpeg and waits on its stdin for a job folder (end of input: it exits).
_WAITING: dict[str, tuple[subprocess.Popen, object]] = {}


def prewarm() -> None:
    """Start the renderer's child process now, so that a video rendered later in this process
    skips the child's start-up (importing MuJoCo, Pillow, ffmpeg: ~1 s of one core). ``biped
    push`` calls it before it simulates, while the second core idles. Nothing happens when
    rendering is disabled or a child already waits; an unused child exits with this process
    (its stdin closes)."""
    ok, backend = _first_try()
    if not ok or backend in _WAITING and _WAITING[backend][0].poll() is None:
        return
    err = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 - read and closed by _run_child
    proc = subprocess.Popen(
        [sys.executable, "-c", _CHILD, "-"],
        env=_child_env(backend),
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=err,
        text=True,
        bufsize=1,
    )
    _WAITING[backend] = (proc, err)


_PROBE = r"""
import mujoco
m = mujoco.MjModel.from_xml_string(
    '<mujoco><worldbody><light pos="0 0 3"/>'
    '<geom type="sphere" size=".1" rgba="1 0 0 1"/></worldbody></mujoco>')
d = mujoco.MjData(m)
mujoco.mj_forward(m, d)
r = mujoco.Renderer(m, 32, 32)
r.update_scene(d)
img = r.render()
r.close()
assert img.shape == (32, 32, 3) and img.std() > 0, "blank image"
print("ok")
"""


def _child_env(backend: str) -> dict:
    """Environment of a child process that renders with ``backend``, and imports this package."""
    env = dict(os.environ)
    env["MUJOCO_GL"] = backend
    if backend in ("egl", "osmesa"):
        env["PYOPENGL_PLATFORM"] = backend
    else:
        env.pop("PYOPENGL_PLATFORM", None)
    src = str(pathlib.Path(__file__).resolve().parents[2])  # the folder that holds biped/
    env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


def _last_line(text: str) -> str:
    lines = [ln.strip() for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1][:200] if lines else "no output"


def _candidates() -> list[str]:
    out = []
    env = os.environ.get("MUJOCO_GL", "").strip().lower()
    if env and env not in ("disable", "disabled", "off", "false", "0"):
        out.append(env)
    out += [b for b in _BACKENDS if b not in out]
    if os.environ.get("DISPLAY") and "glfw" not in out:
        out.append("glfw")
    return out


@functools.lru_cache(maxsize=1)
def gl_available() -> tuple[bool, str]:
    """Whether MuJoCo can render offscreen here: ``(True, backend)`` or ``(False, reason)``.

    Probes each candidate backend (``MUJOCO_GL`` if set, ``egl``, ``osmesa``) in a child process
    that renders a 32x32 image; the result is cached for the life of the process.
    """
    if os.environ.get("MUJOCO_GL", "").strip().lower() in ("disable", "disabled", "off", "false", "0"):
        return False, "no video: MUJOCO_GL disables rendering"
    errors = []
    for backend in _candidates():
        try:
            proc = subprocess.run(
                [sys.executable, "-c", _PROBE],
                env=_child_env(backend),
                capture_output=True,
                text=True,
                timeout=_PROBE_TIMEOUT_S,
                check=False,
            )
        except subprocess.TimeoutExpired:
            errors.append(f"{backend}: timed out")
            continue
        if proc.returncode == 0 and proc.stdout.strip().endswith("ok"):
            return True, backend
        errors.append(f"{backend}: {_last_line(proc.stderr)}")
    return False, (
        "no video: no offscreen OpenGL works here (install Debian's libegl1 or "
        "libosmesa6); " + "; ".join(errors)
    )


def _check_inputs(model, times, qpos, fps, width, height, track_body):
    import mujoco

    if not isinstance(model, mujoco.MjModel):
        raise ModelError(f"model must be a mujoco.MjModel, got {type(model).__name__}")
    times = np.asarray(times, dtype=float)
    qpos = np.asarray(qpos, dtype=float)
    if times.ndim != 1 or times.size < 1:
        raise StateError(f"times must have shape (T,) with T >= 1, got {times.shape}")
    if qpos.shape != (times.size, model.nq):
        raise StateError(f"qpos must have shape (T, nq) = ({times.size}, {model.nq}), got {qpos.shape}")
    if not (np.all(np.isfinite(times)) and np.all(np.isfinite(qpos))):
        raise StateError("times or qpos contains NaN or infinite entries")
    if np.any(np.diff(times) < 0):
        raise StateError("times must be non-decreasing")
    if not (isinstance(fps, (int, float)) and math.isfinite(fps) and 1 <= fps <= 240):
        raise ScenarioError(f"fps must be a number in [1, 240], got {fps!r}")
    for name, v in (("width", width), ("height", height)):
        if not (isinstance(v, (int, np.integer)) and 16 <= v <= 4096 and v % 2 == 0):
            raise ScenarioError(
                f"{name} must be an even number of pixels in [16, 4096] (H.264 needs even sizes), got {v!r}"
            )
    body_id = -1
    if track_body is not None:
        body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, str(track_body))
        if body_id < 0:
            names = [model.body(i).name for i in range(model.nbody) if model.body(i).name]
            raise ModelError(unknown_name("track_body", str(track_body), names))
    return times, qpos, body_id


def _check_camera(lookat, shadows, progress, title):
    if lookat is not None:
        lookat = np.asarray(lookat, dtype=float)
        if lookat.shape != (3,) or not np.all(np.isfinite(lookat)):
            raise ScenarioError(f"lookat must be a finite (x, y, z) point in m, got {lookat!r}")
    if shadows not in _SHADOWS:
        raise ScenarioError(f"shadows must be one of {', '.join(map(repr, _SHADOWS))}, got {shadows!r}")
    if progress is not None and not callable(progress):
        raise ScenarioError(f"progress must be a function progress(n, N) or None, got {progress!r}")
    if title is not None and not isinstance(title, str):
        raise ScenarioError(f"title must be a str or None, got {type(title).__name__}")
    return lookat


_SHADOWS = ("follow", "fixed", "off")


def render_video(
    model,
    times,
    qpos,
    path,
    *,
    fps=30,
    width=640,
    height=480,
    track_body="central_body",
    distance=None,
    azimuth=60.0,
    elevation=-12.0,
    lookat=None,
    slow_motion=None,
    events=(),
    title=None,
    overlay=True,
    shadows="follow",
    shadow_radius_m=3.0,
    msaa=None,
    reflection=True,
    progress=None,
    arrows=None,
    cancel=None,
) -> VideoResult:
    """Render the trajectory ``(times, qpos)`` of ``model`` to an H.264 MP4 file.

    Each frame runs ``mujoco.mj_forward`` on the sample shown (see
    :func:`biped.viz.timeline.frame_indices`) and draws it with ``mujoco.Renderer``, from a
    tracking camera (``mjCAMERA_TRACKING``) that follows the subtree centre of mass of
    ``track_body`` at a fixed distance and direction, or from a fixed camera aimed at ``lookat``.
    Rendering runs in a child process with its own ``MUJOCO_GL`` (see the module docstring).

    Args:
        model: ``mujoco.MjModel``; not modified (the child enlarges its own copy's offscreen
            buffer when ``width`` x ``height`` needs it).
        times: (T,) s, non-decreasing.
        qpos: (T, nq) generalized positions.
        path: the ``.mp4`` file to write; missing parent folders are created.
        fps: frames per second of the video.
        width, height: pixels, even.
        track_body: body the camera follows; ``None`` for a fixed camera on the model's centre.
        distance: camera distance, m; default 1.5 times the model's extent (``model.stat``).
        azimuth, elevation: camera direction, deg, MuJoCo's convention (the camera looks along
            ``(cos el cos az, cos el sin az, sin el)``; azimuth 60: from the biped's front left
            when it faces -x; elevation < 0 looks down).
        lookat: a fixed point (3,) [m] the camera aims at; overrides ``track_body``.
        slow_motion: ``None`` (real time) or :class:`~biped.viz.timeline.SlowMotion` windows
            played slower (see :mod:`biped.viz.timeline` for the frame count and duration).
        events: ``[{"time_s": s, "label": str}, ...]`` captioned as they happen.
        title: a line drawn at the top right of every frame.
        overlay: draw the caption (simulated time, slow-motion speed, events, title).
        shadows: ``"follow"`` (default): directional lights' shadows are computed in a box of
            ``shadow_radius_m`` around the point the camera looks at, which moves with it;
            ``"fixed"``: MuJoCo's own (a box of ``vis.map.shadowclip`` x ``stat.extent`` around
            the light's position: on a long walk, its far floor shows dark shadow-map streaks
            near the horizon); ``"off"``: no shadows. Spot lights are left as they are.
            ``"follow"`` also caps the shadow map at 2048 texels (enough for its small box).
        msaa: multisample anti-aliasing samples (0 = off); ``None`` keeps the model's
            ``vis.quality.offsamples`` (MuJoCo's default 4). With Mesa's software renderer 4x
            MSAA costs about 2.5x a frame (docs/viz.md).
        reflection: draw reflective floors' reflections (another pass of the scene per frame).
        progress: ``progress(n, N)`` is called with ``n = 0`` before the first frame and after
            each of the ``N`` frames is written.
        cancel: a ``threading.Event``; when it is set, the child renderer is killed and the
            call returns without a video (for a caller that renders in a background thread).

    Returns:
        :class:`VideoResult`; ``path=None`` and a one-line ``reason`` if no OpenGL backend works
        or the renderer fails. Bad arguments raise (``StateError``, ``ModelError``,
        ``ScenarioError``) before anything is rendered.
    """
    from biped.viz.timeline import overlay_text, playback_times

    times, qpos, body_id = _check_inputs(model, times, qpos, fps, width, height, track_body)
    lookat = _check_camera(lookat, shadows, progress, title)
    if not (isinstance(shadow_radius_m, (int, float)) and shadow_radius_m > 0):
        raise ScenarioError(f"shadow_radius_m must be a positive number of m, got {shadow_radius_m!r}")
    if msaa is not None and not (isinstance(msaa, (int, np.integer)) and 0 <= msaa <= 16):
        raise ScenarioError(f"msaa must be None or a number of samples in [0, 16] (0 = off), got {msaa!r}")
    ft = playback_times(times[0], times[-1], fps, slow_motion)  # validates slow_motion
    captions = overlay_text(ft.tolist(), fps, events=events, slow_motion=slow_motion, t1=times[-1])
    path = pathlib.Path(path)
    ok, backend = _first_try()
    if not ok:
        return VideoResult(None, backend)
    probed = gl_available.cache_info().currsize > 0

    path.parent.mkdir(parents=True, exist_ok=True)
    idx = frame_indices(times, fps, slow_motion)
    fd, dest = files.temp_path(files.check_no_link(path))  # ffmpeg writes here, then it moves
    os.close(fd)
    try:
        return _render_to(model, qpos, idx, arrows, path, dest, (backend, probed, cancel), progress, {
            "fps": float(fps),
            "width": int(width),
            "height": int(height),
            "body_id": -1 if lookat is not None else int(body_id),
            "lookat": None if lookat is None else lookat.tolist(),
            "distance": distance,
            "azimuth": float(azimuth),
            "elevation": float(elevation),
            "shadows": shadows,
            "shadow_radius": float(shadow_radius_m),
            "msaa": None if msaa is None else int(msaa),
            "reflection": bool(reflection),
            "captions": captions if overlay else None,
            "title": title or "",
            "font": _font_file(),
        })  # fmt: skip
    finally:
        dest.unlink(missing_ok=True)


def _render_to(model, qpos, idx, arrows, path, dest, how, progress, cfg) -> VideoResult:
    """Render into the temporary file ``dest`` in a child process, then move it to ``path``.
    ``arrows``: None, or (T, 2, 3) from/to of one arrow a sample (NaN: none), e.g. a push.
    ``how``: (the GL backend, whether it was probed, the cancel event or None)."""
    import mujoco

    backend, probed, cancel = how

    with tempfile.TemporaryDirectory(prefix="biped-video-") as tmp_name:
        tmp = pathlib.Path(tmp_name)
        mujoco.mj_saveModel(model, str(tmp / "model.mjb"), None)
        np.save(tmp / "qpos.npy", qpos[idx])
        if arrows is not None:
            np.save(tmp / "arrows.npy", np.asarray(arrows, dtype=float)[idx])
        extent = float(model.stat.extent) if model.stat.extent > 0 else 1.0
        distance = cfg["distance"]
        cfg = {
            **cfg,
            "out": str(dest.resolve()),
            "distance": float(distance) if distance is not None else 1.5 * extent,
        }
        (tmp / "job.json").write_text(json.dumps(cfg))
        try:
            code, err = _run_child(tmp, backend, len(idx), progress, cancel)
            if code != 0 and not probed and not (cancel is not None and cancel.is_set()):
                # the unprobed first choice failed: probe every backend, as before, and retry
                ok, found = gl_available()
                if not ok:
                    return VideoResult(None, found)
                if found != backend:
                    backend = found
                    code, err = _run_child(tmp, backend, len(idx), progress, cancel)
        except subprocess.TimeoutExpired:
            return VideoResult(None, f"no video: rendering with MUJOCO_GL={backend} timed out", backend)
    if cancel is not None and cancel.is_set():
        return VideoResult(None, "no video: cancelled", backend)
    if code != 0 and any(w in err for w in ("No space left on device", "Disk quota exceeded")):
        raise files.WriteError(errno.ENOSPC, "No space left on device", str(path))  # not a note: exit 1
    if code != 0 or not dest.is_file() or dest.stat().st_size == 0:
        return VideoResult(
            None, f"no video: rendering with MUJOCO_GL={backend} failed: {_last_line(err)}", backend
        )
    files.place(dest, path)
    return VideoResult(path.resolve(), None, backend, len(idx))


def _first_try() -> tuple[bool, str]:
    """The backend to render with first: :func:`gl_available`'s answer when it was probed in this
    process (or rendering is disabled), else the first candidate, unprobed: the probe, a child
    process of its own, costs about 1 s of CPU, and the renderer's failure falls back to it."""
    disabled = os.environ.get("MUJOCO_GL", "").strip().lower() in ("disable", "disabled", "off", "false", "0")
    if disabled or gl_available.cache_info().currsize:
        return gl_available()
    return True, _candidates()[0]


def _font_file() -> str | None:
    """Matplotlib's DejaVu Sans (always installed with matplotlib), for the caption."""
    try:
        import matplotlib

        f = pathlib.Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"
        return str(f) if f.is_file() else None
    except ImportError:  # pragma: no cover
        return None


def _run_child(tmp: pathlib.Path, backend: str, n_frames: int, progress, cancel=None) -> tuple[int, str]:
    """Run :func:`biped.viz.video_render._render_job` in a child process; relay its per-frame
    ``"frame n"`` lines to ``progress(n, N)``; kill it when the event ``cancel`` is set. Returns
    (exit code, stderr). Raises ``subprocess.TimeoutExpired``."""
    import threading

    timeout = 120 + 2.0 * n_frames
    waiting = _WAITING.pop(backend, None)
    if waiting is not None and waiting[0].poll() is None:  # started ahead by prewarm()
        proc, err = waiting
        assert proc.stdin is not None  # stdin=PIPE
        proc.stdin.write(f"{tmp}\n")
        proc.stdin.close()
    else:
        err = open(tmp / "stderr.txt", "w+")  # noqa: SIM115 - closed below
        proc = subprocess.Popen(
            [sys.executable, "-c", _CHILD, str(tmp)],
            env=_child_env(backend),
            stdout=subprocess.PIPE,
            stderr=err,
            text=True,
            bufsize=1,
        )
    with err:  # type: ignore[attr-defined]
        killed = threading.Event()

        def _kill():
            killed.set()
            proc.kill()

        timer = threading.Timer(timeout, _kill)
        timer.start()
        done = threading.Event()
        if cancel is not None:

            def _watch():
                while not done.is_set():
                    if cancel.wait(0.2):
                        proc.kill()
                        return

            threading.Thread(target=_watch, daemon=True).start()
        try:
            if progress is not None:
                progress(0, n_frames)
            assert proc.stdout is not None  # stdout=PIPE
            for line in proc.stdout:
                parts = line.split()
                if progress is not None and len(parts) == 2 and parts[0] == "frame":
                    progress(int(parts[1]), n_frames)
            code = proc.wait()
        except BaseException:
            proc.kill()
            proc.wait()
            raise
        finally:
            done.set()
            timer.cancel()
            if proc.stdout is not None:
                proc.stdout.close()
        err.seek(0)  # type: ignore[attr-defined]
        text = err.read()  # type: ignore[attr-defined]
    if killed.is_set():
        raise subprocess.TimeoutExpired(_CHILD, timeout)
    return code, text
