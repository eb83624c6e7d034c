"""The limit along one direction: bracket, then bisection, then check trials below the limit.

Pure Python, no MuJoCo: the search runs on the indices ``0 .. n-1`` of a lattice of sizes
(speeds, or any magnitude axis) in increasing order and asks an oracle "survived?" one index at
a time. It is a generator (:func:`search`): it yields the index it wants tried and is sent the
answer, so a driver can run many directions side by side (:mod:`biped.sim.sweep.envelope`).

Method (docs/envelope.md):

1. **Bracket**: try ``start``; from a survivor go up, from a failure go down, in steps that double
   (first step ``max(1, n // 8)``), until a survivor lies below a failure (or an end of the
   lattice is reached: everything up to the largest size survived, or the smallest failed).
2. **Bisection** between the largest survivor ``lo`` and the smallest failure ``hi`` until they
   are neighbours (one lattice step apart: the resolution).
3. **Checks**: ``checks`` trials below ``lo`` at distances that double, 2, 4, 8, ... lattice
   steps (``lo - 2**j``, j = 1..checks; sizes already tried are not tried again), where a fall
   inside the envelope is most likely: near its edge, where the push is marginal. If one fails,
   survival is not monotone: the lowest failure becomes ``hi``, the bisection runs again below
   it, and the new limit gets its own checks. The reported limit is therefore never above a
   failure that was seen: the optimistic first limit is kept only as ``first_limit`` beside the
   flag.
"""

from __future__ import annotations

from collections.abc import Generator
from dataclasses import dataclass, field

__all__ = ["SearchResult", "search"]


@dataclass(frozen=True)
class SearchResult:
    """The outcome of one :func:`search` on lattice indices.

    limit: the largest index below which (and at which) every tried size survived, -1 if the
        smallest failed; first_fail: the smallest index that failed (``n`` if none did: the limit
        is then at least the largest size); non_monotone: a check trial below the first limit
        failed; first_limit: the limit the bisection found before any check failed (== limit when
        monotone); check_failures: how many check trials failed; tried: {index: survived} in the
        order tried; n_checks: check trials run.
    """

    n: int
    limit: int
    first_fail: int
    non_monotone: bool
    first_limit: int
    check_failures: int
    n_checks: int
    tried: dict = field(default_factory=dict)


def search(
    n: int, *, start: int | None = None, checks: int = 3, bracket: tuple[int, int] | None = None
) -> Generator[int, bool, SearchResult]:
    """Find the survival limit on lattice indices ``0 .. n-1`` (see the module docstring).

    Drive it with ``i = next(gen)``, then ``i = gen.send(survived)`` until it raises
    ``StopIteration`` whose ``value`` is the :class:`SearchResult`. ``start``: the first index
    tried (default the middle); ``checks``: check trials below each limit (0: none);
    ``bracket``: ``(lo, hi)`` known already (a survivor, -1 for none, and a failure, ``n`` for
    none: ``biped sweep --refine`` takes them from its grid), which skips the bracket phase.
    """
    if not isinstance(n, int) or n < 1:
        raise ValueError(f"the lattice needs at least one size; got n = {n!r}")
    if not isinstance(checks, int) or checks < 0:
        raise ValueError(f"checks must be an integer >= 0; got {checks!r}")
    start = n // 2 if start is None else min(max(int(start), 0), n - 1)
    tried: dict[int, bool] = {}

    def probe(i: int) -> Generator[int, bool, bool]:
        if i not in tried:
            tried[i] = bool((yield i))
        return tried[i]

    lo, hi = -1, n  # largest survivor, smallest failure (n: none tried fails)
    # 1. bracket
    step = max(1, n // 8)
    i = start
    if bracket is not None:
        lo, hi = bracket
        if not -1 <= lo < hi <= n:
            raise ValueError(f"bracket must be -1 <= lo < hi <= n = {n}; got {bracket!r}")
    elif (yield from probe(i)):
        lo = i
        while lo < n - 1:
            j = min(n - 1, lo + step)
            if (yield from probe(j)):
                lo = j
                step *= 2
            else:
                hi = j
                break
    else:
        hi = i
        while hi > 0:
            j = max(0, hi - step)
            if (yield from probe(j)):
                lo = j
                break
            hi = j
            step *= 2
    first_limit = None
    check_failures = n_checks = 0
    while True:
        # 2. bisection
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if (yield from probe(mid)):
                lo = mid
            else:
                hi = mid
        if first_limit is None:
            first_limit = lo
        # 3. checks below the limit
        failed = None
        for j in range(1, checks + 1):
            c = lo - 2**j
            if c < 0:
                break
            if c in tried:
                continue
            n_checks += 1
            if not (yield from probe(c)):
                check_failures += 1
                failed = c  # the lowest failing check (they run from the top down)
        if failed is None:
            break
        hi = failed
        lo = max((k for k, ok in tried.items() if ok and k < failed), default=-1)
    return SearchResult(
        n=n,
        limit=lo,
        first_fail=hi,
        non_monotone=check_failures > 0,
        first_limit=first_limit,
        check_failures=check_failures,
        n_checks=n_checks,
        tried=dict(tried),
    )
