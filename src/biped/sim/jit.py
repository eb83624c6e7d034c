"""First-run cost of the compiled kernels: know when numba's cache is cold, compile ahead, say so.

W's controller is one numba kernel (:func:`biped.control.recursions.compute_kernel`); the contact
monitor's classification is another (:func:`biped.sim.contact._contact_bits`), the push loop's
hot path a third (:func:`biped.sim.fused._run_rows`, which calls the controller's). numba compiles
them on first use (~15 s for the controller on a 2-core x86_64 machine) and keeps the machine
code on disk (see :mod:`biped._numba_cache` for where), so every later process loads it in well
under a second. :func:`cold_kernels` tells, before anything compiles, which kernels have no
cached code for this machine and these sources; :func:`warm_up` compiles them, telling the user
first. ``biped push`` and ``biped sweep`` call it before they start (the sweep before its worker
processes start, so that they all load the cache instead of each compiling).

Usage (the answer depends on this machine's cache, so not a doctest)::

    from biped.sim.jit import cold_kernels, warm_up
    cold_kernels()            # [] once compiled on this machine
    warm_up(log=print)        # prints "compiling ..." only when something is cold

Chosen over compiling at install (a wheel or editable install runs no package code, and the
machine code is tied to the CPU that runs it) and at ``import biped`` (which would charge ~15 s
to every user of :mod:`biped.planar` or :mod:`biped.kinematic`, which do not use these kernels).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from biped._numba_cache import is_cached, mark_said, measured_compile_s, record_compile_s

__all__ = [
    "KERNELS",
    "announce_and_warm",
    "cold_kernels",
    "estimate_s",
    "is_cached",
    "kernels_for",
    "warm_up",
]

#: Kernel names for :func:`cold_kernels` / :func:`warm_up`: what they are and about how long
#: they take to compile [s] on an idle 2-core x86_64 machine (several times that under load),
#: measured 2026-11-25 on a fresh cache: ``biped push`` (controller, loop, contact) 92-101 s,
#: a stepping sweep (controller 49 s, contact 1 s, response 8 s); the loop is the rest. The
#: loop has grown the perturbations', the nervous system's and the response's rows.
KERNELS = {
    "controller": ("W's controller", 49),
    "qp": ("the contact QP", 5),
    "contact": ("the contact monitor", 1),
    "loop": ("the compiled push loop", 47),
    "response": ("the sweep's margin of stability", 8),
    "swing": ("the stepping swing law", 3),  # biped.control.swing_kernel, swing_period (2-4 s, load 0-5)
}

#: Kernels found compiled or cached in this process (no need to look again).
_WARM: set[str] = set()


def kernels_for(
    controller: str,
    distribution: str = "statics",
    *,
    sweep: bool = False,
    robot: bool = False,
    stepping: bool = False,
) -> tuple[str, ...]:
    """The kernels a push run with ``controller`` (``"workspace"`` or ``"joint-pd"``) and the
    workspace controller's ``distribution`` uses; ``sweep``: and a sweep row's response
    (:mod:`biped.sim.mos`). Every run goes through the compiled push loop
    (:func:`biped.sim.push.run_closed_loop`), the joint PD's, the QP's and a stepping one's too
    (whose swings call the controller's and the QP's kernels from Python); a ``robot`` trial
    (:func:`biped.sim.robot.robot_push`), which measures no response, goes through its own
    Python loop. ``stepping``: and W's swing law (:mod:`biped.control.swing_kernel`), which a
    stepping run's swings call (not a robot's)."""
    calls = ("controller", "qp") if distribution == "qp" else ("controller",)
    if robot:  # (a robot's swing is its own law: biped.control.swing_task)
        return calls
    if stepping and controller == "workspace":
        calls = (*calls, "swing")
    more = ("response",) if sweep else ()
    if controller != "workspace":
        return ("loop", "contact", *more)  # the joint PD runs in the compiled loop
    return (*calls, "loop", "contact", *more)  # the loop calls the controller's kernel (and the QP's part)


def _dispatcher(name: str):
    if name == "controller":
        from biped.control.recursions import compute_kernel

        return compute_kernel
    if name == "contact":
        from biped.sim.contact import _contact_bits

        return _contact_bits
    if name == "qp":  # the controller's QP call: one compiled call with daqp's C function, else the build
        from biped.control.daqp_c import daqp_c

        if daqp_c() is not None:
            from biped.control.qp_call import qp_kernel

            return qp_kernel
        from biped.control.distribution import qp_build

        return qp_build
    if name == "loop":
        from biped.sim.fused import _run_rows

        return _run_rows
    if name == "response":
        from biped.sim.mos import _margins

        return _margins
    if name == "swing":
        from biped.control.swing_kernel import swing_law

        return swing_law
    raise ValueError(f"unknown kernel {name!r}; valid: {', '.join(KERNELS)}")


def cold_kernels(names=tuple(KERNELS)) -> list[str]:
    """The kernels of ``names`` that would compile on first use (not cached, or cannot tell)."""
    cold = []
    for n in names:
        if n in _WARM:
            continue
        if is_cached(_dispatcher(n)):
            _WARM.add(n)
        else:
            cold.append(n)
    return cold


def estimate_s(names) -> tuple[float, bool]:
    """(seconds, measured): the time the kernels ``names`` take to compile, measured on this
    machine when each was compiled here before (``measured`` True), else the :data:`KERNELS`
    estimates."""
    measured = [measured_compile_s(n) for n in names]
    if names and all(m is not None for m in measured):
        return float(sum(m for m in measured if m is not None)), True
    return float(sum(KERNELS[n][1] for n in names)), False


class _Ticker:
    """While kernels compile: the elapsed time, every second on a terminal (one line redrawn),
    else a line every 1.5 s (a fresh clone's first run is never silent for 2 s)."""

    def __init__(self, stream, what: str, estimate: float):
        self.stream, self.what, self.estimate = stream, what, estimate
        self.tty = bool(getattr(stream, "isatty", lambda: False)())
        self.stage = ""
        self._stop = threading.Event()
        self._t0 = time.perf_counter()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _line(self) -> str:
        t = time.perf_counter() - self._t0
        if t <= self.estimate:
            return f"  compiling{self.stage}: {t:.0f} s of ~{self.estimate:.0f} s"
        return (
            f"  compiling{self.stage}: {t:.0f} s (over the ~{self.estimate:.0f} s estimate: a busy machine)"
        )

    def _run(self) -> None:
        period = 1.0 if self.tty else 1.5
        while not self._stop.wait(period):
            if self.tty:
                self.stream.write("\r" + self._line() + "   ")
            else:
                self.stream.write(self._line() + "\n")
            self.stream.flush()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()
        end = f"  compiled in {time.perf_counter() - self._t0:.0f} s"
        self.stream.write(("\r" + end + " " * 30 + "\n") if self.tty else end + "\n")
        self.stream.flush()


def _compile(name: str) -> None:
    """Run the kernel once on real inputs (what compiles it, and stores it in the cache)."""
    import numpy as np

    if name == "contact":
        from biped.sim.contact import compile_kernel

        compile_kernel()
        return
    if name == "loop":
        import biped.control.daqp_stub  # noqa: F401 - the loop's placeholder C function (compiles on import)
        from biped.sim.fused import compile_kernel as compile_loop

        compile_loop()
        return
    if name == "swing":
        from biped.control.swing_kernel import compile_law
        from biped.control.swing_period import compile_plan

        compile_law()
        compile_plan()
        return
    if name == "response":
        from biped.sim.mos import margins

        n = 3
        feet = np.zeros((n, 2, 4))
        feet[..., 0] = 1.0
        corners = [np.array([[x, y, 0.0] for x in (-0.1, 0.1) for y in (-0.05, 0.05)])] * 2
        margins(np.zeros((n, 2)), np.ones((n, 2), dtype=bool), np.zeros((n, 2, 3)), feet, corners, 0)
        return
    import biped.models
    from biped.control import WorkspaceController
    from biped.model import TreeModel

    tree = TreeModel.from_mjcf(biped.models.path("wendlandt"))
    ctrl = WorkspaceController(tree, distribution="qp" if name == "qp" else "statics")
    qpos = np.zeros(tree.nq)
    qpos[3] = 1.0
    ctrl.torques(qpos, np.zeros(tree.nv))


def warm_up(names=tuple(KERNELS), *, log: Callable[[str], None] | None = print, tick=None) -> float:
    """Compile the cold kernels of ``names`` now, after one line through ``log`` saying so, with
    an estimate (measured on this machine when it compiled them before); nothing is said when
    everything is cached. ``tick``: a stream (e.g. ``sys.stderr``) on which the elapsed time
    ticks while it compiles. Each kernel's compile time is remembered for the next estimate.
    Returns the seconds spent compiling."""
    cold = cold_kernels(names)
    if not cold:
        return 0.0
    labels = [KERNELS[n][0] for n in cold]
    what = " and ".join([", ".join(labels[:-1]), labels[-1]] if len(labels) > 1 else labels)
    secs, measured = estimate_s(cold)
    if log is not None:
        how = "measured on this machine" if measured else "on an idle 2-core machine; longer under load"
        log(f"compiling {what} (first run only, ~{secs:.0f} s, {how}; cached for later runs)")
    for label in labels:
        mark_said(label)
    ticker = _Ticker(tick, what, secs) if tick is not None else None
    t0 = time.perf_counter()
    try:
        for k, n in enumerate(cold):
            if ticker is not None:
                ticker.stage = f" {KERNELS[n][0]} ({k + 1}/{len(cold)})"
            t = time.perf_counter()
            _compile(n)
            took = time.perf_counter() - t
            if took > 0.5:  # less: loaded from a cache another process filled meanwhile
                record_compile_s(n, took)
            _WARM.add(n)
    finally:
        if ticker is not None:
            ticker.stop()
    return time.perf_counter() - t0


def announce_and_warm(names) -> None:
    """What the Python API does before a run: compile the cold kernels of ``names``, saying so
    once through ``logging`` (logger ``"biped"``, a warning) with the estimate."""
    import logging

    if cold_kernels(names):
        warm_up(names, log=lambda line: logging.getLogger("biped").warning("biped: %s", line))
