"""Files of `biped walk` and the commands' messages: inverse_dynamics.csv against Newton's law on
MuJoCo's whole-body COM, strict JSON, MuJoCo's warnings kept out of the current directory,
progress after the simulation and the whole command's time."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import mujoco
import numpy as np
import pytest
from _helpers import read_csv, strict_json, walk_argv

from biped.cli import main
from biped.kinematic.dynamics import load_biped
from biped.outputs._json import finite_json, write_json

SRC = str(Path(__file__).resolve().parents[1] / "src")


@pytest.mark.parametrize("gait", ["forward", "jump"])
def test_walk_inverse_dynamics_csv_obeys_newtons_law(tmp_path, gait):
    """inverse_dynamics.csv: the ground forces of both feet plus the flight residual equal
    m (a_com - g), the whole-body COM's acceleration from central differences of MuJoCo's
    subtree COM at the biped poses the inverse dynamics used (the biped's MJCF masses); CoP empty
    off the ground; the summary is strict JSON with a unit for every column."""
    from biped.kinematic import FigureDims, GaitParams, jump, step_forward
    from biped.outputs.walk import write_walk

    dims, params = FigureDims.from_anthropometry(), GaitParams()
    plan = step_forward(dims, 2, 1.0, params) if gait == "forward" else jump(dims, 1.0, params)
    out = tmp_path / "w"
    run = write_walk(plan, out, gait=gait, speed=1.0, rate=200.0, figures=False, replay=False, video=False)
    head, data = read_csv(out / "inverse_dynamics.csv")
    summary = strict_json((out / "summary.json").read_text())
    assert list(summary["inverse_dynamics_columns"]) == head
    with open(out / "trajectory.csv") as f:
        assert list(summary["trajectory_columns"]) == next(csv.reader(f))
    c = lambda n: data[:, head.index(n)]
    t = c("time")
    m = load_biped()
    d = mujoco.MjData(m)
    qpos = run.idyn.qpos
    com = np.zeros((len(t), 3))
    root = m.body("central_body").id
    for k in range(len(t)):
        d.qpos[:] = qpos[k]
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        com[k] = d.subtree_com[root]
    mass = float(m.body_subtreemass[root])
    g = np.array(m.opt.gravity)
    h = np.diff(t)
    ok = np.flatnonzero(np.abs(h[1:] - h[:-1]) < 1e-9) + 1
    acc = np.zeros_like(com)
    acc[ok] = (com[ok + 1] - 2 * com[ok] + com[ok - 1]) / h[ok][:, None] ** 2
    force = np.stack([c(f"left_grf_{a}") + c(f"right_grf_{a}") + c(f"residual_f{a}") for a in "xyz"], axis=1)
    # away from the gait's switches (stance changes make the acceleration jump)
    st = np.column_stack([c("left_stance"), c("right_stance")])
    same = np.zeros(len(t), dtype=bool)
    same[1:-1] = (st[:-2] == st[1:-1]).all(axis=1) & (st[2:] == st[1:-1]).all(axis=1)
    sel = np.intersect1d(ok, np.flatnonzero(same))
    assert sel.size > 0.5 * len(t)
    err = np.abs(force[sel] - mass * (acc[sel] - g))
    weight = mass * np.linalg.norm(g)
    # measured: median 1e-5, 95th percentile 3e-4 of the weight (second differences, h = 5 ms)
    assert np.median(err) < 1e-4 * weight and np.percentile(err, 95) < 2e-3 * weight
    air = c("left_stance") == 0
    assert np.isnan(c("left_cop_x")[air]).all()


def test_finite_json_replaces_every_non_finite_value(tmp_path):
    obj = {
        "a": float("nan"),
        "b": [1.0, float("inf"), np.float64("-inf")],
        "c": np.array([[np.nan, 2.0]]),
        "d": {"e": np.float32(3.5), "f": np.int64(4)},
        "g": (True, None, "x"),
    }
    path = write_json(tmp_path / "x.json", obj)
    assert strict_json(path.read_text()) == {
        "a": None,
        "b": [1.0, None, None],
        "c": [[None, 2.0]],
        "d": {"e": 3.5, "f": 4},
        "g": [True, None, "x"],
    }
    assert finite_json(float("nan")) is None


def test_posture_writes_strict_json_under_runs(tmp_path, monkeypatch):
    """`biped posture` without --out writes a new folder under runs/, like the other commands."""
    monkeypatch.chdir(tmp_path)
    assert main(["posture", "pendulum", "--duration", "0.2", "--no-animation"]) == 0
    (out,) = (tmp_path / "runs").glob("posture-pendulum-*")
    strict_json((out / "summary.json").read_text())


_WARN = textwrap.dedent("""
    import os, sys, mujoco
    import biped.sim  # noqa: F401  (sets where MuJoCo's warnings go)
    from biped.sim.mjlog import route_to
    if len(sys.argv) > 1:
        route_to(sys.argv[1])
    m = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/><geom size='.1'/></body></worldbody></mujoco>")
    d = mujoco.MjData(m)
    d.qvel[0] = float("nan")
    mujoco.mj_step(m, d)  # MuJoCo warns: bad qvel
    assert d.warning[mujoco.mjtWarning.mjWARN_BADQVEL].number == 1
""")


def _warn(cwd: Path, *args: str):
    env = dict(os.environ, PYTHONPATH=SRC)
    env.pop("BIPED_MUJOCO_LOG", None)
    return subprocess.run(
        [sys.executable, "-c", _WARN, *args],
        check=False,
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_mujoco_warnings_never_land_in_the_current_directory(tmp_path):
    """MuJoCo appends its warnings to MUJOCO_LOG.TXT in the current directory by default; with
    biped imported nothing is written there, and route_to sends them to the run's log."""
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    r = _warn(cwd)
    assert r.returncode == 0, r.stderr
    assert not (cwd / "MUJOCO_LOG.TXT").exists()
    log = tmp_path / "run" / "mujoco.log"
    log.parent.mkdir()
    r = _warn(cwd, str(log))
    assert r.returncode == 0, r.stderr
    assert not (cwd / "MUJOCO_LOG.TXT").exists()
    assert "QVEL" in log.read_text()
    # routed to the run's log, the warning is not printed (it would break a progress bar's line)
    assert "QVEL" not in r.stdout + r.stderr
    from biped.sim.mjlog import count_warnings, summary

    assert count_warnings(log) == 1 and summary(log, 0) == (
        f"MuJoCo warned 1 time (e.g. a diverging simulation): see {log}"
    )
    assert summary(log, 1) is None


def test_push_says_what_it_writes_and_the_whole_time(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "run"
    assert (
        main(
            [
                "push",
                "--duration",
                "0.05",
                "--no-video",
                "--no-replay",
                "--out",
                str(out),
                "--controller",
                "joint-pd",
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    assert "writing trajectory.csv" in text and "writing figures/" in text
    assert "the whole command" in text
    assert "joint-pd judged against its own set point" in text
    assert "W's set point" in text
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    assert (out / "columns.json").exists()


def test_walk_cli_writes_the_dynamics_csv_and_the_whole_time(tmp_path, capsys):
    out = tmp_path / "w"
    assert main(walk_argv(out, "--no-replay", "--no-figures", files=True)) == 0
    text = capsys.readouterr().out
    assert "the whole command" in text
    head, _data = read_csv(out / "inverse_dynamics.csv")
    assert head[0] == "time" and "left_grf_z" in head and "residual_mz" in head
    manifest = json.loads((out / ".biped-run.json").read_text())
    assert "inverse_dynamics.csv" in manifest["files"]


def _stub_video(frames: int):
    """A render_video for outputs.walk and outputs.push that reports ``frames`` frames through its
    progress callback and writes nothing."""
    from biped.viz.video import VideoResult

    def fake(*args, progress=None, **kw):
        for i in range(frames + 1):
            if progress is not None:
                progress(i, frames)
        return VideoResult(None, "stubbed", None, 0)

    return fake


@pytest.mark.parametrize("quiet", [False, True])
def test_walk_video_draws_pushs_frame_bar_unless_quiet(tmp_path, capsys, monkeypatch, quiet):
    """The walk's video stage shows the same frame counter as push (cli._common.frame_bar):
    "rendering video.mp4: n/7 frame" on stderr (whole lines here, where stderr is not a terminal;
    a tqdm bar on one); --quiet shows none."""
    import biped.outputs.walk as walk_out

    monkeypatch.setattr(walk_out, "render_video", _stub_video(7))
    argv = walk_argv(tmp_path / "w", files=True)
    argv.remove("--no-video")
    argv += ["--no-replay", "--no-figures", "--no-dynamics"]
    if not quiet:
        argv.remove("--quiet")
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert ("rendering video.mp4: 7/7 frame" in err) is not quiet, err


def test_push_quiet_says_nothing_about_video_frames(tmp_path, capsys, monkeypatch):
    """--quiet: no frame bar, and no "video.mp4: rendering n/N frames" lines instead of it."""
    import biped.outputs.push as push_out

    monkeypatch.setattr(push_out, "render_push_video", _stub_video(8))
    argv = ["push", "--duration", "0.02", "--controller", "joint-pd", "--no-replay", "--no-figures"]
    assert main([*argv, "--quiet", "--out", str(tmp_path / "q")]) == 0
    cap = capsys.readouterr()
    assert "rendering" not in cap.out + cap.err, cap
    assert main([*argv, "--out", str(tmp_path / "loud")]) == 0
    cap = capsys.readouterr()
    assert "rendering video.mp4" in cap.err and "8/8" in cap.err, cap


def test_push_outputs_report_stages_and_video_frames(tmp_path, monkeypatch):
    import biped.outputs.push as push_out
    from biped.sim import Scenario, simulate
    from biped.viz.video import VideoResult

    def fake_render(model, result, path, progress=None, **kw):
        for i in range(2):
            progress(i + 1, 2)
        return VideoResult(None, "stubbed", None, 0)

    monkeypatch.setattr(push_out, "render_push_video", fake_render)
    stages, frames = [], []
    push_out.write_outputs(
        simulate(Scenario(duration_s=0.02)),
        tmp_path,
        figures=False,
        replay=False,
        log=lambda m: None,
        on_stage=stages.append,
        on_frame=lambda d, n: frames.append((d, n)),
    )
    # the video renders while the rest is written: the frames done meanwhile are said at once,
    # then each as it comes (here all were done before write_outputs waited for them)
    assert stages == ["trajectory.csv", "video.mp4"] and frames[-1] == (2, 2)
    assert frames == sorted(frames) and set(frames) <= {(1, 2), (2, 2)}


def test_any_nested_value_gives_strict_json(tmp_path):
    """Property: whatever floats (NaN, +-Infinity, huge, tiny) sit in nested dicts, lists and
    arrays, write_json gives text that a strict parser accepts, with finite values kept and
    the others null."""
    from hypothesis import given, settings
    from hypothesis import strategies as st

    leaf = st.one_of(
        st.floats(allow_nan=True, allow_infinity=True),
        st.integers(),
        st.booleans(),
        st.none(),
        st.text(max_size=5),
    )
    tree = st.recursive(
        leaf,
        lambda ch: st.one_of(st.lists(ch, max_size=4), st.dictionaries(st.text(max_size=4), ch, max_size=4)),
        max_leaves=20,
    )

    def same(a, b):
        if isinstance(a, float):
            return b is None if not np.isfinite(a) else b == a
        if isinstance(a, dict):
            return set(a) == set(b) and all(same(a[k], b[k]) for k in a)
        if isinstance(a, list):
            return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
        return a == b

    @settings(max_examples=200, deadline=None)
    @given(tree)
    def check(obj):
        path = write_json(tmp_path / "p.json", obj)
        assert same(obj, strict_json(path.read_text()))

    check()


def test_progress_is_whole_lines_when_stderr_is_not_a_terminal(tmp_path):
    """Redirected (a pipe here), `biped push`'s progress is whole lines, never a tqdm bar redrawn
    with carriage returns, and says the figures as they are drawn and the end of the run."""
    env = dict(os.environ, PYTHONPATH=SRC)
    r = subprocess.run(
        [sys.executable, "-m", "biped", "push", "--duration", "0.1", "--no-video", "--no-replay"]
        + ["--controller", "joint-pd", "--out", str(tmp_path / "run")],
        check=False,
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    assert "\r" not in r.stderr
    lines = r.stderr.splitlines()
    assert "biped push: 0.10/0.10 s sim" in " ".join(lines)
    figs = [ln for ln in lines if ln.startswith("figures: ")]
    assert figs[0].startswith("figures: 0/4 figure") and figs[-1].startswith("figures: 4/4 figure"), lines
