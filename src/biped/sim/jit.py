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

import hashlib
import time
from collections.abc import Callable

#: Kernel names for :func:`cold_kernels` / :func:`warm_up`: what they are and about how long
#: they take to compile [s] on an idle 2-core x86_64 machine (several times that under load).
KERNELS = {
    "controller": ("W's controller", 15),
    "qp": ("the contact QP", 5),
    "contact": ("the contact monitor", 1),
    "loop": ("the compiled push loop", 3),
}


def kernels_for(controller: str, distribution: str = "statics") -> tuple[str, ...]:
    """The kernels a push run with ``controller`` (``"workspace"`` or ``"joint-pd"``) and the
    workspace controller's ``distribution`` uses."""
    if controller != "workspace":
        return ("contact",)
    if distribution == "qp":
        return ("controller", "qp", "contact")
    return ("controller", "loop", "contact")  # the loop calls the controller's kernel


def _dispatcher(name: str):
    if name == "controller":
        from biped.control.recursions import compute_kernel

        return compute_kernel
    if name == "contact":
        from biped.sim.contact import _contact_bits

        return _contact_bits
    if name == "qp":
        from biped.control.distribution import qp_build

        return qp_build
    if name == "loop":
        from biped.sim.fused import _run_rows

        return _run_rows
    raise ValueError(f"unknown kernel {name!r}; valid: {', '.join(KERNELS)}")


def is_cached(dispatcher) -> bool | None:
    """True if numba's on-disk cache holds machine code of ``dispatcher`` for this CPU and this
    version of its source (what numba itself checks before it loads an entry: the source stamp
    in the index, then the code hash and the CPU in the entry's key); None if that cannot be told
    (caching off, or a numba whose cache layout differs)."""
    if getattr(dispatcher, "overloads", None):
        return True  # compiled in this process already
    cache = getattr(dispatcher, "_cache", None)
    try:
        index = cache._cache_file._load_index()  # type: ignore[union-attr]
        from numba.core.registry import cpu_target

        magic = cpu_target.target_context.codegen().magic_tuple()
        code = hashlib.sha256(dispatcher.py_func.__code__.co_code).hexdigest()
        return any(key[1] == magic and key[2][0] == code for key in index)
    except Exception:  # noqa: BLE001 - a numba without this layout, or no cache: cannot tell
        return None


def cold_kernels(names=tuple(KERNELS)) -> list[str]:
    """The kernels of ``names`` that would compile on first use (not cached, or cannot tell)."""
    return [n for n in names if not is_cached(_dispatcher(n))]


def _compile(name: str) -> None:
    """Run the kernel once on real inputs (what compiles it, and stores it in the cache)."""
    import numpy as np

    if name == "contact":
        from biped.sim.contact import compile_kernel

        compile_kernel()
        return
    if name == "loop":
        from biped.sim.fused import compile_kernel as compile_loop

        compile_loop()
        return
    import biped.models
    from biped.control import WorkspaceController
    from biped.model import TreeModel

    tree = TreeModel.from_mjcf(biped.models.path("wendlandt"))
    ctrl = WorkspaceController(tree, distribution="qp" if name == "qp" else "statics")
    qpos = np.zeros(tree.nq)
    qpos[3] = 1.0
    ctrl.torques(qpos, np.zeros(tree.nv))


def warm_up(names=tuple(KERNELS), *, log: Callable[[str], None] | None = print) -> float:
    """Compile the cold kernels of ``names`` now, after one line through ``log`` saying so
    (nothing is said when everything is cached). Returns the seconds spent compiling."""
    cold = cold_kernels(names)
    if not cold:
        return 0.0
    if log is not None:
        names = [KERNELS[n][0] for n in cold]
        what = " and ".join([", ".join(names[:-1]), names[-1]] if len(names) > 1 else names)
        secs = sum(KERNELS[n][1] for n in cold)
        log(f"compiling {what} (first run only, ~{secs} s; cached for later runs)")
    t0 = time.perf_counter()
    for n in cold:
        _compile(n)
    return time.perf_counter() - t0
