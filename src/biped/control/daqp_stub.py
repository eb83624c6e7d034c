"""The placeholder C function the compiled loop is given when it does not solve a QP in C
(:func:`biped.control.daqp_c.c_arguments`: no QP, another solver, or daqp's C function not
usable): a numba ``cfunc`` of daqp_quadprog's signature that is never called.

In its own module so that importing :mod:`biped.control.daqp_c` compiles nothing: a ``cfunc`` is
compiled (or loaded from numba's cache) when it is defined, and that first load set up numba's
whole compiler target (~0.5-1 s of CPU, scipy.linalg included) in every process that imported
the QP modules, the sweep's and the envelope's parent too, which only check the cache before
their workers start.
"""

from __future__ import annotations

from numba import cfunc

from biped.control.daqp_c import DAQP_SIG


@cfunc(DAQP_SIG, cache=True)
def unused(res, prob, settings):  # pragma: no cover - the placeholder when the C solve is off
    return -1


__all__ = ["unused"]
