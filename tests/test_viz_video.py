"""The offscreen video: decoded frames show the biped, and the tracking camera keeps it in view.

Oracle: the decoded MP4 itself (imageio-ffmpeg, independent of the writer's code path), and a
counterfactual: with a fixed camera the same sliding motion moves the biped across the image.
"""

from __future__ import annotations

import numpy as np
import pytest

from biped.errors import ModelError, ScenarioError, StateError
from biped.viz import gl_available, render_video
from biped.viz.video import frame_indices


def _sliding(model, T=10, fps=30.0, dx=-0.8):
    """(times, qpos): W's initial posture, the root sliding ``dx`` m along x over T frames."""
    q = np.tile(model.key_qpos[0], (T, 1))
    q[:, 0] += np.linspace(0.0, dx, T)
    return np.arange(T) / fps, q


def _trunk_pixels(frame):
    """Boolean mask of the trunk's colour (MJCF rgba 0.8 0.35 0.3) in an RGB frame, shaded."""
    f = frame.astype(float)
    r, g, b = f[..., 0], f[..., 1], f[..., 2]
    return (r > 60) & (r > 1.6 * g) & (r > 1.6 * b)


def _decode(path):
    import imageio.v3 as iio

    return iio.imread(path, plugin="FFMPEG")


def test_frame_indices_hold_the_last_sample_at_or_before_each_frame_time():
    times = np.arange(501) / 500.0  # 1 s at 500 Hz
    idx = frame_indices(times, 30)
    assert len(idx) == 31  # 0, 1/30, ..., 30/30 s
    k = np.arange(31)
    np.testing.assert_array_equal(idx, np.floor(k * 500 / 30 + 1e-9).astype(int))
    assert np.all(times[idx] <= k / 30 + 1e-12)


def test_bad_arguments_raise_before_rendering(wendlandt_mj, tmp_path):
    t, q = _sliding(wendlandt_mj, T=3)
    with pytest.raises(ModelError, match="valid track_bodys: .*'central_body'"):
        render_video(wendlandt_mj, t, q, tmp_path / "v.mp4", track_body="pelvis")
    with pytest.raises(ScenarioError, match="width must be an even number"):
        render_video(wendlandt_mj, t, q, tmp_path / "v.mp4", width=641)
    with pytest.raises(ScenarioError, match="fps"):
        render_video(wendlandt_mj, t, q, tmp_path / "v.mp4", fps=0)
    with pytest.raises(StateError, match=r"\(T, nq\) = \(3, 19\)"):
        render_video(wendlandt_mj, t, q[:, :7], tmp_path / "v.mp4")
    assert not (tmp_path / "v.mp4").exists()


def test_video_decodes_and_the_tracking_camera_follows_the_biped(wendlandt_mj, gl, tmp_path):
    t, q = _sliding(wendlandt_mj)
    res = render_video(wendlandt_mj, t, q, tmp_path / "track.mp4", width=320, height=240)
    assert res.reason is None and res.path is not None and res.backend == gl
    frames = _decode(res.path)
    assert frames.shape == (10, 240, 320, 3) and res.frames == 10
    cx = []
    for f in frames:
        assert f.std() > 10, "a uniform frame"
        mask = _trunk_pixels(f)
        assert mask.sum() > 200, "the biped's trunk is not in the frame"
        cx.append(np.nonzero(mask)[1].mean())
    # the body slides 0.8 m but stays where the camera looks
    assert abs(cx[-1] - cx[0]) < 6, cx

    # counterfactual: a fixed camera sees the same motion sweep across the image
    fixed = render_video(wendlandt_mj, t, q, tmp_path / "fixed.mp4", width=320, height=240, track_body=None)
    xs = [np.nonzero(_trunk_pixels(f))[1].mean() for f in _decode(fixed.path)[[0, -1]]]
    assert abs(xs[1] - xs[0]) > 40, xs


def test_without_opengl_it_returns_a_one_line_reason_instead_of_raising(wendlandt_mj, tmp_path, monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "disable")
    gl_available.cache_clear()
    try:
        t, q = _sliding(wendlandt_mj, T=3)
        res = render_video(wendlandt_mj, t, q, tmp_path / "v.mp4")
    finally:
        gl_available.cache_clear()
    assert res.path is None and res.frames == 0
    assert "MUJOCO_GL" in res.reason and "\n" not in res.reason
    assert not (tmp_path / "v.mp4").exists()


def test_an_unprobed_backend_that_fails_falls_back_to_the_probe(wendlandt_mj, gl, tmp_path, monkeypatch):
    """The video tries its first backend without the ~1 s probe; when that one cannot render
    (here MUJOCO_GL names one that does not exist) it probes the others and renders with the
    one that works, as it did when it always probed first."""
    monkeypatch.setenv("MUJOCO_GL", "nosuchbackend")
    gl_available.cache_clear()
    try:
        t, q = _sliding(wendlandt_mj, T=3)
        res = render_video(wendlandt_mj, t, q, tmp_path / "v.mp4", width=64, height=48)
    finally:
        gl_available.cache_clear()
    assert res.reason is None and res.backend in ("egl", "osmesa"), res
    assert res.frames == 3 and len(_decode(res.path)) == 3


def test_a_prewarmed_renderer_takes_the_job_and_an_unused_one_exits(wendlandt_mj, gl, tmp_path):
    """prewarm() starts the renderer's process ahead (what `biped push` does before it
    simulates); the next video is rendered by that process; one never given a job exits as
    soon as its stdin closes (as when the command ends), leaving no process behind."""
    from biped.viz import video

    video.prewarm()
    ((waiting, _),) = video._WAITING.values()
    t, q = _sliding(wendlandt_mj, T=3)
    res = render_video(wendlandt_mj, t, q, tmp_path / "v.mp4", width=64, height=48)
    assert res.reason is None and res.frames == 3 and not video._WAITING
    assert waiting.poll() == 0  # it rendered the job and exited
    video.prewarm()
    ((unused, err),) = video._WAITING.values()
    video._WAITING.clear()
    unused.stdin.close()
    assert unused.wait(timeout=60) == 0
    err.close()
