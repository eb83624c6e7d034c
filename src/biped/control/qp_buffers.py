"""The preallocated arrays of :class:`biped.control.distribution.ContactQP` as views of two flat
buffers, so that one compiled call (:func:`biped.control.qp_call.qp_kernel`) gets them all as two
arguments (numba unboxes every array argument of a call from Python: ~30 arrays cost microseconds).

``qf`` (float64) holds, in this order, the fields of :data:`FLOAT_FIELDS`; ``qi`` (int64) holds a
header (:data:`H_LIMITED` ...), the solve's status counters (:mod:`biped.control.daqp_c`'s
``qstat``), daqp's result struct and the int32 ``sense`` array. :func:`qp_views` is the one
definition of the layout, compiled and called from Python alike (the views share the buffers).
:class:`QPState` keeps ``status``, ``fallbacks``, ``meq``, ``rows`` and ``first`` up to date with
what compiled calls counted in ``qi``, read when asked for (no per-call Python work).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from biped.control.buffers import _take1, _take2, _take3
from biped.control.daqp_c import XS, c_solve

__all__ = [
    "CMAP",
    "FLOAT_FIELDS",
    "PRM",
    "QPState",
    "float_size",
    "int_size",
    "qp_int_views",
    "qp_views",
    "solve_flat",
]

PRM = 12  # entries of QPWeights.array
#: entries of a foot's contact map (cones.map_contact_rows): on/off, K (6, 6) row by row, r (6,)
CMAP = 43
#: qf's fields (name, shape with nj = joints, rows = constraint rows)
FLOAT_FIELDS = (
    ("soles", (2, 4, 4)),
    ("dims", (2, 4)),  # a sole's half length, half width; the part in use: half length, centre
    ("prm", (PRM,)),
    ("lo", ("nj",)),
    ("hi", ("nj",)),
    ("A", (2, 6, 6)),
    ("T", ("nj", 12)),
    ("F", ("nj+1", 6)),
    ("tau", ("nj",)),
    ("col", (2, 6)),
    ("Gq", (12, 12)),
    ("av", (12,)),
    ("Ct", ("rows", 12)),
    ("b", ("rows",)),
    ("x", (12,)),
    ("wg", (2, 6)),
    ("upper", ("rows",)),
    ("f", (12,)),
    ("xs", (XS,)),
    ("lam", ("rows",)),
    ("cmap", (2, CMAP)),
)
# qi's header: torque-limit rows on, rows, daqp_quadprog's address (0: no C solve), the addresses
# of daqp's result, problem and settings structs and of ContactQP.Gq, a call not yet read by QPState
H_LIMITED, H_ROWS, H_FN, H_RES, H_PROB, H_SET, H_GQ, H_FRESH = range(8)
HEADER, QSTAT, RESULT = 8, 8, 8  # int64 entries of the header, qstat, daqp's result struct
# qstat entries (as biped.control.daqp_c's)
S_STATUS, S_RELAXED, S_ZEROED, S_SOLVES, S_MEQ, S_USED, S_F0, S_F1 = range(8)


def float_size(nj: int, rows: int) -> int:
    dims = {"nj": nj, "nj+1": nj + 1, "rows": rows}
    return sum(int(np.prod([dims[d] if isinstance(d, str) else d for d in sh])) for _, sh in FLOAT_FIELDS)


def int_size(rows: int) -> int:
    return HEADER + QSTAT + RESULT + (rows + 1) // 2


@njit(cache=True)
def qp_views(qf, nj, rows):
    """The views of :data:`FLOAT_FIELDS` in ``qf``, in that order."""
    o = 0
    soles, o = _take3(qf, o, 2, 4, 4)
    dims, o = _take2(qf, o, 2, 4)
    prm, o = _take1(qf, o, PRM)
    lo, o = _take1(qf, o, nj)
    hi, o = _take1(qf, o, nj)
    A, o = _take3(qf, o, 2, 6, 6)
    T, o = _take2(qf, o, nj, 12)
    F, o = _take2(qf, o, nj + 1, 6)
    tau, o = _take1(qf, o, nj)
    col, o = _take2(qf, o, 2, 6)
    Gq, o = _take2(qf, o, 12, 12)
    av, o = _take1(qf, o, 12)
    Ct, o = _take2(qf, o, rows, 12)
    b, o = _take1(qf, o, rows)
    x, o = _take1(qf, o, 12)
    wg, o = _take2(qf, o, 2, 6)
    upper, o = _take1(qf, o, rows)
    f, o = _take1(qf, o, 12)
    xs, o = _take1(qf, o, XS)
    lam, o = _take1(qf, o, rows)
    cmap, o = _take2(qf, o, 2, CMAP)
    return soles, dims, prm, lo, hi, A, T, F, tau, col, Gq, av, Ct, b, x, wg, upper, f, xs, lam, cmap


@njit(cache=True)
def qp_int_views(qi, rows):
    """(qstat, daqp's result struct as int32, the int32 ``sense`` of ``rows`` rows) in ``qi``."""
    o = HEADER
    qstat = qi[o : o + QSTAT]
    o += QSTAT
    res32 = qi[o : o + RESULT].view(np.int32)
    o += RESULT
    sense = qi[o : o + (rows + 1) // 2].view(np.int32)[:rows]
    return qstat, res32, sense


@njit(cache=True)
def solve_flat(qf, qi, nj, meq, used, f0, f1):  # pragma: no cover - compiled
    """:func:`biped.control.daqp_c.c_solve` (ContactQP.solve in C) on the flat buffers of a
    ContactQP whose C structs :func:`biped.control.daqp_c.bind_c` set up."""
    rows = qi[H_ROWS]
    _, dims, prm, _, _, _, _, _, _, _, _, av, Ct, b, x, _, upper, f, xs, _, _ = qp_views(qf, nj, rows)
    qstat, res32, sense = qp_int_views(qi, rows)
    c_solve(
        qi[H_FN],
        qi[H_RES : H_GQ + 1],
        res32,
        meq,
        used,
        f0,
        f1,
        sense,
        upper,
        f,
        av,
        Ct,
        b,
        x,
        xs,
        dims,
        prm,
        qstat,
    )
    qi[H_FRESH] = 1


class QPState:
    """``status``, ``fallbacks``, ``meq``, ``rows`` and ``first`` of a ContactQP, as set by Python
    or counted by compiled calls in ``self._qi`` (moved over when one of them is read)."""

    _qi: np.ndarray
    _status: int
    _fallbacks: dict
    _meq: int
    _rows: int
    _first: tuple

    def _pull(self) -> None:
        qi = self._qi
        if qi[H_FRESH] == 0:
            return
        qi[H_FRESH] = 0
        q = qi[HEADER : HEADER + QSTAT]
        self._meq, self._rows, self._first = int(q[S_MEQ]), int(q[S_USED]), (int(q[S_F0]), int(q[S_F1]))
        if q[S_SOLVES]:
            self._status = int(q[S_STATUS])
            self._fallbacks[1] += int(q[S_RELAXED])
            self._fallbacks[2] += int(q[S_ZEROED])
            q[S_RELAXED] = q[S_ZEROED] = q[S_SOLVES] = 0

    def _prop(name: str):  # type: ignore[misc]  # noqa: N805 - a helper of the class body
        def get(self):
            self._pull()
            return getattr(self, name)

        def put(self, value):
            self._pull()
            setattr(self, name, value)

        return property(get, put)

    status = _prop("_status")
    fallbacks = _prop("_fallbacks")
    meq = _prop("_meq")
    rows = _prop("_rows")
    first = _prop("_first")
    del _prop
