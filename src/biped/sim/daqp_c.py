"""daqp's C solver called from the compiled push loop, without Python (:mod:`biped.sim.fused`).

:meth:`biped.control.distribution.ContactQP.solve` calls ``daqp.solve`` from Python; inside the
compiled loop that costs an ``objmode`` round trip and ~27 us a call (7.8 us in a tight loop).
:func:`c_solve` does the same solve with the same fallbacks (RELAXED retry without the legs'
weight and the minimum normal force, then ZEROED; a non-finite solution is ZEROED) by calling
daqp's own C ``daqp_quadprog`` on the ContactQP's own arrays, so a run's records, ``x``, ``Gq``,
``b``, ``status`` and ``fallbacks`` are bit for bit those of the Python path
(``tests/test_sim_fused.py``).

The C structs (``DAQPProblem``, ``DAQPResult``) are not part of daqp's Python API: their layout is
that of the daqp versions in :data:`CHECKED_VERSIONS`, and :func:`daqp_c` also solves a fixed
problem through them and compares it bit for bit with ``daqp.solve`` before the loop may use
them. Any other version, or a mismatch, leaves the solve to Python (``objmode``).
"""

from __future__ import annotations

import ctypes
import importlib.metadata
import math

import numpy as np
from numba import cfunc, njit, types

from biped.control.cones import cone_rows

__all__ = ["CHECKED_VERSIONS", "C_TYPES", "c_arguments", "c_solve", "daqp_c", "sync_status"]

#: daqp releases whose C structs were checked against this module's layout
CHECKED_VERSIONS = ("0.11.0",)
DAQP_SIG = types.int32(types.uintp, types.uintp, types.uintp)  # daqp_quadprog(res*, prob*, settings*)
SOLVED, RELAXED, ZEROED = 0, 1, 2  # biped.control.distribution's statuses
# qstat entries: last status, RELAXED and ZEROED counts, solves, meq, rows used, first rows
S_STATUS, S_RELAXED, S_ZEROED, S_SOLVES, S_MEQ, S_USED, S_F0, S_F1 = range(8)

#: the arguments of the compiled loop after biped.sim.fused_qp.QP_TYPES, in c_arguments' order
C_TYPES = (
    types.FunctionType(DAQP_SIG),  # daqp_quadprog
    types.uint64[::1],  # addresses: result, problem, settings
    types.int32[::1],  # the result struct as int32 (exitflag at 8)
    types.int32[::1],  # ContactQP._sense
    types.float64[::1],  # ContactQP._upper
    types.float64[::1],  # ContactQP._f
    types.float64[::1],  # daqp's x
    types.int64[::1],  # qstat
)


class _Problem(ctypes.Structure):  # DAQPProblem (daqp 0.11.0, types.h)
    _fields_ = [
        ("n", ctypes.c_int),
        ("m", ctypes.c_int),
        ("ms", ctypes.c_int),
        ("H", ctypes.c_void_p),
        ("f", ctypes.c_void_p),
        ("A", ctypes.c_void_p),
        ("bupper", ctypes.c_void_p),
        ("blower", ctypes.c_void_p),
        ("sense", ctypes.c_void_p),
        ("break_points", ctypes.c_void_p),
        ("nh", ctypes.c_int),
        ("problem_type", ctypes.c_int),
    ]


class _DaqpQuadprog(types.WrapperAddressProtocol):
    def __init__(self, address: int):
        self._address = address

    def __wrapper_address__(self):
        return self._address

    def signature(self):
        return DAQP_SIG


@cfunc(DAQP_SIG, cache=True)
def _unused(res, prob, settings):  # pragma: no cover - the placeholder when the C solve is off
    return -1


def _result(x: np.ndarray, lam: np.ndarray) -> np.ndarray:
    res = np.zeros(8, dtype=np.int64)  # DAQPResult: x*, lam*, fval, soft_slack, exitflag, ... (64 bytes)
    res[0], res[1] = x.ctypes.data, lam.ctypes.data
    return res


def _check(lib, settings) -> bool:
    """daqp_quadprog through these structs gives daqp.solve's solution bit for bit on a fixed
    problem with equality, two-sided and one-sided rows."""
    import daqp

    rng = np.random.default_rng(7)
    n, m = 12, 30
    M = rng.standard_normal((n, n))
    H = M @ M.T + n * np.eye(n)
    f, A = 10 * rng.standard_normal(n), rng.standard_normal((m, n))
    ax = A @ (0.1 * rng.standard_normal(n))  # feasible around x0, with active rows at the optimum
    bu, bl = ax + 0.05 * rng.random(m), ax - 0.05 * rng.random(m)
    bl[::3] = -1e30
    sense = np.zeros(m, dtype=np.int32)
    sense[:3] = 5
    bu[:3] = bl[:3] = ax[:3]
    x_ref, _, flag, _ = daqp.solve(H.copy(), f.copy(), A.copy(), bu.copy(), bl.copy(), sense.copy())
    x, lam = np.zeros(n), np.zeros(m)
    p = _Problem(n, m, 0, H.ctypes.data, f.ctypes.data, A.ctypes.data, bu.ctypes.data, bl.ctypes.data)
    p.sense = sense.ctypes.data
    res = _result(x, lam)
    lib.daqp_quadprog(ctypes.c_void_p(res.ctypes.data), ctypes.byref(p), settings)
    return flag >= 1 and int(res.view(np.int32)[8]) == flag and np.array_equal(x, x_ref)


_C: list = []


def daqp_c():
    """(daqp_quadprog as a numba first-class function, daqp's default settings) when the installed
    daqp is one of :data:`CHECKED_VERSIONS` and passes :func:`_check`; else None (made once)."""
    if not _C:
        found = None
        try:
            import daqp

            if importlib.metadata.version("daqp") in CHECKED_VERSIONS:
                lib = ctypes.CDLL(daqp.__file__)
                settings = (ctypes.c_char * 512)()  # DAQPSettings: 136 bytes in 0.11.0
                lib.daqp_default_settings(settings)
                if _check(lib, settings):
                    found = (
                        _DaqpQuadprog(ctypes.cast(lib.daqp_quadprog, ctypes.c_void_p).value or 0),
                        settings,
                    )
        except (ImportError, OSError, AttributeError, importlib.metadata.PackageNotFoundError):
            found = None
        _C.append(found)
    return _C[0]


def c_arguments(qp, keep: list) -> tuple[bool, tuple]:
    """(whether the loop may solve ``qp`` in C, the :data:`C_TYPES` arguments); the ctypes objects
    the addresses point to are appended to ``keep``, which must outlive the run."""
    c = daqp_c()
    if qp is None or c is None or getattr(qp, "solver", None) != "daqp":
        z = np.zeros(1)
        fn = c[0] if c is not None else _DaqpQuadprog(_unused.address or 0)
        empty = (np.zeros(3, dtype=np.uint64), np.zeros(16, dtype=np.int32), np.zeros(1, dtype=np.int32))
        return False, (fn, *empty, z, z, z, np.zeros(8, dtype=np.int64))
    fn, settings = c
    rows = len(qp.b)
    xs, lam = np.zeros(12), np.zeros(rows)
    prob = _Problem(12, rows, 0, qp.Gq.ctypes.data, qp._f.ctypes.data, qp.Ct.ctypes.data)
    prob.bupper, prob.blower, prob.sense = qp._upper.ctypes.data, qp.b.ctypes.data, qp._sense.ctypes.data
    res = _result(xs, lam)
    addr = np.array([res.ctypes.data, ctypes.addressof(prob), ctypes.addressof(settings)], dtype=np.uint64)
    keep.extend((prob, lam, settings))
    qstat = np.zeros(8, dtype=np.int64)
    return True, (fn, addr, res.view(np.int32), qp._sense, qp._upper, qp._f, xs, qstat)


@njit(cache=True)
def _once(fn, addr, res32, meq, sense, upper, f, av, b):  # pragma: no cover - compiled
    """ContactQP._solve_once (daqp): True if daqp's exit flag is >= 1."""
    sense[:] = 0
    sense[:meq] = 5  # daqp: ACTIVE + IMMUTABLE, an equality row
    upper[:] = 1e30
    upper[:meq] = b[:meq]
    for i in range(f.shape[0]):
        f[i] = -av[i]
    fn(addr[0], addr[1], addr[2])
    return res32[8] >= 1


@njit(cache=True)
def c_solve(
    fn, addr, res32, meq, used, f0, f1, sense, upper, f, av, Ct, b, x, xs, dims, prm, qstat
):  # pragma: no cover
    """ContactQP.solve in compiled code (its fallbacks, status and counts into ``qstat``)."""
    if _once(fn, addr, res32, meq, sense, upper, f, av, b):
        x[:] = xs
        status = SOLVED
    else:
        saved = b.copy()
        for k in range(2):
            m = f0 if k == 0 else f1
            if m >= 0:
                cone_rows(dims[k, 0], dims[k, 1], prm[6], 0.0, prm[7], 6 * k, Ct, b, m)
        if _once(fn, addr, res32, meq, sense, upper, f, av, b):
            x[:] = xs
            status = RELAXED
        else:
            x[:] = 0.0
            status = ZEROED
        b[:] = saved
        qstat[S_RELAXED + status - 1] += 1
    if not math.isfinite(x.sum()):
        x[:] = 0.0
        status = ZEROED
        qstat[S_ZEROED] += 1
    qstat[S_STATUS] = status
    qstat[S_SOLVES] += 1
    qstat[S_MEQ], qstat[S_USED], qstat[S_F0], qstat[S_F1] = meq, used, f0, f1


def sync_status(qp, qstat: np.ndarray) -> None:
    """Move what :func:`c_solve` counted since the last sync onto the ContactQP ``qp``."""
    if qstat[S_SOLVES] == 0:
        return
    qp.status = int(qstat[S_STATUS])
    qp.fallbacks[RELAXED] += int(qstat[S_RELAXED])
    qp.fallbacks[ZEROED] += int(qstat[S_ZEROED])
    qp.meq, qp.rows, qp.first = int(qstat[S_MEQ]), int(qstat[S_USED]), (int(qstat[S_F0]), int(qstat[S_F1]))
    qp._meq_sense = qp.meq
    qstat[:] = 0
