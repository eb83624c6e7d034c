"""Progress counters that suit where they are shown: a tqdm bar on a terminal, whole lines in a
log file or a pipe.

A tqdm bar redraws itself with carriage returns; written to a file (``biped sweep ... 2> log``, a
batch system, CI) it becomes one huge line. :func:`progress_bar` returns a tqdm bar when the stream
is a terminal and otherwise a :class:`LineProgress`, which prints ``desc: n/total unit (elapsed)``
as a whole line at the start (with tqdm's ``delay``, not before that many seconds), every
``every_s`` seconds (default 1) and at the end (unless ``line_at_close=False``).

>>> import io
>>> out = io.StringIO()
>>> bar = progress_bar(total=4, desc="figures", unit="figure", file=out)
>>> for _ in range(4):
...     bar.update(1)
>>> bar.close()
>>> print(out.getvalue().splitlines()[-1].split(" (")[0])
figures: 4/4 figure
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO

__all__ = ["LineProgress", "is_terminal", "progress_bar", "track"]


def is_terminal(stream: Any) -> bool:
    """Whether ``stream`` is an interactive terminal."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # closed or not a file
        return False


class LineProgress:
    """A tqdm-like counter (``update``, ``n``, ``total``, ``set_postfix``, ``close``) that writes
    whole lines: at the first update (the first after ``delay`` seconds, tqdm's meaning), then at
    most every ``every_s`` seconds, and when closed (unless ``at_close`` is false, or nothing was
    said and ``delay`` has not passed)."""

    def __init__(
        self,
        total: float | None,
        desc: str,
        unit: str = "it",
        *,
        file: TextIO | None = None,
        initial: float = 0,
        every_s: float = 1.0,
        fmt: str = "{:g}",
        delay: float = 0.0,
        at_close: bool = True,
    ):
        self.total, self.desc, self.unit = total, desc, unit
        self.n = initial
        self.file = file
        self.every_s = every_s
        self.fmt = fmt
        self.delay, self.at_close = delay, at_close
        self._postfix = ""
        self._t0 = time.perf_counter()
        self._last: float | None = None
        self._said: float | None = None
        self._closed = False

    def _line(self) -> str:
        n = self.fmt.format(self.n)
        total = f"/{self.fmt.format(self.total)}" if self.total is not None else ""
        post = f", {self._postfix}" if self._postfix else ""
        return f"{self.desc}: {n}{total} {self.unit} ({time.perf_counter() - self._t0:.1f} s{post})"

    def _say(self) -> None:
        print(self._line(), file=self.file if self.file is not None else sys.stderr, flush=True)
        self._last = time.perf_counter()
        self._said = self.n

    def _quiet_start(self) -> bool:
        """Nothing said yet and ``delay`` not over."""
        return self._last is None and time.perf_counter() - self._t0 < self.delay

    def update(self, k: float = 1) -> None:
        self.n += k
        if self._quiet_start():
            return
        if self._last is None or time.perf_counter() - self._last >= self.every_s:
            self._say()

    def set_postfix(self, **kw: Any) -> None:
        self._postfix = ", ".join(f"{k}={v}" for k, v in kw.items())

    def set_postfix_str(self, text: str) -> None:
        self._postfix = text

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            if self.at_close and self._said != self.n and not self._quiet_start():
                self._say()


class _Silent:
    """The counter of a quiet command: counts, says nothing."""

    def __init__(self):
        self.n: float = 0

    def update(self, k: float = 1) -> None:
        self.n += k

    def set_postfix(self, **kw: Any) -> None:
        pass

    def set_postfix_str(self, text: str) -> None:
        pass

    def close(self) -> None:
        pass


def progress_bar(
    total: float | None,
    desc: str,
    unit: str = "it",
    *,
    file: TextIO | None = None,
    line_format: str = "{:g}",
    line_at_close: bool = True,
    **tqdm_kwargs: Any,
):
    """A tqdm bar on ``file`` (default ``sys.stderr``) when it is a terminal, else a
    :class:`LineProgress` (``line_format`` formats its counts, e.g. ``"{:.2f}"``; ``line_at_close``
    false: no line when it is closed); nothing at all with ``disable=True``.
    ``tqdm_kwargs`` (``initial``, ``bar_format``, ``leave``, ``delay``...) go to tqdm; of them the
    line counter takes ``initial`` and ``delay``."""
    stream = file if file is not None else sys.stderr
    if tqdm_kwargs.get("disable"):
        return _Silent()
    if is_terminal(stream):
        from tqdm import tqdm

        return tqdm(total=total, desc=desc, unit=unit, file=stream, **tqdm_kwargs)
    return LineProgress(
        total,
        desc,
        unit,
        file=file,
        initial=tqdm_kwargs.get("initial", 0),
        fmt=line_format,
        delay=tqdm_kwargs.get("delay", 0.0),
        at_close=line_at_close,
    )


def track(iterable, total: int, desc: str, unit: str = "it"):
    """``iterable`` with a counter: a tqdm bar on a terminal, whole lines otherwise."""
    if is_terminal(sys.stderr):
        from tqdm import tqdm

        yield from tqdm(iterable, total=total, desc=desc, unit=unit)
        return
    bar = LineProgress(total, desc, unit)
    try:
        for item in iterable:
            yield item
            bar.update(1)
    finally:
        bar.close()
