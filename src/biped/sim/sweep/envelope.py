"""``biped envelope``: per direction, the largest push survived, by an adaptive search.

Each direction runs :func:`biped.sim.sweep.search.search` (bracket, bisection, check trials) on a
lattice of sizes: the values ``--min``, ``--min + --resolution``, ... up to ``--max`` of one
magnitude axis (the block's ``speed_m_s``, or ``magnitude``, the size of another perturbation
paradigm in its own unit: force N, platform m, release deg; the search knows only indices). The
lattice times the directions is an ordinary :class:`SweepSpec` grid:
every trial the search asks for is a trial of that grid, with its key, run by the sweep's trial
function and stored as a row of the same Parquet file (:mod:`.store`: lock, part files written
as each trial finishes, one consolidated file holding the trials that ran). So an interrupted
envelope resumes (its trials are found by key and not rerun: the search is deterministic and
asks for them again), a full grid sweep of the same lattice into the same file extends it, and
an envelope on a finished grid file runs no trial at all.

Directions run side by side (one trial in flight per direction, on local worker processes, in
this process, or on Dask); a direction's own search is sequential.
"""

from __future__ import annotations

import math
import os
import time
from collections import deque
from collections.abc import Callable, Generator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from biped.errors import ScenarioError
from biped.sim.sweep import store
from biped.sim.sweep.cluster import stream as stream_dask
from biped.sim.sweep.pool import LocalPool
from biped.sim.sweep.record import row_survived
from biped.sim.sweep.runner import (
    check_run_args,
    default_trial_fn,
    default_workers,
    execute_trial,
    sigterm_raises,
)
from biped.sim.sweep.search import SearchResult, search
from biped.sim.sweep.spec import AXES, SweepSpec, Trial

__all__ = ["DirectionResult", "EnvelopeRun", "Lattice", "lattice", "paradigm_lattice", "run_envelope"]

#: Magnitude axes an envelope can search along.
MAGNITUDE_AXES = ("speed_m_s", "magnitude")


@dataclass(frozen=True)
class Lattice:
    """A paradigm's search: its axis, unit, default step and top, and the largest size its
    scenario checks accept (``--max`` above it is refused before any work)."""

    axis: str
    unit: str
    resolution: float
    max: float
    limit: float
    limit_why: str


def paradigm_lattice(perturbation: str) -> Lattice:
    """The :class:`Lattice` of ``perturbation`` (``block``, ``force``, ``platform``, ``release``,
    ``pull``; docs/envelope.md): force 10 N to 1000 N (the pulse's ``force_duration_s``, 0.15 s by
    default: up to 150 N s, six times W's block limit); platform 0.01 m to the floor's 1 m;
    release 0.5 deg to 14.5 deg (what W's friction 0.3 holds in every direction: 14.5 deg sideways,
    15.2 deg forward and backward; a larger lean's trial is a row with friction's error, counted
    as not survived); pull 5 mm to 0.5 m of the motor's travel (at ``pull_velocity_m_s``)."""
    from biped.sim.perturbations.platform import MAX_DISPLACEMENT_M

    table = {
        "block": Lattice("speed_m_s", "m/s", 0.25, 24.0, math.inf, ""),
        "force": Lattice("magnitude", "N", 10.0, 1000.0, 1e5, "force_n is at most 1e5 N"),
        "platform": Lattice(
            "magnitude",
            "m",
            0.01,
            1.0,
            MAX_DISPLACEMENT_M,
            f"the feet stay on the platform: at most {MAX_DISPLACEMENT_M:g} m",
        ),  # fmt: skip
        "release": Lattice("magnitude", "deg", 0.5, 14.5, 45.0, "release_lean_deg is at most 45 deg"),
        "pull": Lattice("magnitude", "m", 0.005, 0.5, 2.0, "pull_displacement_m is at most 2 m long"),
    }
    if perturbation not in table:
        raise ScenarioError(f"perturbation must be one of {', '.join(table)}; got {perturbation!r}")
    return table[perturbation]


def lattice(lo: float, hi: float, resolution: float) -> tuple[float, ...]:
    """The sizes ``lo, lo + resolution, ..., hi`` (``hi - lo`` a multiple of ``resolution``
    within 1e-9), as ``numpy.linspace`` gives them, so they are the values (and trial keys) of
    ``biped sweep --speed lo:hi:num``."""
    for name, v in (("--resolution", resolution), ("--min", lo), ("--max", hi)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ScenarioError(f"{name} must be a number > 0; got {v!r}")
    if hi < lo:
        raise ScenarioError(f"--max ({hi:g}) must be >= --min ({lo:g})")
    steps = (hi - lo) / resolution
    if abs(steps - round(steps)) > 1e-9 * max(1.0, steps):
        raise ScenarioError(
            f"--max - --min ({hi:g} - {lo:g}) must be a whole number of --resolution steps ({resolution:g})"
        )
    num = round(steps) + 1
    if num > 100_000:
        raise ScenarioError(f"the lattice would have {num} sizes; at most 100000 (a coarser --resolution)")
    return tuple(float(x) for x in np.linspace(lo, hi, num))


@dataclass(frozen=True)
class DirectionResult:
    """One direction's search: its :class:`SearchResult` on the lattice and the sizes it means.

    limit: the largest size survived with every tried size below it survived (NaN: the smallest
    failed); first_fail: the smallest size that failed (NaN: none did, the limit is >= the
    largest); first_limit: the limit before a failing check trial (== limit when monotone);
    rows: {size: row} of the trials this direction used; complete: its search finished (False if
    a trial was lost twice to a dead worker).
    """

    direction_deg: float
    limit: float
    first_fail: float
    first_limit: float
    non_monotone: bool
    check_failures: int
    n_checks: int
    n_trials: int
    rows: dict
    complete: bool
    search: SearchResult | None


@dataclass(frozen=True)
class EnvelopeRun:
    """What :func:`run_envelope` did: per direction its :class:`DirectionResult`; the lattice;
    trials run now and reused from the file; wall time; the backend."""

    path: Path
    axis: str
    criterion: str
    sizes: tuple
    directions: tuple
    ran: int
    reused: int
    lost: int
    wall_time_s: float
    backend: str
    spec: SweepSpec

    @property
    def complete(self) -> bool:
        return all(d.complete for d in self.directions)


class _Direction:
    """One direction's search in progress."""

    def __init__(self, direction: float, n: int, start: int | None, checks: int, pre: tuple = ()):
        self.direction = direction
        self.pre = list(pre)  # grid sizes run before the search (``biped sweep --refine``)
        self.n, self.checks = n, checks
        self.result: SearchResult | None = None
        self.next_search: int | None = None
        self.gen: Generator[int, bool, SearchResult]
        if not pre:
            self.gen = search(n, start=start, checks=checks)
            self.next_search = next(self.gen)
        self.rows: dict[int, dict] = {}
        self.in_flight = False
        self.losses: dict[int, int] = {}
        self.abandoned = False

    @property
    def want(self) -> int | None:
        return self.pre[0] if self.pre else self.next_search

    def tell(self, index: int, row: dict, criterion: str) -> None:
        self.rows[index] = row
        if self.pre and index == self.pre[0]:
            self.pre.pop(0)
            if not self.pre:  # the grid is done: bisect between its last survivor and first failure
                ok = {i: row_survived(r, criterion) for i, r in self.rows.items()}
                hi = min((i for i, v in ok.items() if not v), default=self.n)
                lo = max((i for i, v in ok.items() if v and i < hi), default=-1)
                self.gen = search(self.n, checks=self.checks, bracket=(lo, hi))
                self._next()
            return
        self._next(row_survived(row, criterion))

    def _next(self, answer: bool | None = None) -> None:
        try:
            self.next_search = next(self.gen) if answer is None else self.gen.send(answer)
        except StopIteration as stop:
            self.next_search, self.result = None, stop.value


def run_envelope(
    spec: SweepSpec,
    out: str | os.PathLike,
    *,
    axis: str = "speed_m_s",
    checks: int = 3,
    start: float | None = None,
    criterion: str = "survived",
    workers: int | None = None,
    scheduler: Any = None,
    trial_fn: Callable | None = None,
    progress: Callable[[int, int], None] | None = None,
    overwrite: bool = False,
    grid: tuple = (),
) -> EnvelopeRun:
    """Search every direction of ``spec`` along ``axis`` (``spec``'s grid: the lattice of sizes on
    ``axis``, the directions on ``direction_deg``, one value on every other axis; see
    :func:`lattice`) and store every trial in ``out`` (see the module docstring).

    checks: check trials below each limit; start: the first size tried (default the lattice's
    middle; the nearest lattice size); criterion: ``"survived"`` or ``"recovered"`` (as
    :func:`biped.analysis.survived`); workers / scheduler / trial_fn / overwrite: as
    :func:`biped.sim.sweep.run_sweep`; ``progress(done, running)`` after every row; ``grid``:
    sizes (on the lattice) every direction runs first, whatever the search needs (``biped sweep
    --refine``: the coarse grid, then the bisection between its last survivor and first failure,
    which reuses the grid's trials).
    """
    t0 = time.perf_counter()
    if axis not in MAGNITUDE_AXES:
        raise ScenarioError(f"envelope axis must be one of {', '.join(MAGNITUDE_AXES)}; got {axis!r}")
    if criterion not in ("survived", "recovered"):
        raise ScenarioError(f"criterion must be 'survived' or 'recovered'; got {criterion!r}")
    if not isinstance(checks, int) or isinstance(checks, bool) or not 0 <= checks <= 20:
        raise ScenarioError(f"--checks must be an integer from 0 to 20; got {checks!r}")
    if spec.samples is not None:
        raise ScenarioError("an envelope searches a grid; samples are not used")
    axes = dict(spec.axes)
    for name in AXES:
        if name not in (axis, "direction_deg") and len(axes[name]) != 1:
            raise ScenarioError(f"an envelope takes one value of {name}; got {len(axes[name])}")
    sizes = tuple(sorted(axes[axis]))
    pre = []
    for v in sorted(grid):
        i = int(np.argmin(np.abs(np.asarray(sizes) - float(v))))
        if abs(sizes[i] - float(v)) > 1e-9 * max(1.0, abs(float(v))):
            raise ScenarioError(f"grid size {v:g} is not on the lattice of {axis}")
        pre.append(i)
    dirs = tuple(sorted(set(axes["direction_deg"])))
    start_i = None
    if start is not None:
        start_i = int(np.argmin(np.abs(np.asarray(sizes) - float(start))))
    out = check_run_args(out, workers=workers, scheduler=scheduler)
    if trial_fn is None:
        trial_fn = default_trial_fn(spec)
    trials = spec.trials()
    by_point: dict[tuple[float, float], Trial] = {(t.direction_deg, getattr(t, axis)): t for t in trials}
    out.parent.mkdir(parents=True, exist_ok=True)
    with store.SweepLock(out), sigterm_raises():
        if overwrite:
            store.remove_sweep(out)
        else:
            store.check_same_sweep(spec, out)
        table, _ = store.read_rows(out)
        known = {r["trial_key"]: r for r in table.to_pylist() if r["error"] is None}
        store.write_manifest(spec, out)
        writer = store.PartWriter(store.parts_dir(out))
        searches = [_Direction(d, len(sizes), start_i, checks, tuple(pre)) for d in dirs]
        ran_keys: set[str] = set()
        keyed: dict[str, tuple[_Direction, int]] = {}
        queue: deque[tuple[_Direction, int]] = deque()
        counts = {"ran": 0, "reused": 0, "lost": 0}

        def advance(s: _Direction) -> None:
            """Answer ``s``'s wants from stored rows; queue the first it still needs."""
            while s.want is not None and not s.in_flight and not s.abandoned:
                trial = by_point[(s.direction, sizes[s.want])]
                row = known.get(trial.key)
                if row is None:
                    keyed[trial.key] = (s, s.want)
                    queue.append((s, s.want))
                    s.in_flight = True
                    return
                counts["reused"] += trial.key not in ran_keys
                s.tell(s.want, row, criterion)

        def record(rows: list[dict]) -> None:
            writer.write(rows)  # on disk first
            for row in rows:
                s, i = keyed.pop(row["trial_key"])
                counts["ran"] += 1
                if row["error"] is None:
                    known[row["trial_key"]] = row
                    ran_keys.add(row["trial_key"])
                s.in_flight = False
                s.tell(i, row, criterion)
                advance(s)
            if progress is not None:
                progress(counts["ran"], sum(x.in_flight for x in searches))

        def lost(setups: list) -> None:
            for setup in setups:
                s, i = keyed[setup.trial.key]
                s.losses[i] = s.losses.get(i, 0) + 1
                counts["lost"] += 1
                if s.losses[i] >= 2:  # lost twice: leave this direction unfinished
                    s.abandoned, s.in_flight = True, False
                    keyed.pop(setup.trial.key)
                else:
                    queue.append((s, i))

        def next_setup():
            if not queue:
                return None
            s, i = queue.popleft()
            return spec.setup(by_point[(s.direction, sizes[i])])

        for s in searches:
            advance(s)
        n_workers = workers or default_workers()
        try:
            if not queue:
                backend = "none"
            elif scheduler is not None:
                backend = "dask"
                stream_dask(scheduler, trial_fn, next_setup, record, lost)
            elif n_workers == 1:
                backend = "serial"
                while (setup := next_setup()) is not None:
                    record([execute_trial(trial_fn, setup)])
            else:
                n = min(n_workers, len(dirs))
                backend = f"processes:{n}"
                LocalPool(n, trial_fn).stream(next_setup, record, lost)
        finally:
            writer.close()
        store.consolidate(spec, out, trials)
    results = tuple(_direction_result(s, sizes) for s in searches)
    return EnvelopeRun(
        path=out,
        axis=axis,
        criterion=criterion,
        sizes=sizes,
        directions=results,
        ran=counts["ran"],
        reused=counts["reused"],
        lost=counts["lost"],
        wall_time_s=time.perf_counter() - t0,
        backend=backend,
        spec=spec,
    )


def _direction_result(s: _Direction, sizes: tuple) -> DirectionResult:
    r = s.result
    rows = {sizes[i]: row for i, row in sorted(s.rows.items())}
    if r is None:
        nan = float("nan")
        return DirectionResult(s.direction, nan, nan, nan, False, 0, 0, len(rows), rows, False, None)

    def size(i: int) -> float:
        return float(sizes[i]) if 0 <= i < len(sizes) else float("nan")

    return DirectionResult(
        direction_deg=s.direction,
        limit=size(r.limit),
        first_fail=size(r.first_fail),
        first_limit=size(r.first_limit),
        non_monotone=r.non_monotone,
        check_failures=r.check_failures,
        n_checks=r.n_checks,
        n_trials=len(rows),
        rows=rows,
        complete=True,
        search=r,
    )
