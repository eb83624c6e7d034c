"""A sweep never loses or overwrites finished trials: grid changes, concurrent sweeps, SIGTERM and
SIGKILL of the parent. The trials are pure Python (the runner only knows ``trial_fn(setup) ->
row``), so these tests are about storage and processes, not physics. Each asserts the set of
rows on disk afterwards against the trials the trial function itself logged as finished."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from _helpers import toy_trial

from biped.errors import ScenarioError
from biped.sim.scenario import Scenario
from biped.sim.sweep import SweepSpec, load, parts_dir, run_sweep
from biped.sim.sweep.store import part_files, read_part

HERE = Path(__file__).parent
GRID = {"speed_m_s": (1.0, 3.0), "direction_deg": (0.0, 90.0, 180.0, 270.0)}


def slow_trial(setup) -> dict:
    """0.1 s of "work", then logs ``<index> <pid>`` as finished and returns its row."""
    time.sleep(0.1)
    with open(os.environ["BIPED_TEST_DONE_LOG"], "a") as f:
        f.write(f"{setup.trial.index} {os.getpid()}\n")
    return toy_trial(setup)


def _rows_on_disk(out: Path) -> list[int]:
    """Trial indices in ``out`` and its parts (duplicates kept: there must be none)."""
    idx = []
    if out.exists():
        idx += load(out).column("index").tolist()
    for p in part_files(parts_dir(out)):
        idx += read_part(p).column("index").to_pylist()
    return idx


def _done(log: Path) -> dict[int, int]:
    if not log.exists():
        return {}
    return {int(a): int(b) for a, b in (line.split() for line in log.read_text().split("\n") if line.strip())}


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")


def _children(pid: int) -> set[int]:
    """Every descendant of ``pid`` (Linux /proc)."""
    out, todo = set(), [pid]
    while todo:
        p = todo.pop()
        for task in Path(f"/proc/{p}/task").glob("*"):
            try:
                kids = (task / "children").read_text().split()
            except FileNotFoundError:
                continue
            for k in map(int, kids):
                if k not in out:
                    out.add(k)
                    todo.append(k)
    return out


# ---------------------------------------------------------------------------------------------
# a rerun with another grid


def test_a_different_grid_is_refused_naming_the_difference(tmp_path):
    """The issue's reproduction: 16 trials, then a 2-trial grid on the same file."""
    out = tmp_path / "b.parquet"
    big = SweepSpec(axes={"speed_m_s": (1.0, 5.0), "direction_deg": tuple(range(0, 360, 45))})
    run_sweep(big, out, workers=1, trial_fn=toy_trial, progress=False)
    small = SweepSpec(axes={"speed_m_s": 2.0, "direction_deg": (0.0, 90.0)})
    with pytest.raises(ScenarioError) as err:
        run_sweep(small, out, workers=1, trial_fn=toy_trial, progress=False)
    msg = str(err.value)
    assert "\n" not in msg and "--overwrite" in msg
    assert "speed_m_s: 2 values [1, 5] in the file, 1 value [2] now" in msg
    assert "direction_deg: 8 values" in msg
    assert sorted(_rows_on_disk(out)) == list(range(16))  # untouched
    s = run_sweep(small, out, workers=1, trial_fn=toy_trial, progress=False, overwrite=True)
    assert s.ran == 2 and sorted(_rows_on_disk(out)) == [0, 1]


def test_a_grid_that_extends_the_old_one_adds_rows(tmp_path, monkeypatch):
    log = tmp_path / "done"
    monkeypatch.setenv("BIPED_TEST_DONE_LOG", str(log))
    out = tmp_path / "s.parquet"
    run_sweep(SweepSpec(axes=GRID), out, workers=1, trial_fn=slow_trial, progress=False)
    first = {(r["speed_m_s"], r["direction_deg"]): r["trial_key"] for r in load(out).table.to_pylist()}
    log.unlink()
    wider = SweepSpec(axes={**GRID, "speed_m_s": (1.0, 2.0, 3.0)})
    s = run_sweep(wider, out, workers=1, trial_fn=slow_trial, progress=False)
    assert s.skipped == 8 and s.ran == 4 and sorted(_done(log)) == [4, 5, 6, 7]
    rows = load(out).table.to_pylist()
    assert [r["index"] for r in rows] == list(range(12))  # re-indexed in the wider grid
    assert [(r["speed_m_s"], r["direction_deg"]) for r in rows] == [
        (s_, d) for s_ in (1.0, 2.0, 3.0) for d in (0.0, 90.0, 180.0, 270.0)
    ]
    assert all(
        first[(r["speed_m_s"], r["direction_deg"])] == r["trial_key"] for r in rows if r["speed_m_s"] != 2.0
    )
    # and the old, narrower grid is now a different sweep
    with pytest.raises(ScenarioError, match=r"speed_m_s: 3 values \[1, 2, 3\] in the file"):
        run_sweep(SweepSpec(axes=GRID), out, workers=1, trial_fn=toy_trial, progress=False)


def test_a_different_base_scenario_is_named(tmp_path):
    out = tmp_path / "s.parquet"
    run_sweep(SweepSpec(axes=GRID), out, workers=1, trial_fn=toy_trial, progress=False)
    other = SweepSpec(axes=GRID, base=SweepSpec().base.with_overrides(friction=0.5))
    old = SweepSpec().base.friction
    with pytest.raises(ScenarioError, match=f"scenario key friction: {old} in the file, 0.5 now"):
        run_sweep(other, out, workers=1, trial_fn=toy_trial, progress=False)


# ---------------------------------------------------------------------------------------------
# processes: a second sweep, SIGTERM, SIGKILL

SCRIPT = textwrap.dedent("""
    import sys
    sys.path.insert(0, {here!r})
    from biped.sim.sweep import SweepSpec, Terminated, run_sweep
    from test_sweep_storage import slow_trial
    axes = {{"speed_m_s": (1.0, 3.0, 5.0), "direction_deg": tuple(range(0, 360, 45))}}
    spec = SweepSpec(axes=axes)
    try:
        s = run_sweep(spec, {out!r}, workers={workers}, trial_fn=slow_trial, progress=False)
    except Terminated:
        sys.exit(143)
    sys.exit(0 if s.complete else 1)
""")
N_TRIALS = 24


def _start(tmp_path, out, log, workers=2):
    env = dict(os.environ, BIPED_TEST_DONE_LOG=str(log))
    code = SCRIPT.format(here=str(HERE), out=str(out), workers=workers)
    return subprocess.Popen([sys.executable, "-c", code], env=env, stderr=subprocess.PIPE)


def _wait_for(cond, timeout=60.0):
    t0 = time.monotonic()
    while not cond():
        if time.monotonic() - t0 > timeout:
            raise AssertionError("timed out")
        time.sleep(0.02)


def _finish(out, log):
    """The same sweep again, in this process: it must run exactly the trials not on disk."""
    before = set(_rows_on_disk(out))
    log.unlink(missing_ok=True)
    s = run_sweep(
        SweepSpec(axes={"speed_m_s": (1.0, 3.0, 5.0), "direction_deg": tuple(range(0, 360, 45))}),
        out,
        workers=1,
        trial_fn=slow_trial,
        progress=False,
    )
    assert s.complete and s.skipped == len(before)
    assert set(_done(log)) == set(range(N_TRIALS)) - before
    assert load(out).column("index").tolist() == list(range(N_TRIALS))


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_killing_the_parent_keeps_finished_trials_and_its_workers_exit(tmp_path, monkeypatch, sig):
    out, log = tmp_path / "s.parquet", tmp_path / "done"
    monkeypatch.setenv("BIPED_TEST_DONE_LOG", str(log))
    proc = _start(tmp_path, out, log)
    _wait_for(lambda: len(_done(log)) >= 6)
    kids = _children(proc.pid)
    proc.send_signal(sig)
    rc = proc.wait(timeout=30)
    err = proc.stderr.read().decode()
    finished = _done(log)
    assert kids and set(finished.values()) <= kids  # the trials ran in its worker processes
    _wait_for(lambda: not any(_alive(k) for k in kids), timeout=10)  # workers (and all) exit
    rows = _rows_on_disk(out)
    assert len(rows) == len(set(rows))
    assert set(rows) <= set(finished)
    in_flight = set(finished) - set(rows)
    if sig == signal.SIGTERM:
        assert rc == 143 and "Traceback" not in err
        assert len(in_flight) <= 2  # a trial that finished while the parent was stopping
    else:
        assert rc == -signal.SIGKILL
        assert len(in_flight) <= 2  # at most one per worker
    assert not out.exists() and len(rows) >= 5
    _finish(out, log)


def test_a_second_sweep_on_the_same_file_is_refused(tmp_path, monkeypatch):
    out, log = tmp_path / "s.parquet", tmp_path / "done"
    monkeypatch.setenv("BIPED_TEST_DONE_LOG", str(log))
    proc = _start(tmp_path, out, log, workers=1)
    _wait_for(lambda: len(_done(log)) >= 2)
    (parts_dir(out) / "notes.txt").write_text("mine")  # not the sweep's: must survive it
    spec = SweepSpec(axes={"speed_m_s": (1.0, 3.0, 5.0), "direction_deg": tuple(range(0, 360, 45))})
    with pytest.raises(ScenarioError, match=rf"another sweep \(pid {proc.pid}\) is writing"):
        run_sweep(spec, out, workers=1, trial_fn=slow_trial, progress=False)
    assert proc.wait(timeout=60) == 0
    assert load(out).column("index").tolist() == list(range(N_TRIALS))
    assert sorted(_done(log)) == list(range(N_TRIALS))  # each trial ran once
    assert (parts_dir(out) / "notes.txt").read_text() == "mine"
    s = run_sweep(spec, out, workers=1, trial_fn=slow_trial, progress=False)  # lock released
    assert s.skipped == N_TRIALS and s.ran == 0


def test_a_torn_part_file_keeps_its_complete_batches(tmp_path):
    """SIGKILL while a batch is being written: the batches before it are read back."""
    from biped.sim.sweep.runner import execute_trial
    from biped.sim.sweep.store import PartWriter

    spec = SweepSpec(axes=GRID)
    w = PartWriter(tmp_path)
    rows = [execute_trial(toy_trial, spec.setup(t)) for t in spec.trials()]
    for r in rows[:3]:
        w.write([r])
    size = w.path.stat().st_size
    w.write([rows[3]])
    w.close()
    data = w.path.read_bytes()
    w.path.write_bytes(data[: size + (len(data) - size) // 2])  # cut inside the 4th batch
    assert read_part(w.path).column("index").to_pylist() == [0, 1, 2]


# ---------------------------------------------------------------------------------------------
# a QP file written while qp_floor_friction defaulted to false


def _old_qp_file(tmp_path) -> Path:
    """A QP sweep file as the code before 2026-11-27 wrote it: qp_floor_friction false, its default
    then, and so left out of the stored scenario (metadata rewritten from today's false file, whose
    rows, trial keys and identity are those of that time)."""
    import json

    import pyarrow.parquet as pq

    out = tmp_path / "old.parquet"
    spec = SweepSpec(
        axes=GRID, base=SweepSpec().base.with_overrides(distribution="qp", qp_floor_friction=False)
    )
    run_sweep(spec, out, workers=1, trial_fn=toy_trial, progress=False)
    table = pq.read_table(out)
    meta = dict(table.schema.metadata)
    stored = json.loads(meta[b"biped.sweep"])
    assert stored["scenario"].pop("qp_floor_friction") is False
    meta[b"biped.sweep"] = json.dumps(stored).encode()
    toml = meta[b"biped.scenario"].decode().replace("qp_floor_friction = false\n", "")
    meta[b"biped.scenario"] = toml.encode()
    assert b"qp_floor_friction" not in meta[b"biped.sweep"] + meta[b"biped.scenario"]
    assert meta[b"biped.sweep_id"].decode() == spec.identity  # the trials' keys of that time
    pq.write_table(table.replace_schema_metadata(meta), out)
    return out


def test_an_old_qp_file_reads_as_the_sole_pyramid_and_is_not_resumed_as_the_floors(tmp_path):
    """Since qp_floor_friction defaults to true, a QP file without the key (written when it
    defaulted to false) is read as false and refused, with the usual message, by a sweep or an
    envelope of today's default, which would otherwise have resumed it (and consolidated its rows
    into a file that says true); a rerun that asks for false resumes it without running a trial."""
    from biped.sim.sweep import SweepSpec as Spec
    from biped.sim.sweep.envelope import run_envelope

    out = _old_qp_file(tmp_path)
    before = out.read_bytes()
    assert load(out).scenario.qp_floor_friction is False
    now = Spec(axes=GRID, base=Spec().base.with_overrides(distribution="qp"))
    assert now.base.qp_floor_friction is True
    msg = r"holds a different sweep \(scenario key qp_floor_friction: False in the file, True now\)"
    with pytest.raises(ScenarioError, match=msg):
        run_sweep(now, out, workers=1, trial_fn=toy_trial, progress=False)
    with pytest.raises(ScenarioError, match=msg):
        run_envelope(now.with_axes(speed_m_s=(1.0, 2.0, 3.0)), out, trial_fn=toy_trial, workers=1)
    assert out.read_bytes() == before and not parts_dir(out).exists()

    def never(setup):
        raise AssertionError(f"trial {setup.trial.index} ran again: the old rows were not reused")

    same = Spec(axes=GRID, base=now.base.with_overrides(qp_floor_friction=False))
    s = run_sweep(same, out, workers=1, trial_fn=never, progress=False)
    assert sorted(load(out).column("index").tolist()) == list(range(8)), s
    assert load(out).scenario.qp_floor_friction is False


def test_an_old_stepping_file_reads_as_capture_and_resumes_only_as_capture(tmp_path):
    """Since step_trigger defaults to "qp", a stepping file without the key (written when
    "capture" was the default, and so left out) is read as "capture" and refused by today's
    default; a rerun asking for "capture" resumes it without running a trial (its trials' keys
    are those of that time)."""
    import json

    import pyarrow.parquet as pq

    out = tmp_path / "old.parquet"
    spec = SweepSpec(axes=GRID, base=SweepSpec().base.with_overrides(stepping=True, step_trigger="capture"))
    run_sweep(spec, out, workers=1, trial_fn=toy_trial, progress=False)
    table = pq.read_table(out)
    meta = dict(table.schema.metadata)
    stored = json.loads(meta[b"biped.sweep"])
    assert stored["scenario"].pop("step_trigger") == "capture"
    meta[b"biped.sweep"] = json.dumps(stored).encode()
    meta[b"biped.scenario"] = (
        meta[b"biped.scenario"].decode().replace('step_trigger = "capture"\n', "").encode()
    )
    assert b"step_trigger" not in meta[b"biped.sweep"] + meta[b"biped.scenario"]
    # the trials' keys are those of that time: the identity of a scenario whose to_dict leaves
    # the key out (as it did at its then default)
    to_dict = Scenario.to_dict
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(
            Scenario, "to_dict", lambda sc: {k: v for k, v in to_dict(sc).items() if k != "step_trigger"}
        )
        then = spec.identity
    assert meta[b"biped.sweep_id"].decode() == spec.identity == then
    pq.write_table(table.replace_schema_metadata(meta), out)
    assert load(out).scenario.step_trigger == "capture"
    now = SweepSpec(axes=GRID, base=SweepSpec().base.with_overrides(stepping=True))
    with pytest.raises(ScenarioError, match=r"scenario key step_trigger: 'capture' in the file, 'qp' now"):
        run_sweep(now, out, workers=1, trial_fn=toy_trial, progress=False)

    def never(setup):
        raise AssertionError(f"trial {setup.trial.index} ran again: the old rows were not reused")

    run_sweep(spec, out, workers=1, trial_fn=never, progress=False)
    assert sorted(load(out).column("index").tolist()) == list(range(8))
