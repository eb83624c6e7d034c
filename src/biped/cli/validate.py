"""``biped validate``: the human balance experiments on the biped, ideal and young nervous
systems side by side, thresholds against people's (:mod:`biped.analysis.validate`;
docs/validate.md). Writes validation.json, validation.md, figures/<experiment>.png and
trials.parquet."""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from biped.cli._common import add_folder_options, keeps_mujoco_log, run_dir

#: Bisection halvings after the bracket: --quick, full.
QUICK_ITERATIONS, FULL_ITERATIONS = 3, 9


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "validate",
        help="run the human balance experiments (lean releases, platform, waist pull) and compare",
        description="Run the human balance experiments of docs/validate.md with neuromotor = ideal "
        "and young, find each threshold by bisection and compare it with the human mean +/- 2 SD.",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help=f"coarse: {QUICK_ITERATIONS} bisection steps, the one-step lean's staircase in 8 deg steps with no "
        "halving (a smoke run; ~50 s of CPU, <= 60 s on an idle 2-core machine)",
    )
    p.add_argument(
        "--neuromotor",
        action="append",
        choices=("ideal", "young", "older"),
        help="the presets to run (repeatable; default: ideal and young)",
    )
    p.add_argument(
        "--experiment",
        action="append",
        metavar="NAME",
        help="run only these experiments (repeatable): ankle_release, platform_backward, step_release, waist_pull",
    )
    p.add_argument(
        "--jobs",
        type=int,
        choices=(1, 2),
        default=None,
        help="1: one trial at a time; 2 (default with 2 or more cores): the next trial a search may need "
        "runs beside the one it waits for, in a second process (the same trials and thresholds)",
    )
    add_folder_options(p, "a new runs/validate-<date>-<time>")
    p.set_defaults(func=run, _parser=p)


@keeps_mujoco_log
def run(args) -> int:

    from biped.analysis.validate import EXPERIMENTS, run_experiment
    from biped.errors import ScenarioError, unknown_name
    from biped.outputs.validate import write_validation

    names = args.experiment or list(EXPERIMENTS)
    for n in names:
        if n not in EXPERIMENTS:
            raise ScenarioError(unknown_name("experiment", n, EXPERIMENTS))
    presets = list(dict.fromkeys(args.neuromotor or ["ideal", "young"]))
    out = run_dir(args.out, "validate", overwrite=args.overwrite)
    from biped.sim.mjlog import count_warnings, route_to, summary

    route_to(out / "mujoco.log")  # MuJoCo's warnings (a diverging trial's), as biped push does
    warned_before = count_warnings(out / "mujoco.log")
    iterations = QUICK_ITERATIONS if args.quick else FULL_ITERATIONS
    jobs = args.jobs or min(2, os.cpu_count() or 1)
    t0, cpu0 = time.perf_counter(), time.process_time()
    results: dict = {}
    interrupted = False
    running: _Running | None = None
    pool = _pool(jobs)
    pool_cpu0 = _children_cpu_s()
    # the trials run in the pool's processes: SIGTERM stops this one as Ctrl-C does (simulate's own
    # handling is the running trial's, in the other process)
    term = signal.signal(signal.SIGTERM, _interrupt) if pool is not None else None
    searches = None if pool is None else ThreadPoolExecutor(len(names) * len(presets))
    stop = threading.Event()  # set: the searches' threads stop waiting on the pool
    started: dict = {}

    def search(name: str, preset: str, running=None):
        return run_experiment(
            EXPERIMENTS[name],
            preset,
            iterations,
            progress=_said(name, preset, running),
            running=running,
            quick=args.quick,
            pool=pool,
            waiting=_waiting(name, preset, EXPERIMENTS[name].unit),
            stop=stop,
        )

    try:
        if searches is not None:  # every search at once, their trials queued in the pool: the
            # one-step lean's (the longest) first
            for name, preset in sorted(((a, b) for a in names for b in presets), key=_longest_first):
                started[name, preset] = searches.submit(search, name, preset)
        for name in names:
            per: dict = {}
            results[name] = per
            for preset in presets:
                if searches is not None:
                    th = started[name, preset].result()
                else:
                    running = _Running(name, preset, EXPERIMENTS[name].unit)
                    th = search(name, preset, running)
                per[preset] = th
                print(
                    f"  {name:<18} {preset:<6} threshold {th.bound}{th.value:.4g} {th.unit} ({len(th.trials)} trials)"
                )
    except KeyboardInterrupt:  # Ctrl-C / SIGTERM: write the finished thresholds, then stop
        if running is not None:
            running.close()
        interrupted = True
        for (name, preset), done in started.items():  # searches finished behind the one waited on
            if done.done() and not done.cancelled() and done.exception() is None:
                results.setdefault(name, {})[preset] = done.result()
        results = {k: v for k, v in results.items() if v}
    finally:
        if pool is not None:
            signal.signal(signal.SIGTERM, term)
            stop.set()
            _close(pool, interrupted)
        if searches is not None:
            searches.shutdown(wait=True, cancel_futures=True)
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    cpu_pool = _children_cpu_s() - pool_cpu0  # the pool's processes, ended above
    note = (
        "Each threshold is the largest magnitude the biped survived (bisection on a log scale; '<' "
        "below the searched range, '>' above it); the one-step lean's, the largest lean recovered "
        "(Wojcik's success: no fall in a 7 s run, at most one step, still at the end) with every lean "
        "below it recovered (raised 1 deg at a time from 2 deg until one failed, then bisected). "
        "Presets: biped.control.neuromotor, "
        "docs/validate.md."
    )
    n = sum(len(th.trials) for per in results.values() for th in per.values())
    trials_cpu = sum(t.cpu_time_s for per in results.values() for th in per.values() for t in th.trials)
    meta = {"mode": "quick" if args.quick else "full", "iterations": iterations, "presets": presets,
            "trials": n, "wall_time_s": wall, "note": note, "interrupted": interrupted, "jobs": jobs,
            "trials_cpu_s": trials_cpu, "main_cpu_s": cpu, "pool_cpu_s": cpu_pool,
            "trials_dropped": sum(th.dropped for per in results.values() for th in per.values())}  # fmt: skip
    if results:
        write_validation(out, results, meta)
    said = summary(out / "mujoco.log", warned_before)
    if said:
        print(said, file=sys.stderr)
    if interrupted:
        raise KeyboardInterrupt
    print(
        f"  wrote {out}/validation.md, validation.json, trials.parquet, figures/ ({n} trials, {wall:.1f} s; "
        f"{trials_cpu:.1f} s of CPU in the trials taken, {cpu + cpu_pool:.1f} s in all, {jobs} job(s))"
    )
    return 0


def _longest_first(task: tuple[str, str]) -> tuple[int, int]:
    """The order the searches queue their trials: the one-step lean's first, the young's and the
    older's (their trials the longest) before the ideal's."""
    name, preset = task
    return (0 if name == "step_release" else 1, 1 if preset == "ideal" else 0)


def _pool(jobs: int):
    """Two processes (forked: the parent has run no simulation; the numba kernels warmed first, so
    the children inherit them compiled; forked at once, before the searches' threads start) for
    ``jobs`` 2, else None (one trial at a time, here)."""
    if jobs < 2:
        return None
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from biped.sim.jit import announce_and_warm, kernels_for

    announce_and_warm(kernels_for("workspace", "qp"))
    method = "fork" if "fork" in multiprocessing.get_all_start_methods() else None
    pool = ProcessPoolExecutor(
        jobs, mp_context=multiprocessing.get_context(method), initializer=_quiet_worker
    )
    pool.submit(int).result()  # forks every worker now (the fork context starts them all at once)
    return pool


def _quiet_worker() -> None:
    """A pool's process ignores Ctrl-C (the terminal sends it to every process of the group: this
    one stops the workers; ``_close`` kills them) and dies of SIGTERM without a traceback."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _children_cpu_s() -> float:
    """The CPU time [s] of this process's ended children (the pool's, once shut down)."""
    import resource

    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def _close(pool, interrupted: bool) -> None:
    """Shut ``pool`` down; after Ctrl-C / SIGTERM its running trials are stopped too."""
    if interrupted:
        for p in list(getattr(pool, "_processes", {}).values()):
            p.kill()  # their trials are dropped: nothing of theirs to keep
    pool.shutdown(wait=not interrupted, cancel_futures=True)


def _waiting(name: str, preset: str, unit: str):
    """With a pool, a line on stderr every 10 s a trial runs (its simulated time is the other
    process's)."""

    def waiting(magnitude: float, wall: float) -> None:
        print(f"    {name} {preset}: {magnitude:.4g} {unit}: running ({wall:.0f} s)", file=sys.stderr)

    return waiting


#: A running trial says nothing for its first second, then its simulated time every second.
RUNNING_DELAY_S = 1.0


class _Running:
    """A running trial's simulated time on stderr (a young trial may run 10-25 s): a tqdm bar on a
    terminal, gone when the trial ends, else a line a second (``biped._progress``); nothing for a
    trial that ends within :data:`RUNNING_DELAY_S`."""

    def __init__(self, name: str, preset: str, unit: str):
        self.name, self.preset, self.unit = name, preset, unit
        self.bar: Any = None

    def __call__(self, magnitude: float, t: float, duration: float) -> None:
        if self.bar is None:
            from biped._progress import progress_bar

            self.bar = progress_bar(
                total=duration,
                desc=f"    {self.name} {self.preset}: {magnitude:.4g} {self.unit}",
                unit="s simulated",
                line_format="{:.2f}",
                line_at_close=False,
                delay=RUNNING_DELAY_S,
                leave=False,
                bar_format="{desc}: {n:.2f}/{total:.2f} s simulated [{elapsed}]",
            )
        self.bar.update(t - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def _said(name: str, preset: str, running: _Running | None = None):
    """Each trial's line on stderr as it ends (a trial may take seconds: the user sees it work)."""
    from biped.analysis.validate import EXPERIMENTS, ONE_STEP, RECOVERED

    def said(t) -> None:
        if running is not None:
            running.close()
        what = "survived" if t.survived else (t.outcome or "fell")  # fell, diverged or error
        criterion = EXPERIMENTS[t.experiment].criterion
        if t.survived and criterion == RECOVERED:
            what = "recovered" if t.recovered else "stood, not recovered"
        elif t.survived and criterion == ONE_STEP:
            what = f"{t.steps} step{'' if t.steps == 1 else 's'}, " + ("still" if t.still else "still moving")
        print(
            f"    {name} {preset}: {t.magnitude:.4g} {t.unit} {what} ({t.wall_time_s:.1f} s)", file=sys.stderr
        )

    return said
