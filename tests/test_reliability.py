"""Reliability (issue 24, docs/cli.md "Guarantees"): biped never removes a file it did not write,
never writes through a symbolic link, never leaves an empty or half file in place of a good one,
never reads an unbounded input, never mixes two models in one sweep, never hangs on a peer that
is not Dask, and refuses bad input before any lock, manifest, trial or file exists.

Each test builds the hostile state itself (a planted link, an odd run marker, a silent TCP
peer, a real full tmpfs where the machine allows mounting one) and checks the files afterwards
against what was there before, not against what the code says it did."""

from __future__ import annotations

import errno
import json
import os
import socket
import subprocess
import threading
import time
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from _helpers import one_line_error, toy_trial

from biped import files, models
from biped.cli import main
from biped.errors import ModelError, ScenarioError
from biped.sim.sweep import SweepSpec, connect_scheduler, parse_axis, run_sweep
from biped.sim.sweep.store import parts_dir, spec_difference

_POSTURE = ["posture", "pendulum", "--dt", "0.02", "--duration", "0.2", "--no-animation"]


def _tree(root: Path) -> dict[str, bytes]:
    """Every file under ``root`` (links as their target text) and its content."""
    out = {}
    for p in sorted(root.rglob("*")):
        rel = str(p.relative_to(root))
        if p.is_symlink():
            out[rel] = b"-> " + os.readlink(p).encode()
        elif p.is_file():
            out[rel] = p.read_bytes()
    return out


# ---------------------------------------------------------------------------------------------
# 1. --overwrite removes only what the checked run marker lists


def test_overwrite_keeps_a_users_files_in_a_run_folder(tmp_path, capsys):
    out = tmp_path / "u"
    (out / "figures").mkdir(parents=True)
    (out / "figures" / "thesis.tex").write_text("t")
    (out / "run.log").write_text("n")
    assert main([*_POSTURE, "--out", str(out), "--overwrite"]) == 0  # no marker: nothing removed
    assert (out / "figures" / "thesis.tex").read_text() == "t" and (out / "run.log").read_text() == "n"
    marker = json.loads((out / ".biped-run.json").read_text())
    assert "run.log" not in marker["files"] and "figures/thesis.tex" not in marker["files"]
    # a previous run's own file in figures/ goes, the user's file beside it stays
    (out / "figures" / "old.png").write_bytes(b"png")
    marker["files"].append("figures/old.png")
    (out / ".biped-run.json").write_text(json.dumps(marker))
    assert main([*_POSTURE, "--out", str(out), "--overwrite"]) == 0
    assert not (out / "figures" / "old.png").exists()
    assert (out / "figures" / "thesis.tex").read_text() == "t" and (out / "run.log").read_text() == "n"
    capsys.readouterr()


@pytest.mark.parametrize(
    "marker",
    [
        '{"files": null}',
        '["."]',
        "not json",
        '{"command": "rm -rf /", "files": ["victim.txt"]}',
        '{"command": "push", "files": ["../victim.txt"]}',
        '{"command": "push", "files": ["/etc/hostname"]}',
        '{"command": "push", "files": ["."]}',
        '{"command": "push", "files": [3]}',
        '{"command": "push", "files": ["link/victim.txt"]}',
    ],
)
def test_an_odd_run_marker_is_refused_and_nothing_is_removed(tmp_path, capsys, marker):
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "victim.txt").write_text("keep")
    out = tmp_path / "run"
    out.mkdir()
    (out / "victim.txt").write_text("keep too")
    (out / "link").symlink_to(outside)
    (out / ".biped-run.json").write_text(marker)
    before = _tree(tmp_path)
    rc = main([*_POSTURE, "--out", str(out), "--overwrite"])
    line = one_line_error(capsys.readouterr().err, "posture pendulum")
    assert rc == 2 and ".biped-run.json" in line
    assert _tree(tmp_path) == before


# ---------------------------------------------------------------------------------------------
# 2. never through a link


def test_a_link_where_a_run_writes_is_refused_and_its_target_kept(tmp_path, capsys):
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    out = tmp_path / "run"
    out.mkdir()
    (out / "summary.json").symlink_to(victim)
    rc = main([*_POSTURE, "--out", str(out), "--overwrite"])
    line = one_line_error(capsys.readouterr().err, "posture pendulum")
    assert rc == 2 and "symbolic link" in line and "summary.json" in line
    assert victim.read_text() == "keep" and (out / "summary.json").is_symlink()


def test_the_writers_never_follow_a_link(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("keep")
    link = tmp_path / "out.txt"
    link.symlink_to(victim)
    for write in (
        lambda: files.write_text(link, "x"),
        lambda: files.write_bytes(link, b"x"),
        lambda: files.write_via(link, lambda tmp: tmp.write_text("x")),
    ):
        with pytest.raises(files.LinkError, match="symbolic link"):
            write()
    assert victim.read_text() == "keep" and sorted(p.name for p in tmp_path.iterdir()) == [
        "out.txt",
        "victim",
    ]


@pytest.mark.parametrize("where", ["lock", "out", "parts", "tmp"])
def test_a_sweep_never_writes_through_a_planted_link(tmp_path, where):
    victim = tmp_path / "victim"
    victim.write_text("keep")
    out = tmp_path / "s.parquet"
    planted = {
        "lock": out.with_name("s.parquet.lock"),
        "out": out,
        "parts": parts_dir(out),
        "tmp": out.with_name("s.parquet.tmp"),
    }[where]
    planted.symlink_to(victim)
    spec = SweepSpec(axes={"speed_m_s": (1.0,), "direction_deg": (0.0, 90.0)})
    if where == "tmp":  # the temporary file is a new name of its own: the link is never touched
        assert run_sweep(spec, out, workers=1, trial_fn=toy_trial, progress=False).complete
        assert planted.is_symlink()
    else:
        with pytest.raises(ScenarioError, match="symbolic link"):
            run_sweep(spec, out, workers=1, trial_fn=toy_trial, progress=False)
    assert victim.read_text() == "keep"


# ---------------------------------------------------------------------------------------------
# 6. a write error: exit 1, one line, the previous file kept, no empty or half file


def test_a_failed_write_keeps_the_previous_file_and_leaves_no_temporary(tmp_path, monkeypatch):
    target = tmp_path / "summary.json"
    target.write_text("good")

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(files.os, "fsync", full)
    with pytest.raises(files.WriteError) as info:
        files.write_text(target, "new" * 1000)
    assert info.value.errno == errno.ENOSPC and info.value.filename == str(target)
    assert target.read_text() == "good" and [p.name for p in tmp_path.iterdir()] == ["summary.json"]


def test_a_full_disk_during_a_run_is_exit_1_in_one_line_with_no_empty_files(tmp_path, capsys, monkeypatch):
    calls = {"n": 0}
    real = os.fsync

    def fills_up(fd):  # the disk fills after the first file
        calls["n"] += 1
        if calls["n"] > 1:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(fd)

    monkeypatch.setattr(files.os, "fsync", fills_up)
    out = tmp_path / "run"
    rc = main([*_POSTURE, "--out", str(out)])
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc == 1 and len(lines) == 1 and "No space left on device" in lines[0] and "Traceback" not in err
    left = [p for p in out.rglob("*") if p.is_file()]
    assert all(p.stat().st_size > 0 for p in left) and not (out / ".biped-run.json").exists()
    assert not any("biped-tmp" in p.name for p in left)


def test_a_full_disk_at_a_sweeps_end_keeps_every_finished_trial(tmp_path, monkeypatch):
    """The consolidated file cannot be written: the write error propagates (exit 1 on the CLI),
    no half file is in place, and every finished trial is still in the parts for a rerun."""
    out = tmp_path / "s.parquet"
    spec = SweepSpec(axes={"speed_m_s": (1.0, 3.0), "direction_deg": (0.0, 90.0)})

    real = os.fsync

    def full(fd):  # the disk is full when the sweep's file is written (its temporary)
        if os.readlink(f"/proc/self/fd/{fd}").endswith(".parquet"):
            raise OSError(errno.ENOSPC, "No space left on device")
        real(fd)

    with monkeypatch.context() as m:
        m.setattr(files.os, "fsync", full)
        with pytest.raises(files.WriteError):
            run_sweep(spec, out, workers=1, trial_fn=toy_trial, progress=False)
    assert not out.exists() and not [p for p in tmp_path.iterdir() if "biped-tmp" in p.name]
    again = run_sweep(spec, out, workers=1, trial_fn=toy_trial, progress=False)
    assert again.complete and again.skipped == 4 and again.ran == 0
    assert pq.read_table(out).column("index").to_pylist() == [0, 1, 2, 3]


def test_a_real_full_tmpfs_keeps_the_previous_file(tmp_path):
    """On a 64 KiB tmpfs (needs root and mount; skipped elsewhere): ENOSPC from the kernel."""
    mnt = tmp_path / "small"
    mnt.mkdir()
    if (
        os.geteuid() != 0
        or subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mnt)], capture_output=True
        ).returncode
    ):
        pytest.skip("cannot mount a tmpfs here")
    try:
        good = mnt / "replay.html"
        files.write_text(good, "good")
        with pytest.raises(files.WriteError) as info:
            files.write_bytes(good, b"x" * 200_000)
        assert info.value.errno == errno.ENOSPC
        assert good.read_text() == "good" and [p.name for p in mnt.iterdir()] == ["replay.html"]
    finally:
        subprocess.run(["umount", str(mnt)], check=False)


# ---------------------------------------------------------------------------------------------
# 7. bounded reads


@pytest.mark.parametrize("kind", ["device", "fifo", "folder", "large", "empty"])
def test_inputs_must_be_small_regular_files(tmp_path, capsys, kind):
    path = {"device": "/dev/zero", "fifo": str(tmp_path / "ff"), "folder": str(tmp_path), "empty": ""}.get(
        kind, str(tmp_path / "big")
    )
    if kind == "fifo":
        os.mkfifo(path)
    if kind == "large":  # sparse: larger than either limit, nothing written
        with open(path, "wb") as f:
            f.truncate(files.MAX_MODEL_BYTES + 1)
    words = {"device": "a device", "fifo": "a fifo", "folder": "a folder", "large": "MiB", "empty": "empty"}
    t0 = time.monotonic()
    for argv in (
        ["sweep", "--grid", path, "--dry-run", "--out", str(tmp_path / "s.parquet")],
        ["sweep", "--model", path, "--dry-run", "--out", str(tmp_path / "s.parquet")],
        ["push", "--scenario", path, "--out", str(tmp_path / "r")],
        ["push", "--model", path, "--out", str(tmp_path / "r")],
    ):
        assert _main(argv) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and words[kind] in err.splitlines()[-1], err
    assert time.monotonic() - t0 < 30 and not (tmp_path / "r").exists()


# ---------------------------------------------------------------------------------------------
# 3. a sweep's model is the compiled model; grid values are numbers


def _included_model(tmp_path: Path, head_size: str = "0.09647") -> Path:
    """A model file that ``<include>``s W's biped, whose head size is ``head_size``."""
    text = (
        models.path("wendlandt")
        .read_text()
        .replace('size="0.09647" rgba="0.8 0.65', f'size="{head_size}" rgba="0.8 0.65')
    )
    (tmp_path / "body.xml").write_text(text)
    main_file = tmp_path / "biped.xml"
    main_file.write_text('<mujoco model="with include">\n  <include file="body.xml"/>\n</mujoco>\n')
    return main_file


def test_a_change_in_an_included_file_is_a_different_sweep(tmp_path):
    from biped.sim.scenario import Scenario

    model = _included_model(tmp_path)
    out = tmp_path / "s.parquet"
    axes = {"speed_m_s": (1.0,), "direction_deg": (0.0, 90.0)}
    spec = SweepSpec(axes=axes, base=Scenario.for_model(model))
    assert run_sweep(spec, out, workers=1, trial_fn=toy_trial, progress=False).complete
    top = model.read_bytes()
    _included_model(tmp_path, head_size="0.12")  # the top-level file is the same bytes
    assert model.read_bytes() == top
    wider = SweepSpec(axes={**axes, "speed_m_s": (1.0, 2.0)}, base=Scenario.for_model(model))
    with pytest.raises(ScenarioError, match="compiles differently"):
        run_sweep(wider, out, workers=1, trial_fn=toy_trial, progress=False)
    # nothing of the new model was run or written: the old rows, alone, with their metadata
    assert pq.read_table(out).num_rows == 2 and not parts_dir(out).exists()


def test_a_range_and_the_same_values_typed_are_one_sweep():
    typed = ",".join(f"{1 + 0.1 * k:g}" for k in range(11))
    assert parse_axis("speed_m_s", "1:2:11") == parse_axis("speed_m_s", typed)
    a = SweepSpec(axes={"speed_m_s": parse_axis("speed_m_s", "1:2:11")})
    b = SweepSpec(axes={"speed_m_s": parse_axis("speed_m_s", typed)})
    assert [t.key for t in a.trials()] == [t.key for t in b.trials()]
    # a file written with the unrounded values is still the same sweep (compared as numbers)
    old = a.to_dict()
    old["grid"]["speed_m_s"] = [1 + 0.1 * k for k in range(11)]  # 1.7000000000000002 ...
    assert spec_difference(old, None, b) is None
    # a value that differs is named with all its digits
    old["grid"]["speed_m_s"][3] = 1.3000001
    diff = spec_difference(old, None, b)
    assert diff is not None and "1.3000001" in diff


# ---------------------------------------------------------------------------------------------
# 4. a scheduler that is not Dask


def _peer(mode: str):
    """A TCP server on 127.0.0.1 that accepts and says nothing, or garbage; (port, stop)."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    srv.settimeout(0.2)
    stop = threading.Event()
    conns = []

    def serve():
        while not stop.is_set():
            try:
                c, _ = srv.accept()
            except OSError:
                continue
            conns.append(c)
            if mode == "garbage":
                try:
                    c.sendall(b"\xff" * 64 + b"HTTP/1.1 200 OK\r\n\r\nnot dask" * 8)
                except OSError:
                    pass

    threading.Thread(target=serve, daemon=True).start()

    def close():
        stop.set()
        for c in conns:
            c.close()
        srv.close()

    return srv.getsockname()[1], close


@pytest.mark.parametrize("mode", ["silent", "garbage"])
def test_a_scheduler_that_is_not_dask_is_refused_in_time_leaving_nothing(tmp_path, capsys, monkeypatch, mode):
    import biped.sim.sweep.cluster as cluster  # the Dask side of the runner

    monkeypatch.setattr(cluster, "SCHEDULER_TIMEOUT_S", 0.5)
    port, close = _peer(mode)
    try:
        t0 = time.monotonic()
        with pytest.raises(ScenarioError, match="not a Dask scheduler|no Dask scheduler answered"):
            connect_scheduler(f"tcp://127.0.0.1:{port}")
        assert time.monotonic() - t0 < 5
        rc = main(["sweep", "--speed", "2", "--direction", "0", "--scheduler", f"tcp://127.0.0.1:{port}",
                   "--out", str(tmp_path / "s.parquet"), "--quiet"])  # fmt: skip
        one_line_error(capsys.readouterr().err, "sweep")
        assert rc == 2 and list(tmp_path.iterdir()) == []
    finally:
        close()


# ---------------------------------------------------------------------------------------------
# 5. every input checked before any lock, manifest, trial or file


@pytest.mark.parametrize(
    "bad",
    [
        ["--mass", "1000"],
        ["--speed", "500"],
        ["--speed", "2,500"],
        ["--height", "100"],
        ["--gain-scale", "1e9"],
        ["--direction", "1e300"],
        ["--plot", "FILE/plot.png"],
        ["--plot", "p.png", "--compare", "corrupt.parquet"],
        ["--out", ""],
        ["--model", ""],
        ["--out", "linked.parquet"],
        ["--out", "logged.parquet"],
    ],
)
@pytest.mark.parametrize("dry", [False, True])
def test_bad_sweep_inputs_are_refused_before_anything_exists(tmp_path, capsys, monkeypatch, bad, dry):
    monkeypatch.chdir(tmp_path)
    Path("FILE").write_text("a file, not a folder")
    Path("corrupt.parquet").write_bytes(b"PAR1 not really")
    Path("linked.parquet.lock").symlink_to("FILE")  # links where the sweep would write
    Path("logged.mujoco.log").symlink_to("FILE")
    before = _tree(tmp_path)
    argv = ["sweep", "--duration", "0.02", "--workers", "1", "--quiet", "--out", "s.parquet", *bad]
    assert _main([*argv, *(["--dry-run"] if dry else [])]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "error:" in err
    assert _tree(tmp_path) == before  # no lock, no parts, no manifest, no runs/ folder


def _main(argv: list[str]) -> int:
    """``main``'s status, argparse's own errors (SystemExit) included."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code or 0)


# ---------------------------------------------------------------------------------------------
# 8. no tracebacks: part files that are not parts, a model with other body names


@pytest.mark.parametrize("kind", ["garbage", "foreign schema"])
def test_a_part_file_that_is_not_a_part_is_named(tmp_path, kind):
    out = tmp_path / "s.parquet"
    pdir = parts_dir(out)
    pdir.mkdir()
    bad = pdir / "part-00000000000000000001-1.arrows"
    if kind == "garbage":
        bad.write_bytes(b"this is not arrow at all" * 10)
    else:
        table = pa.table({"x": [1, 2, 3]})
        with pa.OSFile(str(bad), "wb") as f, pa.ipc.new_stream(f, table.schema) as w:
            w.write_table(table)
    spec = SweepSpec(axes={"speed_m_s": (1.0,), "direction_deg": (0.0,)})
    with pytest.raises(ScenarioError, match="not a part file of a biped sweep") as info:
        run_sweep(spec, out, workers=1, trial_fn=toy_trial, progress=False)
    assert str(bad) in str(info.value) and bad.exists()


@pytest.mark.parametrize("content", ["[1, 2]", "{not json", '{"sweep": null}'])
def test_a_manifest_that_is_not_a_sweeps_is_named(tmp_path, capsys, content):
    out = tmp_path / "s.parquet"
    parts_dir(out).mkdir()
    (parts_dir(out) / "sweep.json").write_text(content)
    before = _tree(tmp_path)
    rc = main(["sweep", "--speed", "2", "--direction", "0", "--dry-run", "--out", str(out)])
    assert rc == 2 and "not a biped sweep's manifest" in one_line_error(capsys.readouterr().err, "sweep")
    assert _tree(tmp_path) == before


def test_walk_reads_a_model_with_other_body_names(tmp_path, capsys):
    """The model check names joints, not bodies: walk (its figure and its inverse dynamics) finds
    the leg by its joints, so a model that passes the check runs, with the same figure."""
    from biped.kinematic.figure import FigureDims

    text = models.path("wendlandt").read_text()
    for old, new in (("left_shank", "l_lower_leg"), ("left_ankle_1", "l_ankle_a"), ("left_hip_1", "l_hip_a")):
        text = text.replace(f'body name="{old}"', f'body name="{new}"')
    renamed = tmp_path / "renamed.xml"
    renamed.write_text(text)
    assert FigureDims.from_mjcf(renamed) == FigureDims.from_mjcf("wendlandt")
    out = tmp_path / "w"
    argv = ["walk", "--gait", "forward", "--steps", "1", "--model", str(renamed), "--out", str(out)]
    assert main([*argv, "--no-video", "--no-replay", "--no-figures", "--quiet"]) == 0
    assert (out / "inverse_dynamics.csv").is_file()
    capsys.readouterr()


# ---------------------------------------------------------------------------------------------
# 9. nonsense models are refused at load, naming the body


@pytest.mark.parametrize(
    ("old", "new", "words"),
    [
        (
            '<body name="left_shank" pos="0 0 -0.407304">',
            '<body name="left_shank" pos="0 0 nan">',
            "left_shank",
        ),
        ('size="0.09647" rgba="0.8 0.65', 'size="1e30" rgba="0.8 0.65', "central_body"),
        ('<geom name="trunk" type="box"', '<geom name="torso" type="box"', "'trunk'"),
    ],
)
def test_nonsense_models_are_refused_naming_the_part(tmp_path, capsys, old, new, words):
    from biped.models.subject import check_biped

    text = models.path("wendlandt").read_text()
    assert old in text
    bad = tmp_path / "bad.xml"
    bad.write_text(text.replace(old, new))
    with pytest.raises(ModelError, match=words):
        check_biped(bad)
    for argv in (
        ["sweep", "--model", str(bad), "--dry-run", "--out", str(tmp_path / "s.parquet")],
        ["push", "--model", str(bad), "--out", str(tmp_path / "r")],
        ["walk", "--model", str(bad), "--out", str(tmp_path / "w"), "--no-video"],
    ):
        assert main(argv) == 2
        assert words in one_line_error(capsys.readouterr().err, argv[0])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.xml"]


@pytest.mark.parametrize("x0", [["1e300", "0"], ["0", "1e300"], ["nan", "0"]])
def test_posture_refuses_an_absurd_initial_state_with_its_range(tmp_path, capsys, x0):
    rc = main(["posture", "pendulum", "--x0", *x0, "--out", str(tmp_path / "r")])
    line = one_line_error(capsys.readouterr().err, "posture pendulum")
    assert rc == 2 and "--x0" in line and ("must be in [" in line or "finite" in line)
    assert not (tmp_path / "r").exists()
