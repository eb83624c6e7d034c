"""Visualisation of a motion: a self-contained 3D browser replay and an offscreen video.

- :func:`replay_from_mujoco` (:mod:`biped.viz.replay_mujoco`) and :func:`write_replay`
  (:mod:`biped.viz.replay`): one HTML file that plays the motion in 3D with three.js (inlined;
  nothing loaded from the network).
- :func:`render_video` (module :mod:`biped.viz.video`): an MP4 from MuJoCo's offscreen renderer
  with a camera that follows a body; returns ``path=None`` and a reason where no OpenGL works.
- :func:`render_push_video` (module :mod:`biped.viz.push_video`): the push run's video, 854 x 480,
  the hit in slow motion (:class:`SlowMotion`, :mod:`biped.viz.timeline`), events captioned.

Both take ``(model, times, qpos)``: the visualisation is a function of the model and the
trajectory, computed after the simulation. See ``docs/viz.md``.
"""

from biped.viz.push_video import render_push_video
from biped.viz.replay import Replay, ReplayGeom, write_replay
from biped.viz.replay_mujoco import replay_from_mujoco
from biped.viz.timeline import SlowMotion
from biped.viz.video import VideoResult, gl_available, render_video

__all__ = [
    "Replay",
    "ReplayGeom",
    "SlowMotion",
    "VideoResult",
    "gl_available",
    "render_push_video",
    "render_video",
    "replay_from_mujoco",
    "write_replay",
]
