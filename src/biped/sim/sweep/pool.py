"""Local worker processes that start once and run trials until told to stop.

Each worker is a fresh interpreter (``sys.executable``, the parent's ``sys.path``), started once
per sweep; it keeps whatever the trial function caches (compiled scenes, controllers, numba code)
for every trial it runs. Parent and worker talk over two pipes with length-prefixed pickles: the
parent sends a chunk of :class:`~biped.sim.sweep.spec.TrialSetup`, the worker answers one row per
trial as soon as it is done. No ``multiprocessing``: no shared semaphores, no resource tracker.

A worker dies with its parent: ``prctl(PR_SET_PDEATHSIG, SIGKILL)`` on Linux, elsewhere a thread
that watches ``getppid()``. It ignores SIGINT (Ctrl-C in a terminal reaches the whole process
group: the parent decides) and writes nothing else on its result pipe (``print`` in a trial goes
to stderr).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import pickle
import selectors
import signal
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any, BinaryIO

_LEN = struct.Struct("<Q")
_PR_SET_PDEATHSIG = 1
_BOOT = (
    "import sys, pickle, struct; f = sys.stdin.buffer; "
    "n = struct.unpack('<Q', f.read(8))[0]; sys.path[:] = pickle.loads(f.read(n)); "
    "from biped.sim.sweep.pool import worker_main; worker_main(int(sys.argv[1]))"
)


def _frame(obj: Any) -> bytes:
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    return _LEN.pack(len(data)) + data


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view) :]


def _read_frame(f: BinaryIO) -> Any:
    head = f.read(_LEN.size)
    if len(head) < _LEN.size:
        return None
    (n,) = _LEN.unpack(head)
    data = f.read(n)
    if len(data) < n:
        return None
    return pickle.loads(data)


def _die_with_parent(parent_pid: int) -> None:
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        ok = libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):  # not Linux
        ok = False
    if not ok:

        def watch() -> None:
            while os.getppid() == parent_pid:
                time.sleep(0.5)
            os._exit(1)

        threading.Thread(target=watch, daemon=True).start()
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(1)


def worker_main(parent_pid: int) -> None:
    """The loop of one worker process (started by :class:`LocalPool`)."""
    from biped.sim.sweep.runner import execute_trial

    _die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    out = os.dup(1)
    os.dup2(2, 1)  # stray prints go to stderr, never into the result pipe
    inp = sys.stdin.buffer
    trial_fn = _read_frame(inp)
    while True:
        setups = _read_frame(inp)
        if setups is None:  # the parent closed the pipe: done; every row is written (unbuffered)
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(0)  # no interpreter teardown: it took ~1-4 s with numba and MuJoCo loaded
        for setup in setups:
            _write_all(out, _frame(execute_trial(trial_fn, setup)))


class _Worker:
    def __init__(self, trial_fn: Callable) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _BOOT, str(os.getpid())],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            bufsize=0,
            close_fds=True,
        )
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.stdin, self.stdout = self.proc.stdin, self.proc.stdout
        self.fd = self.stdout.fileno()
        self.buf = b""
        self.remaining = 0  # rows still due for the chunk it runs
        self.send(sys.path)
        self.send(trial_fn)

    def send(self, obj: Any) -> None:
        _write_all(self.stdin.fileno(), _frame(obj))

    def rows(self, data: bytes) -> list[dict]:
        """Complete rows in what has arrived so far."""
        self.buf += data
        out = []
        while len(self.buf) >= _LEN.size:
            (n,) = _LEN.unpack_from(self.buf)
            if len(self.buf) < _LEN.size + n:
                break
            out.append(pickle.loads(self.buf[_LEN.size : _LEN.size + n]))
            self.buf = self.buf[_LEN.size + n :]
        return out

    def kill(self) -> list[dict]:
        """Kill it; return the rows it had finished and written but not yet delivered."""
        with contextlib.suppress(ProcessLookupError):
            self.proc.kill()
        rows = []
        with contextlib.suppress(OSError, ValueError):
            while data := os.read(self.fd, 1 << 16):
                rows += self.rows(data)
        self.close()
        return rows

    def close(self) -> None:
        for f in (self.stdin, self.stdout):
            with contextlib.suppress(OSError, ValueError):
                f.close()
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


class LocalPool:
    """``workers`` local processes running ``trial_fn`` (importable by name: a module-level
    function) on chunks of trial setups. :meth:`run` calls ``record(rows)`` as rows arrive and
    returns the number of trials lost to workers that died (a dead worker is replaced, up to
    ``4 * workers`` times, for the chunks still to run)."""

    def __init__(self, workers: int, trial_fn: Callable) -> None:
        self.trial_fn = trial_fn
        self.workers: list[_Worker] = []
        self.respawns = 4 * workers
        self.n = workers
        self.prepare: Callable[[Any], Any] | None = None

    def run(
        self,
        chunks: Sequence[Sequence[Any]],
        record: Callable[[list[dict]], None],
        prepare: Callable[[Any], Any] | None = None,
    ) -> int:
        """``prepare(item)``, when given, makes each item of a chunk its trial setup as the chunk
        is sent (a sweep's 1000 scenarios are not built before the first worker starts)."""
        self.prepare = prepare
        todo = list(reversed(chunks))
        lost = 0
        with self._session(record) as sel:
            for _ in range(min(self.n, len(todo))):
                self._assign(self._spawn(sel), todo.pop())
            while sel.get_map():
                for key, _ in sel.select():
                    w: _Worker = key.data
                    rows = self._read(sel, w)
                    if rows is not None:
                        w.remaining -= len(rows)
                        if w.remaining == 0 and todo:  # its next work first, then the bookkeeping
                            self._assign(w, todo.pop())
                        if rows:
                            record(rows)
                        if w.remaining == 0:
                            self._retire(sel, w)
                        continue
                    lost += w.remaining  # the worker died
                    if todo and (self.respawns > 0 or not self.workers):
                        if self.respawns > 0:
                            self.respawns -= 1
                            self._assign(self._spawn(sel), todo.pop())
                        else:
                            lost += sum(len(c) for c in todo)
                            todo.clear()
        return lost

    def stream(
        self,
        next_setup: Callable[[], Any],
        record: Callable[[list[dict]], None],
        lost: Callable[[list[Any]], None],
    ) -> None:
        """Adaptive work (``biped envelope``): whenever a worker is free, ``next_setup()`` gives
        the next trial setup, or None when there is none now (the next may depend on a row still
        running). Rows go to ``record(rows)`` as they arrive; the setups of a worker that died go to
        ``lost(setups)`` (a fresh worker takes the work that follows, up to ``4 * workers`` times).
        Returns when no trial runs and ``next_setup()`` has nothing."""
        idle: list[_Worker] = []
        running: dict[_Worker, list] = {}
        with self._session(record) as sel:
            while True:
                while idle or len(self.workers) < self.n:
                    setup = next_setup()
                    if setup is None:
                        break
                    if idle:
                        w = idle.pop()
                    elif self.respawns >= 0:
                        w = self._spawn(sel)
                    else:
                        lost([setup])
                        continue
                    self._assign(w, [setup])
                    running[w] = [setup]
                if not running:
                    return
                for key, _ in sel.select():
                    w = key.data
                    rows = self._read(sel, w)
                    if rows is not None:
                        if rows:
                            w.remaining -= len(rows)
                            record(rows)
                        if w.remaining == 0:
                            running.pop(w, None)
                            idle.append(w)
                        continue
                    self.respawns -= 1  # the worker died
                    gone = running.pop(w, [])
                    if gone:
                        lost(gone)

    @contextlib.contextmanager
    def _session(self, record: Callable[[list[dict]], None]) -> Iterator[selectors.BaseSelector]:
        """The selector of one :meth:`run` or :meth:`stream`; at its end (done, or interrupted:
        Ctrl-C, SIGTERM) every worker is stopped and what it finished is recorded."""
        sel = selectors.DefaultSelector()
        try:
            yield sel
        finally:
            for w in self.workers:
                record(w.kill())
            self.workers.clear()
            sel.close()

    def _spawn(self, sel: selectors.BaseSelector) -> _Worker:
        w = _Worker(self.trial_fn)
        self.workers.append(w)
        sel.register(w.fd, selectors.EVENT_READ, w)
        return w

    def _read(self, sel: selectors.BaseSelector, w: _Worker) -> list[dict] | None:
        """The rows complete in what ``w`` sent; None when it died (then it is retired)."""
        data = os.read(w.fd, 1 << 16)
        if data:
            return w.rows(data)
        self._retire(sel, w)  # end of file: the worker died
        return None

    def _retire(self, sel: selectors.BaseSelector, w: _Worker) -> None:
        sel.unregister(w.fd)
        self.workers.remove(w)
        w.close()

    def _assign(self, w: _Worker, chunk: Sequence[Any]) -> None:
        w.remaining = len(chunk)
        w.send([self.prepare(x) for x in chunk] if self.prepare is not None else list(chunk))


__all__ = ["LocalPool", "worker_main"]
