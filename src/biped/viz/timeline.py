"""When each video frame is shown, and what its overlay says: slow motion and event captions.

A video plays ``fps`` frames per second of *video* time. Outside the slow-motion windows one
second of video shows one second of the simulation; inside a :class:`SlowMotion` window it shows
``speed`` seconds (``speed = 0.25``: four times slower). Frame ``k`` is shown at video time
``k / fps`` and shows the simulated time ``playback_times(...)[k]``; the video lasts

    D = (t1 - t0) + sum over windows of (end - start) * (1 / speed - 1)    [s of video]

and has ``floor(D * fps) + 1`` frames (the first shows ``t0``, the last the latest frame time
at or before ``t1``).

Captions (:func:`overlay_text`): every frame shows the simulated time and, inside a window, the
playback speed; an event appears on the first frame whose simulated time is at or after the
event's and stays for ``hold_s`` seconds of video.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from biped.errors import ScenarioError

__all__ = ["SlowMotion", "frame_indices", "overlay_text", "playback_times", "video_duration", "video_time"]


@dataclass(frozen=True)
class SlowMotion:
    """Play the simulated interval ``[start_s, end_s]`` at ``speed`` times real time.

    Attributes:
        start_s, end_s: simulated time [s], ``end_s > start_s``.
        speed: playback speed inside the window, in (0, 1] (default 0.25: four times slower).
    """

    start_s: float
    end_s: float
    speed: float = 0.25

    def __post_init__(self):
        for name in ("start_s", "end_s", "speed"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float, np.integer, np.floating)) and math.isfinite(v)):
                raise ScenarioError(f"slow motion {name} must be a finite number, got {v!r}")
        if not self.end_s > self.start_s:
            raise ScenarioError(f"slow motion needs end_s > start_s [s], got [{self.start_s}, {self.end_s}]")
        if not 0.0 < self.speed <= 1.0:
            raise ScenarioError(
                f"slow motion speed must be in (0, 1] (0.25 = four times slower), got {self.speed!r}"
            )


def _windows(t0: float, t1: float, slow_motion) -> list[SlowMotion]:
    """The windows clipped to [t0, t1], sorted; overlapping windows are an error."""
    if slow_motion is None:
        return []
    if isinstance(slow_motion, SlowMotion):
        slow_motion = [slow_motion]
    out = []
    for w in slow_motion:
        if not isinstance(w, SlowMotion):
            raise ScenarioError(f"slow_motion must be SlowMotion windows, got {type(w).__name__}")
        a, b = max(w.start_s, t0), min(w.end_s, t1)
        if b > a:
            out.append(SlowMotion(a, b, w.speed))
    out.sort(key=lambda w: w.start_s)
    for u, v in itertools.pairwise(out):
        if v.start_s < u.end_s:
            raise ScenarioError(
                f"slow motion windows overlap: [{u.start_s}, {u.end_s}] and [{v.start_s}, {v.end_s}] s"
            )
    return out


def _breaks(t0: float, t1: float, slow_motion) -> tuple[np.ndarray, np.ndarray]:
    """Matching breakpoints (simulated time [s], video time [s]) of the piecewise-linear map."""
    sim, vid = [t0], [0.0]
    for w in _windows(t0, t1, slow_motion):
        vid.append(vid[-1] + (w.start_s - sim[-1]))
        sim.append(w.start_s)
        vid.append(vid[-1] + (w.end_s - w.start_s) / w.speed)
        sim.append(w.end_s)
    vid.append(vid[-1] + (t1 - sim[-1]))
    sim.append(t1)
    return np.asarray(sim), np.asarray(vid)


def video_duration(t0: float, t1: float, slow_motion=None) -> float:
    """Video time [s] that the simulated interval [t0, t1] lasts with ``slow_motion``."""
    return float(_breaks(float(t0), float(t1), slow_motion)[1][-1])


def video_time(t, t0: float, t1: float, slow_motion=None):
    """Video time [s] at which simulated time ``t`` (scalar or array, clipped to [t0, t1]) plays."""
    sim, vid = _breaks(float(t0), float(t1), slow_motion)
    return np.interp(t, sim, vid)


def playback_times(t0: float, t1: float, fps: float, slow_motion=None) -> np.ndarray:
    """Simulated time [s] shown by each frame: frame ``k`` plays at video time ``k / fps``."""
    sim, vid = _breaks(float(t0), float(t1), slow_motion)
    n = math.floor(vid[-1] * fps + 1e-9) + 1
    return np.interp(np.arange(n) / fps, vid, sim)


def frame_indices(times: np.ndarray, fps: float, slow_motion=None) -> np.ndarray:
    """Indices into ``times`` (T,) s of the samples shown at ``fps`` frames per second.

    Frame k shows the last sample at or before its simulated time (:func:`playback_times`;
    without ``slow_motion``, ``times[0] + k / fps``): a zero-order hold, so a free joint's
    quaternion is never interpolated. Frames run to ``times[-1]``.
    """
    times = np.asarray(times, dtype=float)
    ft = playback_times(times[0], times[-1], fps, slow_motion)
    return np.clip(np.searchsorted(times, ft + 1e-12, side="right") - 1, 0, times.size - 1)


def _event_list(events: Iterable[Mapping]) -> list[tuple[float, str]]:
    out = []
    for k, e in enumerate(events or ()):
        if not isinstance(e, Mapping) or "time_s" not in e or "label" not in e:
            raise ScenarioError(f"event {k} must be a mapping with 'time_s' (s) and 'label', got {e!r}")
        t = float(e["time_s"])
        if not math.isfinite(t):
            raise ScenarioError(f"event {k}: time_s must be finite, got {e['time_s']!r}")
        out.append((t, str(e["label"])))
    return sorted(out, key=lambda x: x[0])  # stable: simultaneous events keep their order


def overlay_text(
    frame_times: Sequence[float],
    fps: float,
    *,
    events: Iterable[Mapping] = (),
    slow_motion=None,
    hold_s: float = 1.5,
    max_events: int = 6,
    t1: float | None = None,
) -> list[dict]:
    """The caption of each frame: ``[{"time": str, "speed": str, "events": [str, ...]}, ...]``.

    ``time`` is ``"t = 0.123 s"``; ``speed`` is ``"0.25x slow motion"`` inside a window, else
    ``""``; ``events`` are the labels (``"0.082 s  block hits"``) of the at most ``max_events``
    latest events with ``time_s`` at or before the frame's simulated time, each shown for
    ``hold_s`` s of video from the first frame at or after it, oldest first.

    Args:
        frame_times: (N,) simulated time [s] of each frame (:func:`playback_times`).
        fps: frames per second of the video.
        events: mappings with ``time_s`` [s] and ``label``.
        slow_motion: the windows the frames were timed with.
        hold_s: how long an event stays on screen, s of video.
        max_events: at most this many event lines per frame.
        t1: end of the simulated interval (default: the last frame time).
    """
    ft = np.asarray(frame_times, dtype=float)
    if ft.size == 0:
        return []
    t0 = float(ft[0])
    t1 = float(ft[-1]) if t1 is None else float(t1)
    evs = _event_list(events)
    wins = _windows(t0, t1, slow_motion)
    ev_t = np.array([t for t, _ in evs])
    # video time of the first frame that shows each event
    first = np.searchsorted(ft, ev_t - 1e-12, side="left")
    out = []
    for k, tau in enumerate(ft):
        speed = next((w.speed for w in wins if w.start_s <= tau < w.end_s), None)
        shown = [
            f"{t:.3f} s  {lab}"
            for (t, lab), f in zip(evs, first, strict=False)
            if f <= k and (k - f) / fps < hold_s
        ]
        out.append(
            {
                "time": f"t = {tau:.3f} s",
                "speed": f"{speed:g}x slow motion" if speed is not None else "",
                "events": shown[-max_events:] if max_events > 0 else [],
            }
        )
    return out
