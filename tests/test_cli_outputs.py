"""The one output-folder rule of every command (docs/cli.md, biped.cli._common): a folder holding
another run or foreign files is refused unless --overwrite; --overwrite removes what the new run
does not write and keeps files biped did not write; an existing file or an unwritable place is
refused before any work. Shown on `biped posture pendulum` (a short run) and `biped push` (its
simulation replaced by a sentinel: the refusal must come before it)."""

from __future__ import annotations

import json

import pytest

import biped.sim.push
from biped.cli import main

_SHORT = ["--dt", "0.02", "--duration", "0.2"]


def _posture(capsys, out, *extra):
    rc = main(["posture", "pendulum", *_SHORT, "--out", str(out), *extra])
    return rc, capsys.readouterr().err


def test_a_folder_with_another_commands_run_is_refused_naming_it(tmp_path, capsys):
    out = tmp_path / "R"
    out.mkdir()
    (out / "summary.json").write_text("{}")
    (out / ".biped-run.json").write_text(json.dumps({"command": "push", "files": ["summary.json"]}))
    rc, err = _posture(capsys, out, "--no-animation")
    assert rc == 2 and "already holds a run of 'biped push'" in err and "--overwrite" in err
    assert sorted(p.name for p in out.iterdir()) == [".biped-run.json", "summary.json"]


def test_a_folder_with_foreign_files_is_refused(tmp_path, capsys):
    out = tmp_path / "R"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    rc, err = _posture(capsys, out)
    assert rc == 2 and "holds no biped run" in err and "notes.txt" in err


def test_overwrite_removes_what_the_new_run_does_not_write_and_keeps_foreign_files(tmp_path, capsys):
    out = tmp_path / "R"
    rc, _ = _posture(capsys, out)  # with animation.gif
    assert rc == 0 and (out / "animation.gif").is_file()
    first = json.loads((out / ".biped-run.json").read_text())
    assert "animation.gif" in first["files"] and first["command"] == "posture pendulum"
    (out / "notes.txt").write_text("mine")
    rc, err = _posture(capsys, out, "--no-animation")
    assert rc == 2 and "already holds a run" in err
    rc, _ = _posture(capsys, out, "--no-animation", "--overwrite")
    assert rc == 0
    assert not (out / "animation.gif").exists()  # the old run's file did not survive
    assert (out / "notes.txt").read_text() == "mine"  # not biped's: kept
    second = json.loads((out / ".biped-run.json").read_text())
    assert "animation.gif" not in second["files"] and "notes.txt" not in second["files"]
    assert {"summary.json", "trajectory.csv"} <= set(second["files"])


@pytest.mark.parametrize("where", ["file", "under_file", "proc"])
def test_an_out_where_nothing_can_be_written_is_refused_before_the_simulation(
    tmp_path, capsys, monkeypatch, where
):
    def never(*a, **k):
        raise AssertionError("the simulation started")

    monkeypatch.setattr(biped.sim.push, "simulate", never)
    (tmp_path / "f").write_text("x")
    out = {"file": tmp_path / "f", "under_file": tmp_path / "f" / "run", "proc": "/proc/biped-test/run"}[
        where
    ]
    rc = main(["push", "--quiet", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and "--out" in err and "Traceback" not in err
    assert (tmp_path / "f").read_text() == "x"


def test_a_failed_run_removes_the_folders_it_created(tmp_path, capsys):
    out = tmp_path / "a" / "b" / "c"
    # the closed loop blows up after the folder was made: status 2, and no empty folders remain
    # (absurd gains: an --x0 of 1e300 is now refused before the folder, with its range)
    rc = main(["posture", "pendulum", "--dt", "0.02", "--duration", "1", "--gains", "1e15", "1e12",
               "--out", str(out), "--no-animation"])  # fmt: skip
    err = capsys.readouterr().err
    assert rc == 2 and "diverged" in err
    assert not (tmp_path / "a").exists()
