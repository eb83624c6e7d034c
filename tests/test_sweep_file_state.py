"""A property of the sweep's files (hypothesis): whatever sequence of starts, interrupts (SIGINT,
SIGTERM, SIGKILL after k finished trials), reruns, changed grids, overwrites and concurrent
starts on one ``--out``, no finished trial is ever lost or duplicated, and no file outside the
output's own names is touched.

Each run is a forked child of this process running :func:`run_sweep` with a pure-Python trial
(no physics, no interpreter start-up), so a sequence of runs takes a second or two; the number
of examples is bounded to keep the test near 30 s. "Finished" means on disk: the rows of the
output file and its part files, read by this process between the steps. A trial the child
logged but was killed before writing is not finished (it is run again)."""

from __future__ import annotations

import json
import os
import signal
import time
import traceback
from pathlib import Path

import pyarrow.parquet as pq
from _helpers import toy_trial
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from biped.sim.sweep import SweepSpec, run_sweep
from biped.sim.sweep.store import part_files, parts_dir, read_part

#: A, a grid that extends it, and one that does not (refused while A's or B's trials are there).
GRIDS = {
    "A": {"speed_m_s": (1.0, 3.0), "direction_deg": (0.0, 90.0)},
    "B": {"speed_m_s": (1.0, 3.0, 5.0), "direction_deg": (0.0, 90.0)},
    "C": {"speed_m_s": (2.0,), "direction_deg": (0.0, 90.0)},
}
SENTINELS = {"notes.txt": b"mine", "s.parquet.bak": b"an old copy", "s.csv": b"a,b\n"}
LOG = "trials.log"


def quick_trial(setup) -> dict:
    time.sleep(0.03)
    with open(os.environ["BIPED_TEST_TRIALS_LOG"], "a") as f:
        f.write(f"{setup.trial.key}\n")
    return toy_trial(setup)


def _child(out: Path, grid: str, overwrite: bool, crash: Path) -> int:
    """Fork: the child runs the sweep and exits with its status (never returns into pytest).

    SIGINT and SIGTERM are blocked across the fork: a signal the test sends at once would
    otherwise reach the child before its ``try`` and raise KeyboardInterrupt in a copy of the
    pytest worker, which then reports an interrupt to xdist as if it were the worker."""
    stop = {signal.SIGINT, signal.SIGTERM}
    signal.pthread_sigmask(signal.SIG_BLOCK, stop)
    pid = os.fork()
    if pid:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, stop)
        return pid
    code = 99
    try:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, stop)
        s = run_sweep(
            SweepSpec(axes=GRIDS[grid]),
            out,
            workers=1,
            trial_fn=quick_trial,
            progress=False,
            overwrite=overwrite,
        )
        code = 0 if s.complete else 1
    except KeyboardInterrupt as exc:
        code = 143 if type(exc).__name__ == "Terminated" else 130
    except Exception as exc:  # noqa: BLE001
        from biped.errors import BipedError

        if isinstance(exc, BipedError):
            code = 2
        else:
            crash.write_text(traceback.format_exc())
    finally:
        os._exit(code)


def _logged(folder: Path) -> int:
    log = folder / LOG
    return len(log.read_text().splitlines()) if log.exists() else 0


def _keys_on_disk(out: Path) -> tuple[list[str], list[str]]:
    """Trial keys in ``out`` and in its parts (duplicates kept)."""
    in_out = pq.read_table(out).column("trial_key").to_pylist() if out.exists() else []
    in_parts = []
    for p in part_files(parts_dir(out)):
        in_parts += read_part(p).column("trial_key").to_pylist()
    return in_out, in_parts


def _stored_speeds(out: Path) -> list[float] | None:
    """The speeds of the sweep ``out`` or its unfinished parts hold (None: no sweep there)."""
    manifest = parts_dir(out) / "sweep.json"
    if manifest.exists():
        return json.loads(manifest.read_text())["sweep"]["grid"]["speed_m_s"]
    if out.exists():
        return json.loads(pq.read_schema(out).metadata[b"biped.sweep"])["grid"]["speed_m_s"]
    return None


step = st.tuples(
    st.sampled_from(["run", "run", "overwrite", "concurrent"]),
    st.sampled_from(list(GRIDS)),
    st.sampled_from([None, signal.SIGINT, signal.SIGTERM, signal.SIGKILL]),
    st.integers(min_value=0, max_value=4),  # signal after this many trials were logged
)


@settings(
    max_examples=8,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(steps=st.lists(step, min_size=1, max_size=4))
def test_no_finished_trial_is_lost_or_duplicated_and_no_other_file_is_touched(
    tmp_path_factory, monkeypatch, steps
):
    folder = tmp_path_factory.mktemp("state")
    monkeypatch.setenv("BIPED_TEST_TRIALS_LOG", str(folder / LOG))
    out, crash = folder / "s.parquet", folder / "crash.txt"
    for name, data in SENTINELS.items():
        (folder / name).write_bytes(data)
    finished: set[str] = set()
    for kind, grid, sig, after in steps:
        n0 = _logged(folder)
        pids = [_child(out, grid, kind == "overwrite", crash)]
        if kind == "concurrent":
            pids.append(_child(out, "B" if grid == "A" else "A", False, crash))
        if sig is not None:
            t0 = time.monotonic()
            while _logged(folder) < n0 + after and time.monotonic() - t0 < 10:
                if os.waitpid(pids[0], os.WNOHANG) != (0, 0):
                    pids[0] = -1
                    break
                time.sleep(0.005)
            if pids[0] > 0:
                os.kill(pids[0], sig)
        statuses = []
        for pid in pids:
            if pid > 0:
                _, status = os.waitpid(pid, 0)
                statuses.append(os.waitstatus_to_exitcode(status))
        assert not crash.exists(), crash.read_text()
        # -SIGTERM: sent before run_sweep took the signal over (as a kill)
        assert all(s in (0, 2, 130, 143, -signal.SIGKILL, -signal.SIGTERM) for s in statuses), statuses
        in_out, in_parts = _keys_on_disk(out)
        assert len(in_out) == len(set(in_out)) and len(in_parts) == len(set(in_parts)), "duplicated"
        now = set(in_out) | set(in_parts)
        if kind == "overwrite":
            finished = now  # the previous sweep was discarded on purpose
        assert finished <= now, f"lost {len(finished - now)} finished trials after {kind} {grid} {sig}"
        finished = now
        own = {"s.parquet", "s.parquet.lock", "s.parquet.parts", LOG, *SENTINELS}
        stray = {p.name for p in folder.iterdir()} - own
        assert not {n for n in stray if not n.startswith(".s.")}, stray  # only our own temporaries
        assert all((folder / n).read_bytes() == d for n, d in SENTINELS.items())
    # finishing: the sweep on disk (B if it is A's or there is none) runs to its end with every
    # finished trial in it, once
    grid = "C" if _stored_speeds(out) == [2.0] else "B"
    pid = _child(out, grid, False, crash)
    code = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
    assert not crash.exists(), crash.read_text()
    assert code == 0
    keys = pq.read_table(out).column("trial_key").to_pylist()
    assert len(keys) == len(set(keys)) == len(SweepSpec(axes=GRIDS[grid]).trials())
    assert finished <= set(keys)
    assert not parts_dir(out).exists() and not any(p.name.startswith(".s.") for p in folder.iterdir())
