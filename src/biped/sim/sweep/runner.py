"""Running a sweep: every trial that ``out`` does not hold yet, in this process, on local worker
processes or on a Dask cluster, each finished trial on disk at once.

The runner knows nothing of MuJoCo or of pushes: it calls ``trial_fn(setup) -> {column: value}``
(default: :func:`biped.sim.sweep.trial.run_trial`) and stores rows (:mod:`.store`).

Interruptions: Ctrl-C and SIGTERM stop the workers, keep every finished trial (in
``<out>.parts/``) and raise (:class:`KeyboardInterrupt`, :class:`Terminated`); SIGKILL of the
parent loses only the trials in flight, and its workers die with it. Run the same command again
to finish: done trials are skipped.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from biped import files
from biped.errors import ScenarioError
from biped.sim.sweep import store
from biped.sim.sweep.cluster import SCHEDULER_TIMEOUT_S, check_scheduler, connect_scheduler, run_chunks
from biped.sim.sweep.pool import LocalPool
from biped.sim.sweep.record import MEASURED, Measured
from biped.sim.sweep.spec import SweepSpec, TrialSetup


class Terminated(KeyboardInterrupt):
    """The sweep's process received SIGTERM; finished trials were kept."""


def execute_trial(trial_fn: Callable[[TrialSetup], Any], setup: TrialSetup) -> dict:
    """Run one trial and return its row. ``trial_fn`` returns a :class:`Measured` or a mapping of
    some of its columns (:data:`MEASURED`; the others stay empty). An exception of the trial
    becomes the row's ``error`` (``"ExceptionType: message"``) with the measured columns empty;
    it is never lost. (KeyboardInterrupt and SystemExit are not trial errors: they propagate.)"""
    t0 = time.perf_counter()
    trial = setup.trial
    row: dict[str, Any] = {
        "trial_key": trial.key,
        "index": trial.index,
        **trial.params(),
        "controller": setup.scenario.controller,
        "torque_limits": setup.torque_limits,
    }
    try:
        result = trial_fn(setup)
        measured = result.row() if isinstance(result, Measured) else dict(result)
        unknown = set(measured) - set(MEASURED)
        if unknown:
            raise ScenarioError(
                f"trial function returned unknown columns {sorted(unknown)}; valid: {', '.join(MEASURED)}"
            )
        row.update(measured)
        row["error"] = None
    except Exception as exc:  # noqa: BLE001 - a crashed trial is a result, recorded with its error
        row["error"] = f"{type(exc).__name__}: {exc}"
    row["wall_time_s"] = time.perf_counter() - t0
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return row


def default_trial_fn(spec: SweepSpec) -> Callable[[TrialSetup], Any]:
    """The trial a sweep runs when none is given: the push simulation of W's structure
    (:func:`biped.sim.sweep.trial.run_trial`), or on a robot (``spec.robot``)
    :func:`biped.sim.robot_trial.run_robot_trial`; imported only when used."""
    if spec.robot:
        from biped.sim.robot_trial import run_robot_trial

        return run_robot_trial
    from biped.sim.sweep.trial import run_trial

    return run_trial


@dataclass(frozen=True)
class SweepSummary:
    """What :func:`run_sweep` did.

    path: the consolidated Parquet file (written only when ``complete``).
    total: trials in the sweep; skipped: already done before this run; ran: finished in this run;
    failed: trials of this run that raised (recorded with their error); lost: trials whose
    worker died (not recorded: rerun the same command to finish them); complete: every trial
    has a row; wall_time_s: this run's wall time.
    """

    path: Path
    total: int
    skipped: int
    ran: int
    failed: int
    lost: int
    complete: bool
    wall_time_s: float
    backend: str


def default_workers() -> int:
    """Usable local cores (the process's CPU affinity where the OS tells it)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def check_setups(spec: SweepSpec) -> None:
    """Build the scenario of every extreme trial of ``spec`` (each axis's smallest and largest
    value, every direction of a grid, the quarter turns within a sampled direction range), so that
    a value out of a scenario's range (``--mass 1000``, ``--speed 500``) is refused before any
    lock, manifest or trial exists. The checks are monotonic in each axis but the direction, so
    the extremes stand for every trial."""
    import itertools

    from biped.sim.sweep.spec import AXES, Trial

    values = dict(spec.axes)
    cand: dict[str, list[float]] = {n: sorted({min(values[n]), max(values[n])}) for n in AXES}
    dirs = sorted(set(values["direction_deg"]))
    if spec.samples is None and len(dirs) <= 360:
        cand["direction_deg"] = dirs
    else:
        lo, hi = min(dirs), max(dirs)
        quarter = [q for q in range(-720, 721, 90) if lo <= q <= hi]
        cand["direction_deg"] = sorted({lo, hi, *map(float, quarter)})
    names = list(AXES)
    for combo in itertools.product(*(cand[n] for n in names)):
        params = dict(zip(names, combo, strict=True))
        try:
            spec.setup(Trial(index=0, key="check", **params))
        except ScenarioError as exc:
            shown = ", ".join(f"{n} = {v:g}" for n, v in params.items())
            raise ScenarioError(f"the sweep's trial with {shown} is not a valid push: {exc}") from None


def max_local_workers() -> int:
    """The most local worker processes a sweep accepts: twice the cores (at least 4). Each worker
    is a process holding MuJoCo, numba and the compiled controller; more than the cores only
    queues them, and an unbounded count (``--workers 100000``) would start one process per chunk."""
    return max(4, 2 * (os.cpu_count() or 1))


def check_run_args(
    out: str | os.PathLike, *, workers: int | None = None, batch: int = 1, scheduler: Any = None
) -> Path:
    """The checks :func:`run_sweep` makes before any work (one-line :class:`ScenarioError`s);
    returns ``out`` as a Path. A scheduler address must answer within
    :data:`SCHEDULER_TIMEOUT_S`."""
    out = Path(out)
    if str(out) in ("", "."):
        raise ScenarioError("--out is an empty path; name a .parquet file")
    files.check_no_link(out, "--out")
    files.check_no_link(store.lock_path(out), "the lock file")
    store.check_parts_dir(store.parts_dir(out))
    if out.suffix != ".parquet":
        raise ScenarioError(f"--out must name a .parquet file; got {str(out)!r}")
    if out.is_dir():
        raise ScenarioError(f"--out {str(out)!r} is a folder; name a .parquet file")
    limit = max_local_workers()
    if workers is not None and (
        not isinstance(workers, int) or isinstance(workers, bool) or not 1 <= workers <= limit
    ):
        raise ScenarioError(
            f"workers must be an integer from 1 to {limit} (one process each, ~0.2 GB; this machine "
            f"has {os.cpu_count() or 1} cores; for more use a Dask scheduler); got {workers!r}"
        )
    if not isinstance(batch, int) or isinstance(batch, bool) or batch < 1:
        raise ScenarioError(f"batch must be an integer >= 1; got {batch!r}")
    parent = next((p for p in (out.parent, *out.parent.parents) if p.exists()), Path("."))
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise ScenarioError(f"cannot write --out {str(out)!r}: {str(parent)!r} is not a writable folder")
    if isinstance(scheduler, str):
        check_scheduler(scheduler)
    return out


@contextlib.contextmanager
def sigterm_raises() -> Iterator[None]:
    """Within: SIGTERM raises :class:`Terminated` in the main thread (so ``finally`` blocks run),
    and a KeyboardInterrupt that ends the block after a SIGTERM (a trial that turned the first
    into its own) leaves it as :class:`Terminated` too."""
    state = {"terminated": False}
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: Any) -> None:
        state["terminated"] = True
        raise Terminated

    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    except KeyboardInterrupt:
        if state["terminated"]:
            raise Terminated from None
        raise
    finally:
        signal.signal(signal.SIGTERM, old)


def run_sweep(
    spec: SweepSpec,
    out: str | os.PathLike,
    *,
    workers: int | None = None,
    scheduler: Any = None,
    trial_fn: Callable[[TrialSetup], Any] | None = None,
    progress: bool = True,
    retry_failed: bool = False,
    overwrite: bool = False,
    batch: int = 1,
) -> SweepSummary:
    """Run every trial of ``spec`` that ``out`` does not hold yet; write ONE Parquet file.

    workers: local processes (default: every usable core); 1 runs in this process.
    scheduler: a Dask scheduler address (``"tcp://host:8786"``) or a ``dask.distributed.Client``;
        when given, trials run on that cluster instead (every worker needs ``biped`` installed).
    trial_fn: ``f(setup: TrialSetup) -> Measured | {column: value}`` (columns of
        :data:`MEASURED`); default :func:`biped.sim.sweep.trial.run_trial` (the push
        simulation, then its measurements). It must be importable by name (a module-level
        function) for processes and Dask.
    retry_failed: rerun trials recorded with an error.
    overwrite: replace an ``out`` (and its parts) that holds a different sweep; without it a
        different sweep is refused, naming the difference (a grid that extends it is not
        different: its new trials are added).
    batch: trials per task (more amortises the task overhead on a remote cluster).

    A second sweep on the same ``out`` is refused while this one runs. Ctrl-C or SIGTERM keep
    every finished trial (they raise KeyboardInterrupt / :class:`Terminated`).
    """
    t_start = time.perf_counter()
    out = check_run_args(out, workers=workers, batch=batch, scheduler=scheduler)
    check_setups(spec)
    if trial_fn is None:
        trial_fn = default_trial_fn(spec)
    trials = spec.trials()
    own_client = None
    if isinstance(scheduler, str):  # connected before anything exists on disk
        scheduler = own_client = connect_scheduler(scheduler)
    try:
        made_parent = not out.parent.exists()
        try:
            out.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ScenarioError(
                f"cannot create the folder of --out {str(out)!r}: {exc.strerror or exc}"
            ) from None
        try:
            with store.SweepLock(out), sigterm_raises():
                return _run_locked(
                    spec,
                    out,
                    trials,
                    trial_fn,
                    workers,
                    scheduler,
                    progress,
                    retry_failed,
                    overwrite,
                    batch,
                    t_start,
                )
        except ScenarioError:
            if made_parent:
                with contextlib.suppress(OSError):
                    out.parent.rmdir()  # a rejected sweep leaves no empty folder behind
            raise
    finally:
        if own_client is not None:
            own_client.close()


def _run_locked(
    spec: SweepSpec,
    out: Path,
    trials: tuple,
    trial_fn: Callable,
    workers: int | None,
    scheduler: Any,
    progress: bool,
    retry_failed: bool,
    overwrite: bool,
    batch: int,
    t_start: float,
) -> SweepSummary:
    store.remove_stale_temps(out)
    if overwrite:
        store.remove_sweep(out)
    else:
        store.check_same_sweep(spec, out)
    table, _ = store.read_rows(out)
    done = dict(zip(table.column("trial_key").to_pylist(), table.column("error").to_pylist(), strict=True))
    wanted = {t.key for t in trials}
    todo = [t for t in trials if t.key not in done or (retry_failed and done[t.key] is not None)]
    skipped = len(trials) - len(todo)
    failed_before = sum(1 for k, e in done.items() if k in wanted and e is not None and not retry_failed)
    if todo:
        store.write_manifest(spec, out)
    writer = store.PartWriter(store.parts_dir(out))
    bar = None
    if progress:
        from biped._progress import progress_bar  # a bar on a terminal, whole lines otherwise

        bar = progress_bar(total=len(trials), desc="sweep", unit="trial", initial=skipped, smoothing=0.05)
        bar.set_postfix(failed=failed_before)
    counts = {"ran": 0, "failed": 0}

    def record(rows: list[dict]) -> None:
        if not rows:
            return
        writer.write(rows)  # on disk before anything else happens
        counts["ran"] += len(rows)
        counts["failed"] += sum(r["error"] is not None for r in rows)
        if bar is not None:
            bar.update(len(rows))
            bar.set_postfix(failed=failed_before + counts["failed"])

    chunks = [todo[i : i + batch] for i in range(0, len(todo), batch)]
    n_workers = workers or default_workers()
    lost = 0
    try:
        if not chunks:
            backend = "none"
        elif scheduler is not None:
            backend = "dask"
            lost = run_chunks(scheduler, trial_fn, spec, chunks, record)
        elif n_workers == 1 or len(todo) == 1:
            backend = "serial"
            for t in todo:
                record([execute_trial(trial_fn, spec.setup(t))])
        else:
            n = min(n_workers, len(chunks))
            backend = f"processes:{n}"
            lost = LocalPool(n, trial_fn).run(chunks, record, prepare=spec.setup)
    finally:
        writer.close()
        if bar is not None:
            bar.close()
    complete = lost == 0
    if complete:
        if progress:
            import sys

            print(f"sweep: writing {len(trials)} trials into {out} ...", file=sys.stderr, flush=True)
        store.consolidate(spec, out, trials)
    return SweepSummary(
        path=out,
        total=len(trials),
        skipped=skipped,
        ran=counts["ran"],
        failed=counts["failed"],
        lost=lost,
        complete=complete,
        wall_time_s=time.perf_counter() - t_start,
        backend=backend,
    )


__all__ = [
    "SCHEDULER_TIMEOUT_S",
    "SweepSummary",
    "Terminated",
    "check_run_args",
    "check_scheduler",
    "check_setups",
    "connect_scheduler",
    "default_workers",
    "execute_trial",
    "run_sweep",
    "sigterm_raises",
]
