"""The push run's video: the hit in slow motion, seen from where the block and the feet show.

>>> from biped.viz.push_video import render_push_video
>>> render_push_video(scene.model, result, "runs/mine/video.mp4",
...                   progress=lambda n, N: print(f"rendering video {n}/{N}"))  # doctest: +SKIP

Defaults (each a keyword argument of :func:`render_push_video`):

- **Slow motion** (:func:`push_slow_motion`): 0.25x real time from 0.05 s before the block hits
  until 0.1 s after the last foot event (a heel or toe leaving or reaching the floor) in the
  second after the hit, at least until 0.3 s after the hit; real time elsewhere. On W's run
  (hit at 0.082 s, last heel down at 0.294 s) that is [0.032, 0.394] s: 0.36 s of the run take
  1.45 s of video, and the 3 s run makes a 4.1 s video.
- **Camera** (:func:`push_camera`): fixed, from the biped's right and slightly behind it
  (azimuth -110 deg, elevation -10 deg; the biped faces -x and the block comes from +x, so the
  block is between the camera and the trunk), aimed at the middle of everything at the moment of
  the hit (the biped, the block there and where it was thrown from), and as close as keeps all
  of it inside the central 80 % of the frame.
- **Caption**: simulated time, "0.25x slow motion" inside the window, and the events as they
  happen ("block hits", "left heel up", "right heel down", "fall"), each on screen for 1.5 s of
  video.
- **Cheap to render** (software OpenGL renders a frame of it in ~15-30 ms on one core, so the
  3 s run's 99 frames take ~3 s, in a child process while ``biped push`` writes its figures):
  854 x 480 pixels, 24 frames per second, no shadows, no floor reflection, no multisample
  anti-aliasing. Before: 1280 x 720, 30 frames per second, shadows and 4x anti-aliasing, 18-38 s
  (``python benchmarks/outputs.py --video-settings``; docs/viz.md has the measurements). Every
  one of these is a keyword: ``width=1280, height=720, fps=30, shadows="follow", msaa=4,
  reflection=True`` renders the old video.
"""

from __future__ import annotations

import math

import numpy as np

from biped.errors import ScenarioError, StateError
from biped.viz.timeline import SlowMotion
from biped.viz.video import VideoResult, render_video

__all__ = ["event_captions", "push_camera", "push_slow_motion", "render_push_video"]

#: Default playback speed inside the slow-motion window.
SLOW_SPEED = 0.25
#: The window starts this long before the block hits [s].
BEFORE_HIT_S = 0.05
#: ... and ends this long after the last foot event of the second after the hit [s] ...
AFTER_LANDING_S = 0.10
#: ... but not before this long after the hit [s].
MIN_AFTER_HIT_S = 0.30


def event_captions(result) -> list[dict]:
    """The run's events as ``{"time_s", "label"}`` in time order: ``"block hits"``,
    ``"left heel up"`` (lift-off), ``"right toe down"`` (touch-down), ``"fall (reason)"``."""
    out = []
    if result.block_contact_time_s is not None:
        out.append({"time_s": float(result.block_contact_time_s), "label": "block hits"})
    for e in result.events:
        word = "up" if e.kind == "lift_off" else "down"
        out.append({"time_s": float(e.time_s), "label": f"{e.foot} {e.part} {word}"})
    if getattr(result, "fall_time_s", None) is not None:
        reason = getattr(result, "fall_reason", None)
        out.append({"time_s": float(result.fall_time_s), "label": f"fall ({reason})" if reason else "fall"})
    return sorted(out, key=lambda e: e["time_s"])


def push_slow_motion(
    result,
    *,
    speed: float = SLOW_SPEED,
    before_s: float = BEFORE_HIT_S,
    after_s: float = AFTER_LANDING_S,
    min_after_hit_s: float = MIN_AFTER_HIT_S,
) -> SlowMotion | None:
    """The slow-motion window around the hit (module docstring), or ``None`` if the block never
    touched the biped. Foot events are those of ``result.events`` in ``(hit, hit + 1 s]``."""
    hit = result.block_contact_time_s
    if hit is None:
        return None
    for name, v in (("before_s", before_s), ("after_s", after_s), ("min_after_hit_s", min_after_hit_s)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
            raise ScenarioError(f"{name} must be a finite number of s >= 0, got {v!r}")
    hit = float(hit)
    later = [float(e.time_s) for e in result.events if hit < e.time_s <= hit + 1.0]
    end = max([hit + min_after_hit_s] + [t + after_s for t in later])
    return SlowMotion(max(hit - before_s, float(result.times[0])), end, speed)


def _points_at(model, qpos, geoms) -> np.ndarray:
    """World corners of the bounding boxes of ``geoms`` at ``qpos`` (8 per geom), m."""
    import mujoco

    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    pts = []
    for g in geoms:
        half = model.geom_aabb[g, 3:]
        local = model.geom_aabb[g, :3] + signs * half
        pts.append(data.geom_xpos[g] + local @ data.geom_xmat[g].reshape(3, 3).T)
    return np.concatenate(pts)


def _project(points, lookat, distance, azimuth, elevation, fovy_deg, aspect) -> np.ndarray:
    """(n, 2) image coordinates in [-1, 1] (x right, y up) of a pinhole camera looking along
    ``(cos el cos az, cos el sin az, sin el)`` from ``distance`` before ``lookat``."""
    az, el = math.radians(azimuth), math.radians(elevation)
    fwd = _fwd(azimuth, elevation)
    up = np.array([-math.sin(el) * math.cos(az), -math.sin(el) * math.sin(az), math.cos(el)])
    right = np.cross(fwd, up)
    rel = np.asarray(points) - (np.asarray(lookat) - distance * fwd)
    z = rel @ fwd
    t = math.tan(math.radians(fovy_deg) / 2)
    return np.column_stack([(rel @ right) / (z * t * aspect), (rel @ up) / (z * t)])


def push_camera(
    model,
    result,
    *,
    azimuth: float = -110.0,
    elevation: float = -10.0,
    aspect: float = 16 / 9,
    fill: float = 0.8,
) -> dict:
    """``render_video`` camera keywords (``lookat``, ``distance``, ``azimuth``, ``elevation``) of
    a fixed camera that sees every geom but the floor at the moment of the hit (the first sample
    if there is none) and the block where it was thrown from, inside the central ``fill`` of the
    frame (``aspect`` = width / height)."""
    import mujoco

    times = np.asarray(result.times, dtype=float)
    hit = result.block_contact_time_s
    k = 0 if hit is None else int(np.clip(np.searchsorted(times, hit + 1e-12) - 1, 0, times.size - 1))
    planes = np.asarray(model.geom_type) == int(mujoco.mjtGeom.mjGEOM_PLANE)
    # not the floor, nor what is not drawn (a parked block), nor a moving floor (the platform)
    platform = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "platform")
    solids = [g for g in range(model.ngeom) if not planes[g] and model.geom_rgba[g, 3] > 0 and g != platform]
    block = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "block")
    pts = _points_at(model, result.qpos[k], solids)
    if block >= 0 and model.geom_rgba[block, 3] > 0:
        pts = np.concatenate([pts, _points_at(model, result.qpos[0], [block])])
    lookat = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    fovy = float(model.vis.global_.fovy)
    fwd = _fwd(azimuth, elevation)
    lo, hi = 0.1, 100.0  # bisection on the distance that just fits
    for _ in range(60):
        d = 0.5 * (lo + hi)
        uv = _project(pts, lookat, d, azimuth, elevation, fovy, aspect)
        in_front = np.all((pts - lookat) @ fwd + d > 0.05)
        if in_front and np.max(np.abs(uv)) <= fill:
            hi = d
        else:
            lo = d
    return {"lookat": lookat, "distance": hi, "azimuth": float(azimuth), "elevation": float(elevation)}


def _fwd(azimuth, elevation) -> np.ndarray:
    az, el = math.radians(azimuth), math.radians(elevation)
    return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def _paradigm_title(s) -> str:
    """The video's title for a paradigm other than W's block (docs/perturbations.md)."""
    if s.perturbation == "force":
        f = float(np.linalg.norm(s.force_n))
        return f"force pulse: {f:.0f} N for {s.force_duration_s:g} s ({s.force_shape})"
    if s.perturbation == "platform":
        d = float(np.hypot(*s.platform_displacement_m))
        return f"platform translation: {d * 100:.3g} cm in {s.platform_duration_s:g} s"
    if s.perturbation == "pull":
        d = float(np.hypot(*s.pull_displacement_m))
        return f"waist pull: {d * 100:.3g} cm at {s.pull_velocity_m_s:g} m/s"
    return f"lean and release: {s.release_lean_deg:g} deg, released at {s.release_time_s:g} s"


def render_push_video(
    model,
    result,
    path,
    *,
    fps: float = 24,
    width: int = 854,
    height: int = 480,
    speed: float = SLOW_SPEED,
    before_hit_s: float = BEFORE_HIT_S,
    after_landing_s: float = AFTER_LANDING_S,
    azimuth: float = -110.0,
    elevation: float = -10.0,
    title: str | None = None,
    progress=None,
    shadows: str = "off",
    msaa: int | None = 0,
    reflection: bool = False,
    **render_kw,
) -> VideoResult:
    """Render a push run (a :class:`biped.sim.push.PushResult`, or anything with its ``times``,
    ``qpos``, ``events``, ``block_contact_time_s``, ``fall_time_s``) to an MP4 with the
    defaults of the module docstring. ``model`` is the scene's ``MjModel`` (biped + block +
    floor, the layout of ``result.qpos``); ``speed = 1`` turns slow motion off. ``progress(n, N)``,
    ``shadows``, ``msaa``, ``reflection`` and the other keywords (``overlay``, ``lookat``,
    ``cancel``...) go to :func:`biped.viz.video.render_video`."""
    times = np.asarray(result.times, dtype=float)
    if times.size < 1:
        raise StateError("the run has no samples to render")
    slow = None
    if speed != 1:
        slow = push_slow_motion(result, speed=speed, before_s=before_hit_s, after_s=after_landing_s)
    if title is None:
        s = getattr(result, "scenario", None)
        if s is not None and getattr(s, "perturbation", "block") != "block":
            title = _paradigm_title(s)
        elif s is not None and hasattr(s, "block_mass_kg"):
            v = float(np.linalg.norm(s.block_velocity_m_s))
            title = f"W section 4: a {s.block_mass_kg:g} kg block thrown at {v:.2f} m/s"
    cam = push_camera(model, result, azimuth=azimuth, elevation=elevation, aspect=width / height)
    for key in ("lookat", "distance"):
        if key in render_kw:
            cam[key] = render_kw.pop(key)
    return render_video(
        model,
        times,
        result.qpos,
        path,
        fps=fps,
        width=width,
        height=height,
        track_body=None,
        slow_motion=slow,
        events=event_captions(result),
        title=title,
        progress=progress,
        shadows=shadows,
        msaa=msaa,
        reflection=reflection,
        **cam,
        **render_kw,
    )
