"""SIGINT and SIGTERM held while the push loop runs, delivered between its steps.

A Ctrl-C or SIGTERM raises ``KeyboardInterrupt`` wherever Python happens to be. Inside a call of
numba's dispatcher (the compiled loop, :mod:`biped.sim.fused`) that exception can be caught and
misreported by numba's own Python code (seen: ``TypeError: _get_wrapper_address() missing 1
required positional argument: 'sig'`` instead of the interrupt), so a stopped ``biped push``
exited 1 without writing what it had computed. :class:`HeldSignals` holds the signal while the
loop runs and hands it, at a point the loop chooses (between two compiled calls), to the handler
it would have met: the CLI's (SIGTERM as an interrupt, docs/cli.md) or Python's
``KeyboardInterrupt`` for SIGINT. Outside the main thread (where Python cannot handle signals)
it does nothing.
"""

from __future__ import annotations

import signal
import threading
from types import FrameType

__all__ = ["HeldSignals"]

#: The signals held.
SIGNALS = (signal.SIGINT, signal.SIGTERM)


class HeldSignals:
    """``with HeldSignals() as held: ... held.deliver() ...``: a signal that arrives inside the
    block waits for :meth:`deliver` (or the block's end) and then goes to the previous handler."""

    def __init__(self) -> None:
        self.pending: int | None = None
        self._frame: FrameType | None = None
        self._previous: dict[int, object] = {}

    def __enter__(self) -> HeldSignals:
        if threading.current_thread() is threading.main_thread():
            for s in SIGNALS:
                self._previous[s] = signal.signal(s, self._hold)
        return self

    def _hold(self, signum: int, frame: FrameType | None) -> None:
        if self.pending is None:
            self.pending, self._frame = signum, frame

    def deliver(self) -> None:
        """Hand a held signal to its previous handler now (which may raise KeyboardInterrupt);
        the handlers are restored first, so a second signal meets them directly."""
        if self.pending is None:
            return
        signum, frame = self.pending, self._frame
        self.pending = self._frame = None
        handler = self._previous.get(signum, signal.SIG_DFL)
        self._restore()
        if callable(handler):
            handler(signum, frame)
        elif handler in (signal.SIG_DFL, None):
            signal.raise_signal(signum)

    def _restore(self) -> None:
        for s, h in self._previous.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)  # type: ignore[arg-type]
        self._previous = {}

    def __exit__(self, *exc: object) -> None:
        if exc[0] is None:
            self.deliver()
        self._restore()
