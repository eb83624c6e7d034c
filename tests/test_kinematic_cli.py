"""``biped walk``: its files, its errors, its replay in headless Chromium and its video.

Oracles: the floor and the stair treads (closed-form heights), the figure's own geometry for the
boxes three.js builds, and the CSV read back with the csv module.
"""

from __future__ import annotations

import html
import json
import math
import re

import numpy as np
import pytest
from _helpers import read_csv, run_chromium, walk_argv

from biped.cli import main
from biped.kinematic import step_upward
from biped.outputs.walk import CSV_COLUMNS, build_replay, figure_model, figure_qpos


def test_forward_writes_csv_summary_figures_and_replay(tmp_path, capsys):
    out = tmp_path / "fw"
    assert (
        main(["walk", "--gait", "forward", "--steps", "2", "--out", str(out), "--no-video", "--quiet"]) == 0
    )
    header, data = read_csv(out / "trajectory.csv")
    assert tuple(header) == CSV_COLUMNS
    for col in ("time", "left_knee", "pelvis_z", "left_heel_x", "right_toe_z"):
        assert col in header
    c = {n: i for i, n in enumerate(header)}
    # a foot that bears weight is on the floor: heel and toe at z = 0
    for side in ("left", "right"):
        st = data[:, c[f"{side}_stance"]] == 1
        assert np.max(np.abs(data[st, c[f"{side}_heel_z"]])) < 1e-6
        assert np.max(np.abs(data[st, c[f"{side}_toe_z"]])) < 1e-6
    s = json.loads((out / "summary.json").read_text())
    for k in (
        "max_penetration_m",
        "max_stance_slip_m",
        "min_swing_clearance_m",
        "distance_m",
        "height_climbed_m",
        "inverse_dynamics",
    ):
        assert k in s
    L = s["step_length_m"]
    assert s["distance_m"] == pytest.approx(2 * L, abs=1e-9)
    assert s["max_penetration_m"] < 1e-3 and s["max_stance_slip_m"] < 1e-3
    assert s["min_swing_clearance_m"] > 0.01
    for f in ("joint_angles.png", "feet.png", "inverse_dynamics.png"):
        assert (out / "figures" / f).stat().st_size > 10_000
    assert (out / "replay.html").stat().st_size > 100_000
    assert "max stance slip" in capsys.readouterr().out


def test_upstairs_options_reach_the_stairs(tmp_path):
    out = tmp_path / "up"
    assert main(walk_argv(out, "--stair-rise", "0.15", "--stair-run", "0.32", gait="upstairs", steps=3)) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["stairs"]["rise_m"] == 0.15 and s["stairs"]["run_m"] == 0.32
    assert s["height_climbed_m"] == pytest.approx(0.45)
    header, data = read_csv(out / "trajectory.csv")
    c = {n: i for i, n in enumerate(header)}
    assert data[-1, c["left_heel_z"]] == pytest.approx(0.45, abs=1e-6)  # both feet on tread 3
    assert data[-1, c["right_toe_z"]] == pytest.approx(0.45, abs=1e-6)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--gait", "jump", "--steps", "3"], "--steps applies to --gait forward and upstairs"),
        (["--gait", "forward", "--stair-rise", "0.1"], "apply to --gait upstairs and demo"),
        (["--gait", "upstairs", "--stair-run", "0.1"], "stair run must be at least"),
        (["--gait", "forward", "--speed", "-1"], "speed must be a positive number"),
        (["--gait", "forward", "--rate", "5"], r"--rate must be in \[20, 2000\] Hz"),
    ],
)
def test_bad_arguments_exit_2_with_a_clear_message(tmp_path, capsys, argv, message):
    assert main(["walk", *argv, "--out", str(tmp_path / "x"), "--no-video", "--quiet"]) == 2
    assert re.search(message, capsys.readouterr().err)


def test_existing_run_is_not_overwritten(tmp_path, capsys):
    out = tmp_path / "r"
    args = walk_argv(out)
    assert main(args) == 0
    assert main(args) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert main([*args, "--overwrite"]) == 0


@pytest.mark.browser
def test_chromium_draws_the_stance_foot_on_its_tread(tmp_path):
    """In the browser, at a double support on the stairs, each foot's box rests on the top of the
    stair box under it (the tread heights i * rise) and the figure's 15 parts are drawn."""
    plan = step_upward(steps=3)
    motion = plan.sample(100.0)
    rep = build_replay(motion, "stairs")
    f = tmp_path / "stairs.html"
    from biped.viz.replay import write_replay

    write_replay(rep, f)
    t = float(plan.starts[2])  # both feet down: treads 1 and 2
    i = int(np.argmin(np.abs(rep.times - t)))
    t = float(rep.times[i])
    dom = run_chromium(tmp_path, "--dump-dom", url=f"{f.as_uri()}#t={t!r}&probe=1")
    probe = re.search(r'<pre id="probe" style="[^"]*">(.*?)</pre>', dom, re.DOTALL)
    assert probe, dom[-2000:]
    boxes = {b["name"]: b for b in json.loads(html.unescape(probe[1]))["boxes"]}
    assert len([n for n in boxes if not n.startswith(("stair", "floor"))]) == 15
    rise = plan.terrain.blocks[0][2]
    feet = sorted(boxes[f"{s}_foot"]["min"][2] for s in ("left", "right"))
    assert feet == pytest.approx([rise, 2 * rise], abs=2e-4)
    assert boxes["stair1"]["max"][2] == pytest.approx(rise, abs=2e-4)
    assert boxes["stair2"]["max"][2] == pytest.approx(2 * rise, abs=2e-4)


def test_video_of_the_figure(tmp_path, gl):
    """A few frames of the figure's MJCF render to an MP4 (skipped where no OpenGL works)."""
    from biped.viz.video import render_video

    motion = step_upward(steps=1).sample(50.0)
    model = figure_model(motion)
    q = figure_qpos(model, motion)
    k = slice(0, 20)
    res = render_video(
        model,
        motion.times[k],
        q[k],
        tmp_path / "v.mp4",
        fps=10,
        width=160,
        height=120,
        track_body="pelvis",
        distance=3.0,
    )
    assert res.path is not None, res.reason
    assert res.frames == math.floor((motion.times[19] - motion.times[0]) * 10 + 1e-9) + 1
    assert res.path.stat().st_size > 1000


@pytest.mark.parametrize("model", [None, "wendlandt-file"])
def test_walk_with_video_writes_its_summary(tmp_path, monkeypatch, model):
    """The video stage builds the figure's own MjModel; the summary must still name the caller's
    biped (a merge once let that MjModel shadow ``model`` and the default ``biped walk`` crashed
    before summary.json; another rebound ``model`` to the figure's MjModel and the summary failed
    on Path(MjModel)). render_video is replaced by a stub that reports its frames through the
    progress callback, which must reach on_frame: the test is about the summary and the relay."""
    import mujoco

    import biped.outputs.walk as ow
    from biped.kinematic import step_forward
    from biped.models.subject import resolve
    from biped.viz.video import VideoResult

    seen, frames = {}, []

    def fake_video(fig_model, times, qpos, path, progress=None, **kw):
        assert isinstance(fig_model, mujoco.MjModel) and qpos.shape == (len(times), fig_model.nq)
        seen["nbody"] = fig_model.nbody
        for i in range(3):
            if progress is not None:
                progress(i + 1, 3)
        return VideoResult(None, "stubbed in the test")

    monkeypatch.setattr(ow, "render_video", fake_video)
    path = str(resolve("wendlandt")) if model else None
    run = ow.write_walk(
        step_forward(steps=1),
        tmp_path / "w",
        gait="forward",
        speed=1.0,
        rate=50.0,
        dynamics=False,
        figures=False,
        replay=False,
        video=True,
        model=path,
        on_frame=lambda done, total: frames.append((done, total)),
    )
    s = json.loads((tmp_path / "w" / "summary.json").read_text())
    assert s["model"] == (str(resolve("wendlandt").resolve()) if model else "wendlandt")
    assert s["notes"]["video"] == "stubbed in the test" and seen["nbody"] > 10
    assert run.summary == s
    assert frames == [(1, 3), (2, 3), (3, 3)]
