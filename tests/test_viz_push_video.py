"""The push video: slow motion around the hit, a caption that follows the events, a camera that
sees the block and both feet at impact, 854 x 480 (cheap to render); and the walk video's shadow fix.

Oracles: closed-form durations written here from the documented schedule (not the module's
breakpoints); the decoded MP4 (imageio-ffmpeg); MuJoCo's own camera model (``mjv_updateScene``
fills ``mjvGLCamera``: position, axes and frustum) and MuJoCo's collision detection for the moment
the block touches the trunk; a counterfactual render with MuJoCo's fixed shadow box.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest

from biped.errors import ScenarioError
from biped.viz.push_video import push_camera, push_slow_motion, render_push_video
from biped.viz.timeline import SlowMotion, overlay_text, playback_times
from biped.viz.video import frame_indices, render_video


def _expected_frames(t0, t1, fps, windows):
    """Frame count from the documented schedule: real time outside, (end - start) / speed in."""
    d = (t1 - t0) + sum((b - a) * (1 / s - 1) for a, b, s in windows)
    return math.floor(d * fps + 1e-9) + 1, d


def _sim_time_of_frame(k, fps, t0, a, b, s):
    """Simulated time shown at video time k / fps with one window [a, b] at speed s."""
    v = k / fps
    if v <= a - t0:
        return t0 + v
    if v <= (a - t0) + (b - a) / s:
        return a + (v - (a - t0)) * s
    return b + v - (a - t0) - (b - a) / s


def test_frame_count_and_times_follow_the_slow_motion_schedule():
    t0, t1, fps = 0.0, 3.0, 30
    a, b, s = 0.032, 0.394, 0.25
    ft = playback_times(t0, t1, fps, SlowMotion(a, b, s))
    n, d = _expected_frames(t0, t1, fps, [(a, b, s)])
    assert len(ft) == n == 123 and abs(d - 4.086) < 1e-12
    want = [_sim_time_of_frame(k, fps, t0, a, b, s) for k in range(n)]
    np.testing.assert_allclose(ft, want, atol=1e-12)
    # inside the window a frame advances speed / fps of simulated time, outside 1 / fps
    step = np.diff(ft)
    inside = (ft[:-1] >= a) & (ft[1:] <= b)
    np.testing.assert_allclose(step[inside], s / fps, rtol=1e-9)
    outside = (ft[1:] <= a) | (ft[:-1] >= b)
    np.testing.assert_allclose(step[outside], 1 / fps, rtol=1e-9)
    # no window: the old real-time frames
    times = np.arange(1501) / 500.0
    np.testing.assert_array_equal(frame_indices(times, 30), np.floor(np.arange(91) * 500 / 30 + 1e-9))


def test_bad_slow_motion_is_refused_in_one_line():
    with pytest.raises(ScenarioError, match=r"speed must be in \(0, 1\]"):
        SlowMotion(0.1, 0.2, 0.0)
    with pytest.raises(ScenarioError, match="end_s > start_s"):
        SlowMotion(0.2, 0.1)
    with pytest.raises(ScenarioError, match="overlap"):
        playback_times(0, 1, 30, [SlowMotion(0.1, 0.3), SlowMotion(0.2, 0.4)])


def test_captions_change_at_the_event_times():
    fps, a, b, s = 30, 0.032, 0.394, 0.25
    ft = playback_times(0.0, 3.0, fps, SlowMotion(a, b, s))
    events = [
        {"time_s": 0.294, "label": "right heel down"},
        {"time_s": 0.082, "label": "block hits"},
        {"time_s": 0.086, "label": "left heel up"},
    ]
    cap = overlay_text(ft, fps, events=events, slow_motion=SlowMotion(a, b, s), hold_s=1.5)
    for e in events:
        line = f"{e['time_s']:.3f} s  {e['label']}"
        shown = [k for k, c in enumerate(cap) if line in c["events"]]
        # first frame whose simulated time (closed form) is at or after the event
        first = next(
            k for k in range(len(ft)) if _sim_time_of_frame(k, fps, 0, a, b, s) >= e["time_s"] - 1e-12
        )
        assert shown[0] == first, (e, shown[:3], first)
        # on screen for 1.5 s of video, contiguously
        assert shown == list(range(first, first + 45)), e
    # time order on screen, and the speed caption exactly inside the window
    both = next(c for c in cap if len(c["events"]) == 2)
    assert both["events"] == ["0.082 s  block hits", "0.086 s  left heel up"]
    assert all((c["speed"] == "0.25x slow motion") == (a <= t < b) for c, t in zip(cap, ft, strict=False))
    assert cap[0]["time"] == "t = 0.000 s" and cap[10]["time"] == f"t = {ft[10]:.3f} s"


def _thrown_block(scene, T=0.2, rate=500.0):
    """A fake push result: W's initial posture, the block flying at its initial velocity until
    MuJoCo's collision detection finds it touching the biped, then resting there."""
    from biped.sim import Scenario
    from biped.sim.scene import initial_state

    sc = Scenario()
    q0, _ = initial_state(scene, sc)
    m = scene.model
    d = mujoco.MjData(m)
    times = np.arange(round(T * rate) + 1) / rate
    qpos = np.tile(q0, (times.size, 1))
    bi = scene.block_qpos_index[:3]
    hit = None
    for k, t in enumerate(times):
        qpos[k, bi] = np.asarray(sc.block_position_m) + np.asarray(sc.block_velocity_m_s) * (
            t if hit is None else hit
        )
        d.qpos[:] = qpos[k]
        mujoco.mj_forward(m, d)
        touching = any(
            scene.block_geom in (c.geom1, c.geom2) and scene.floor_geom not in (c.geom1, c.geom2)
            for c in d.contact[: d.ncon]
        )
        if touching and hit is None:
            hit = t
    assert hit is not None and 0.05 < hit < 0.12, hit
    Ev = SimpleNamespace
    events = (
        Ev(time_s=hit + 0.004, foot="left", part="heel", kind="lift_off"),
        Ev(time_s=hit + 0.06, foot="left", part="heel", kind="touch_down"),
    )
    return SimpleNamespace(
        times=times,
        qpos=qpos,
        events=events,
        block_contact_time_s=hit,
        fall_time_s=None,
        fall_reason=None,
        scenario=sc,
    )


@pytest.fixture(scope="module")
def push_scene():
    from biped.sim import Scenario
    from biped.sim.scene import build_scene

    return build_scene(Scenario())


def _mujoco_projection(model, qpos, cam_kw, aspect):
    """Image coordinates in [-1, 1] of points, from MuJoCo's camera (mjv_updateScene)."""
    d = mujoco.MjData(model)
    d.qpos[:] = qpos
    mujoco.mj_forward(model, d)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = cam_kw["lookat"]
    cam.distance, cam.azimuth, cam.elevation = (cam_kw["distance"], cam_kw["azimuth"], cam_kw["elevation"])
    scn = mujoco.MjvScene(model, maxgeom=1000)
    mujoco.mjv_updateScene(model, d, mujoco.MjvOption(), None, cam, mujoco.mjtCatBit.mjCAT_ALL, scn)
    gc = scn.camera[0]
    fwd, up = np.array(gc.forward), np.array(gc.up)
    right = np.cross(fwd, up)
    half_h = 0.5 * (gc.frustum_top - gc.frustum_bottom)
    half_w = gc.frustum_width if gc.frustum_width > 0 else half_h * aspect

    def project(p):
        rel = np.asarray(p) - np.array(gc.pos)
        z = rel @ fwd
        assert np.all(z > gc.frustum_near) and np.all(z < gc.frustum_far)
        x = (rel @ right) * gc.frustum_near / z
        y = (rel @ up) * gc.frustum_near / z
        return np.column_stack(
            [(x - gc.frustum_center) / half_w, (y - 0.5 * (gc.frustum_top + gc.frustum_bottom)) / half_h]
        )

    return d, project


def _corners(d, model, g):
    half = model.geom_aabb[g, 3:]
    s = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)])
    return d.geom_xpos[g] + (model.geom_aabb[g, :3] + s * half) @ d.geom_xmat[g].reshape(3, 3).T


def test_the_camera_frustum_holds_the_block_and_both_feet_at_impact(push_scene):
    fake = _thrown_block(push_scene)
    m = push_scene.model
    cam = push_camera(m, fake, aspect=16 / 9)
    k = int(np.searchsorted(fake.times, fake.block_contact_time_s + 1e-12) - 1)
    d, project = _mujoco_projection(m, fake.qpos[k], cam, 16 / 9)
    names = ["block", "left_heel", "left_toe", "right_heel", "right_toe", "head"]
    for name in names:
        uv = project(_corners(d, m, m.geom(name).id))
        assert np.all(np.abs(uv) < 0.95), (name, uv)
    # the check is not vacuous: the same camera aimed 4 m to the side misses the block
    off = dict(cam, lookat=np.asarray(cam["lookat"]) + [4.0, 0.0, 0.0])
    _, project_off = _mujoco_projection(m, fake.qpos[k], off, 16 / 9)
    assert np.any(np.abs(project_off(_corners(d, m, m.geom("block").id))) > 1)


def test_push_video_is_854x480_slowed_around_the_hit_and_shows_the_block(push_scene, gl, tmp_path):
    import imageio.v3 as iio

    fake = _thrown_block(push_scene)
    hit = fake.block_contact_time_s
    fps = 10  # few frames: the CPU is shared
    seen = []
    res = render_push_video(
        push_scene.model, fake, tmp_path / "push.mp4", fps=fps, progress=lambda n, N: seen.append((n, N))
    )
    assert res.reason is None, res.reason
    # the documented window: 0.05 s before the hit until 0.1 s after the last foot event, at
    # least 0.3 s after the hit (clipped to the run's end)
    a, b = hit - 0.05, min(max(hit + 0.3, hit + 0.06 + 0.1), fake.times[-1])
    n, _ = _expected_frames(0.0, fake.times[-1], fps, [(a, b, 0.25)])
    frames = iio.imread(res.path, plugin="FFMPEG")
    assert frames.shape == (n, 480, 854, 3) and res.frames == n
    meta = iio.immeta(res.path, plugin="FFMPEG")
    assert meta["fps"] == fps and abs(meta["duration"] - n / fps) < 1.5 / fps
    assert seen[0] == (0, n) and seen[-1] == (n, n) and len(seen) == n + 1

    # the frame at the hit: block-coloured pixels (rgba 0.9 0.6 0.1) are visible, not hidden
    k_hit = next(k for k in range(n) if _sim_time_of_frame(k, fps, 0.0, a, b, 0.25) >= hit - 1e-12)
    f = frames[k_hit].astype(int)
    r, g, b = f[..., 0], f[..., 1], f[..., 2]
    orange = (r > 70) & (g > 0.5 * r) & (g < 0.85 * r) & (b < 0.25 * r)  # trunk: b ~ 0.36 r
    assert orange.sum() > 400 * (480 / 720) ** 2, orange.sum()  # 400 pixels at 1280 x 720
    f0 = frames[0].astype(int)  # t = 0: the block is in the air, 0.4 m behind
    assert (orange & ((f0[..., 2] < 0.25 * f0[..., 0]) & (f0[..., 0] > 70))).sum() < 50
    # the event caption (bottom left) changes on that frame and not on the one before
    box = (slice(373, 480), slice(0, 347))  # 2/3 of (560:720, 0:520) at 1280 x 720
    diff = [np.abs(frames[k][box].astype(int) - frames[k - 1][box]).mean() for k in range(1, n)]
    assert diff[k_hit - 1] > 5 * max(np.median(diff), 0.2), diff
    assert diff[k_hit - 2] < diff[k_hit - 1] / 5, diff


def test_slow_motion_window_of_a_run(push_scene):
    fake = _thrown_block(push_scene, T=1.0)
    hit = fake.block_contact_time_s
    w = push_slow_motion(fake)
    assert (w.start_s, w.speed) == (pytest.approx(hit - 0.05), 0.25)
    assert w.end_s == pytest.approx(hit + 0.3)  # events end before hit + 0.2 s
    late = SimpleNamespace(
        **{
            **vars(fake),
            "events": fake.events
            + (SimpleNamespace(time_s=hit + 0.5, foot="right", part="toe", kind="touch_down"),),
        }
    )
    assert push_slow_motion(late).end_s == pytest.approx(hit + 0.6)
    missed = SimpleNamespace(**{**vars(fake), "block_contact_time_s": None})
    assert push_slow_motion(missed) is None


def _horizon_streaks(frame):
    """Dark grey pixels in the band just below the horizon (the first non-black row)."""
    f = frame.astype(int)
    lit = np.flatnonzero(f.max(axis=(1, 2)) > 40)
    top = lit[0]
    band = f[top : top + 60]
    grey = (np.ptp(band, axis=-1) < 14) & (band.max(axis=-1) < 150) & (band.min(axis=-1) > 30)
    return int(grey.sum())


def test_walk_video_has_no_shadow_streaks_near_the_horizon(gl, tmp_path):
    import imageio.v3 as iio

    from biped.kinematic import demo
    from biped.kinematic.figure import JOINT_NAMES, figure_mjcf
    from biped.spatial import rot_to_quat

    motion = demo().sample(50.0)
    model = mujoco.MjModel.from_xml_string(figure_mjcf(motion.dims, motion.plan.terrain.boxes(width=1.2)))
    k = round(14.0 * 50)  # 14 s in, 12 m from the light: streaks on the far floor
    # two frames, 0.04 s apart, as in the video: MuJoCo draws the first frame after its context
    # is made without the streaks; every later frame of a video shows them
    ks = (k - 2, k)
    q = np.zeros((2, model.nq))
    root = model.joint("pelvis").qposadr[0]
    for i, kk in enumerate(ks):
        q[i, root : root + 3] = motion.pelvis_pos[kk]
        q[i, root + 3 : root + 7] = rot_to_quat(np.ascontiguousarray(motion.pelvis_rot[kk]))
        for j, name in enumerate(JOINT_NAMES):
            q[i, model.joint(name).qposadr[0]] = motion.angles[kk, j]
    t = [13.96, 14.0]
    kw = {
        "track_body": "pelvis",
        "distance": 4.0,
        "azimuth": -125.0,
        "elevation": -15.0,
        "fps": 25,
        "width": 480,
        "height": 360,
        "overlay": False,
    }
    fixed = render_video(model, t, q, tmp_path / "fixed.mp4", shadows="fixed", **kw)
    follow = render_video(model, t, q, tmp_path / "follow.mp4", **kw)
    a = iio.imread(fixed.path, plugin="FFMPEG")[-1]
    b = iio.imread(follow.path, plugin="FFMPEG")[-1]
    assert _horizon_streaks(a) > 150, "the counterfactual should show MuJoCo's streaks"
    assert _horizon_streaks(b) < 20
    # the shadows under the figure are still there: the frame is not simply shadowless
    off = iio.imread(
        render_video(model, t, q, tmp_path / "off.mp4", shadows="off", **kw).path, plugin="FFMPEG"
    )[-1]
    assert np.abs(b.astype(int) - off).mean() > 0.5


@pytest.mark.slow
def test_biped_push_outputs_write_the_slow_motion_video_and_say_its_progress(gl, tmp_path):
    """write_outputs (what `biped push` calls) of a short closed-loop run: the video is 854 x 480
    at 24 frames/s with the slow-motion frame count of the run's own hit time, and the log says
    n/N frames (the video renders while the rest is written: the frames done meanwhile are said
    at once, then as they come, ending at N/N)."""
    import imageio.v3 as iio

    from biped.outputs.push import write_outputs
    from biped.sim import Scenario, simulate

    r = simulate(Scenario(duration_s=0.12))  # the hit at ~0.08 s, few frames: shared CPU
    hit = r.block_contact_time_s
    assert hit is not None and 0.05 < hit < 0.12
    lines = []
    paths = write_outputs(r, tmp_path, figures=False, replay=False, log=lines.append)
    a, b = hit - 0.05, float(r.times[-1])  # the window is cut at the run's end
    n, _ = _expected_frames(0.0, b, 24, [(a, b, 0.25)])
    frames = iio.imread(paths["video"], plugin="FFMPEG")
    assert frames.shape == (n, 480, 854, 3)
    said = [ln for ln in lines if ln.startswith("video.mp4: rendering")]
    done = [int(ln.split()[2].split("/")[0]) for ln in said]
    assert all(ln.endswith(f"/{n} frames") for ln in said) and done == sorted(done), said
    assert said[-1] == f"video.mp4: rendering {n}/{n} frames" and 1 <= len(said) <= 6, said
