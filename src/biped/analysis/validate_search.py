"""The searches of :func:`biped.analysis.validate.run_experiment`: the log bisection and the
one-step lean's staircase, their trials run one at a time or, with a ``pool`` (a
:class:`concurrent.futures.Executor`, ``biped validate --jobs 2``), the next trial the search may
need started beside the one it waits for. A started trial the search turns out not to need is
dropped, never recorded: the trials, their order and the threshold are the same either way."""

from __future__ import annotations

import time
from collections.abc import Callable
from concurrent.futures import Executor, Future, wait
from typing import Any

__all__ = ["STAIRCASE_HALVINGS", "Trials", "bisect", "staircase"]

#: The staircase's bisection between the last magnitude that passed and the first that failed:
#: at most this many halvings (1/16 of a 1 deg step).
STAIRCASE_HALVINGS = 4
#: How often a search waiting on a pool's trial says so [s of wall time].
WAITING_EVERY_S = 10.0


class Trials:
    """The trials of one search: ``run(m)`` runs (or takes the started) trial at ``m`` and records
    it (``progress`` called with it); ``start(m)``, with a pool, starts it without waiting;
    ``drop()`` forgets the started trials the search did not take."""

    def __init__(self, trial: Callable, pool: Executor | None, progress=None, waiting=None, stop=None):
        self.trial, self.pool, self.progress, self.waiting = trial, pool, progress, waiting
        self.stop = stop  # a threading.Event: set, a wait ends in KeyboardInterrupt (the pool is gone)
        self.taken: list = []
        self.started: dict[float, Future] = {}
        self.dropped = 0  # started, never taken (their CPU spent for nothing)

    def start(self, m: float) -> None:
        if self.pool is not None and m not in self.started:
            self.started[m] = self.pool.submit(self.trial, m)

    def run(self, m: float):
        if self.pool is None:
            t = self.trial(m)
        else:
            self.start(m)
            f = self.started.pop(m)
            t0 = said = time.perf_counter()
            while not wait([f], timeout=1.0).done:
                if self.stop is not None and self.stop.is_set():
                    raise KeyboardInterrupt
                now = time.perf_counter()
                if self.waiting is not None and f.running() and now - said >= WAITING_EVERY_S:
                    self.waiting(m, now - t0)  # (not while it is queued behind others)
                    said = now
            t = f.result()
        self.taken.append(t)
        if self.progress is not None:
            self.progress(t)
        return t

    def drop(self, keep: float | None = None) -> None:
        for m in [m for m in self.started if m != keep]:
            f = self.started.pop(m)
            if not f.cancel():  # running: its result is never read
                self.dropped += 1


def bisect(trials: Trials, bracket, halvings: int, mid) -> tuple[float, Any]:
    """``halvings`` of ``bracket`` = (the magnitude that passed, the one that failed, the trial that
    passed) at ``mid(lo, hi)``: (the largest magnitude that passed, its trial). With a pool the
    next midpoint on the passing side is started beside each one."""
    lo, hi, best = bracket
    for i in range(halvings):
        m = mid(lo, hi)
        trials.start(m)  # queued before the guess
        if i + 1 < halvings:
            trials.start(mid(m, hi))  # the next one if m passes
        t = trials.run(m)
        if t.passed:
            lo, best = m, t
        else:
            hi = m
        trials.drop(keep=mid(lo, hi))
    trials.drop()
    return lo, best


def staircase(trials: Trials, lo: float, hi: float, step: float, halvings: int, mid):
    """The magnitude raised from ``lo`` by ``step`` until a trial fails (the next step started
    beside each with a pool), then ``halvings`` of the last step: (bound, value, trial) with
    bound ">" when every step to ``hi`` passed, "<" when ``lo`` failed."""
    best = None
    k = 0
    while (m := lo + k * step) <= hi + 1e-9:
        trials.start(m)  # queued before the next step
        if lo + (k + 1) * step <= hi + 1e-9:
            trials.start(lo + (k + 1) * step)
        t = trials.run(m)
        if not t.passed:
            break
        best, k = t, k + 1
    else:
        assert best is not None  # lo <= hi: the loop ran
        return ">", best.magnitude, best
    trials.drop()
    if best is None:
        return "<", lo, None
    value, at = bisect(trials, (best.magnitude, m, best), halvings, mid)
    return "", value, at
