"""daqp's C solver called from compiled code, without Python: from the compiled push loop
(:mod:`biped.sim.fused`) and from the controller's own QP call (:mod:`biped.control.qp_call`).

``daqp.solve`` from Python costs ~7.8 us a call in a tight loop (inside the compiled loop, an
``objmode`` round trip on top: ~27 us). :func:`c_solve` does the same solve with the same
fallbacks (RELAXED retry without the legs' weight and the minimum normal force, then ZEROED; a
non-finite solution is ZEROED) by calling daqp's own C ``daqp_quadprog`` on the ContactQP's own
arrays, so a run's records, ``x``, ``Gq``, ``b``, ``status`` and ``fallbacks`` are bit for bit
those of the Python path (``tests/test_sim_fused.py``, ``tests/test_qp_call.py``). Both paths
first try the QP's unconstrained minimizer (:func:`unconstrained`): when it satisfies every row
it is the solution, the one daqp reaches after its first iteration, to rounding.

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
from llvmlite import ir  # type: ignore[import-untyped]
from numba import carray, njit, types
from numba.extending import intrinsic, overload

from biped.control.buffers import _take2
from biped.control.cones import contact_rows

__all__ = [
    "CHECKED_VERSIONS",
    "C_TYPES",
    "bind_c",
    "c_arguments",
    "c_solve",
    "daqp_c",
    "sync_status",
    "unconstrained",
]

#: daqp releases whose C structs were checked against this module's layout
CHECKED_VERSIONS = ("0.11.0",)
DAQP_SIG = types.int32(types.uintp, types.uintp, types.uintp)  # daqp_quadprog(res*, prob*, settings*)
SOLVED, RELAXED, ZEROED = 0, 1, 2  # biped.control.distribution's statuses
# qstat entries: last status, RELAXED and ZEROED counts, solves, meq, rows used, first rows
S_STATUS, S_RELAXED, S_ZEROED, S_SOLVES, S_MEQ, S_USED, S_F0, S_F1 = range(8)

#: length of the ``xs`` buffer: daqp's x (12), then :func:`unconstrained`'s scratch (L, y)
XS = 12 + 144 + 12

#: the arguments of the compiled loop after biped.sim.fused_qp.QP_TYPES, in c_arguments' order
C_TYPES = (
    types.FunctionType(DAQP_SIG),  # daqp_quadprog
    types.uint64[::1],  # addresses: result, problem, settings, ContactQP.Gq
    types.int32[::1],  # the result struct as int32 (exitflag at 8)
    types.int32[::1],  # ContactQP._sense
    types.float64[::1],  # ContactQP._upper
    types.float64[::1],  # ContactQP._f
    types.float64[::1],  # daqp's x, then unconstrained's scratch (XS,)
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


def __getattr__(name: str):
    """``_unused``: the placeholder C function (:mod:`biped.control.daqp_stub`), compiled or
    loaded from numba's cache on first use only."""
    if name == "_unused":
        from biped.control.daqp_stub import unused

        return unused
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _placeholder_address() -> int:
    from biped.control.daqp_stub import unused

    return unused.address or 0


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
        fn = c[0] if c is not None else _DaqpQuadprog(_placeholder_address())
        empty = (np.zeros(4, dtype=np.uint64), np.zeros(16, dtype=np.int32), np.zeros(1, dtype=np.int32))
        return False, (fn, *empty, z, z, z, np.zeros(8, dtype=np.int64))
    fn, settings = c
    rows = len(qp.b)
    xs, lam = np.zeros(XS), np.zeros(rows)
    prob = _Problem(12, rows, 0, qp.Gq.ctypes.data, qp._f.ctypes.data, qp.Ct.ctypes.data)
    prob.bupper, prob.blower, prob.sense = qp._upper.ctypes.data, qp.b.ctypes.data, qp._sense.ctypes.data
    res = _result(xs, lam)
    addr = np.array(
        [res.ctypes.data, ctypes.addressof(prob), ctypes.addressof(settings), qp.Gq.ctypes.data],
        dtype=np.uint64,
    )
    keep.extend((prob, lam, settings))
    qstat = np.zeros(8, dtype=np.int64)
    return True, (fn, addr, res.view(np.int32), qp._sense, qp._upper, qp._f, xs, qstat)


@intrinsic
def _call_address(typingctx, fn, a, b, c):
    """``int32 (*fn)(void*, void*, void*)`` called at the integer address ``fn`` with the integer
    addresses ``a``, ``b``, ``c`` (the address is a run-time value: safe in numba's cache)."""
    if not all(isinstance(t, types.Integer) for t in (fn, a, b, c)):
        return None

    def codegen(context, builder, signature, args):
        vp = ir.IntType(8).as_pointer()
        fnty = ir.FunctionType(ir.IntType(32), [vp, vp, vp])
        ptr = builder.inttoptr(args[0], fnty.as_pointer())
        return builder.call(ptr, [builder.inttoptr(v, vp) for v in args[1:]])

    return types.int32(fn, a, b, c), codegen


def _invoke(fn, a, b, c):  # pragma: no cover - replaced by the overload in compiled code
    raise NotImplementedError


@overload(_invoke)
def _invoke_compiled(fn, a, b, c):
    """``fn(a, b, c)`` for ``fn`` a numba first-class function (the push loop) or an integer
    address (:mod:`biped.control.qp_call`, which thereby skips boxing a function object)."""
    if isinstance(fn, types.Integer):
        return lambda fn, a, b, c: _call_address(fn, a, b, c)  # type: ignore[call-arg]
    return lambda fn, a, b, c: fn(a, b, c)


def bind_c(qp):
    """Point daqp's structs at the ContactQP ``qp``'s own flat buffers and write the addresses into
    its ``_qi`` header (:mod:`biped.control.qp_buffers`), for :func:`biped.control.qp_call.qp_kernel`;
    returns the problem struct (to keep alive with ``qp``), or None without a usable C solver."""
    from biped.control.qp_buffers import H_FN, H_GQ, H_PROB, H_RES, H_SET

    c = daqp_c()
    if c is None:
        return None
    fn, settings = c
    prob = _Problem(12, len(qp.b), 0, qp.Gq.ctypes.data, qp._f.ctypes.data, qp.Ct.ctypes.data)
    prob.bupper, prob.blower, prob.sense = qp._upper.ctypes.data, qp.b.ctypes.data, qp._sense.ctypes.data
    res = qp._res32.view(np.int64)  # DAQPResult: x*, lam*, ...
    res[:] = 0
    res[0], res[1] = qp._xs.ctypes.data, qp._lam.ctypes.data
    qi = qp._qi
    qi[H_FN], qi[H_RES] = fn.__wrapper_address__(), res.ctypes.data
    qi[H_PROB], qi[H_SET], qi[H_GQ] = ctypes.addressof(prob), ctypes.addressof(settings), qp.Gq.ctypes.data
    return prob


@intrinsic
def _f64_pointer(typingctx, address):
    """The integer ``address`` as a float64 pointer (for ``numba.carray``)."""
    if not isinstance(address, types.Integer):
        return None

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(types.CPointer(types.float64)))

    return types.CPointer(types.float64)(address), codegen


@njit(cache=True)
def unconstrained(Gq, av, Ct, b, used, xs):  # pragma: no cover - compiled
    """The QP's unconstrained minimizer ``Gq^-1 av`` into ``xs[:12]`` (Cholesky, scratch in
    ``xs[12:]``); True if it satisfies every one of the ``used`` rows ``Ct x >= b`` exactly, so
    that it is the QP's solution (the QP is strictly convex). False, and the solver must run, if a
    row is violated or Gq is not numerically positive definite. Standing, this is every call: daqp
    then ends after its first iteration with no active row, on the same point to rounding."""
    L = _take2(xs, 12, 12, 12)[0]  # xs[12:156] as (12, 12), without reshape's C helper
    y = xs[156:168]
    for j in range(12):
        d = Gq[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        d = math.sqrt(d)
        L[j, j] = d
        for i in range(j + 1, 12):
            v = Gq[i, j]
            for k in range(j):
                v -= L[i, k] * L[j, k]
            L[i, j] = v / d
    for i in range(12):  # L y = av
        v = av[i]
        for k in range(i):
            v -= L[i, k] * y[k]
        y[i] = v / L[i, i]
    for i in range(11, -1, -1):  # L^T x = y
        v = y[i]
        for k in range(i + 1, 12):
            v -= L[k, i] * xs[k]
        xs[i] = v / L[i, i]
    for r in range(used):
        v = 0.0
        for i in range(12):
            v += Ct[r, i] * xs[i]
        if not v >= b[r]:
            return False
    return True


@njit(cache=True)
def _once(fn, addr, res32, meq, used, sense, upper, f, av, Ct, b, xs):  # pragma: no cover - compiled
    """ContactQP._solve_once (daqp) into ``xs[:12]``: True if the unconstrained minimizer is
    feasible (:func:`unconstrained`) or daqp's exit flag is >= 1."""
    Gq = carray(_f64_pointer(addr[3]), (12, 12))  # type: ignore[call-arg]  # ContactQP.Gq
    if meq == 0 and unconstrained(Gq, av, Ct, b, used, xs):
        return True
    sense[:] = 0
    sense[:meq] = 5  # daqp: ACTIVE + IMMUTABLE, an equality row
    upper[:] = 1e30
    upper[:meq] = b[:meq]
    for i in range(f.shape[0]):
        f[i] = -av[i]
    _invoke(fn, addr[0], addr[1], addr[2])
    return res32[8] >= 1


@njit(cache=True)
def c_solve(
    fn, addr, res32, meq, used, f0, f1, sense, upper, f, av, Ct, b, x, xs, dims, prm, qstat
):  # pragma: no cover
    """ContactQP.solve in compiled code (its fallbacks, status and counts into ``qstat``)."""
    if _once(fn, addr, res32, meq, used, sense, upper, f, av, Ct, b, xs):
        x[:] = xs[:12]
        status = SOLVED
    else:
        saved = b.copy()
        for k in range(2):
            m = f0 if k == 0 else f1
            if m >= 0:
                contact_rows(dims[k, 2], dims[k, 1], dims[k, 3], prm[6], 0.0, prm[7], 6 * k, Ct, b, m)
        if _once(fn, addr, res32, meq, used, sense, upper, f, av, Ct, b, xs):
            x[:] = xs[:12]
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
