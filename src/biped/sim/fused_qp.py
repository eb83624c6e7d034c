"""The QP distribution's part of the compiled push loop (:mod:`biped.sim.fused`).

With ``distribution="qp"`` each compiled control period does what
:meth:`biped.control.WorkspaceController.torques` does after W Alg. 1-4: it builds the QP
(:func:`biped.control.distribution.qp_build`, compiled into the loop), solves it and applies the
solution (:func:`~biped.control.distribution.qp_finish`: the legs' shares and W Alg. 6). The solve
is the controller's own :meth:`~biped.control.distribution.ContactQP.solve` (daqp or quadprog with
the RELAXED and ZEROED fallbacks, ``status`` and ``fallbacks`` counted on the same object), called
from the compiled loop through numba's ``objmode`` (:func:`call_solve`): :func:`solve_qp` finds the ContactQP by the
slot that :func:`register_qp` gave the run. The loop passes the ContactQP's own arrays
(:func:`qp_arguments`), so its matrices and ``x`` after a run are those of the Python loop.
"""

from __future__ import annotations

import itertools
import weakref

import numpy as np
from numba import njit, objmode, types

#: the QP's arguments of the compiled loop (biped.sim.fused._SIGNATURE), in :func:`qp_arguments`' order
QP_TYPES = (
    types.float64[:, :, ::1],  # soles: g_{foot,sole} (2, 4, 4)
    types.float64[:, ::1],  # dims: half length and width (2, 2)
    types.float64[::1],  # prm: the weights' array
    types.float64[::1],  # torque-limit rows: lower bounds
    types.float64[::1],  # upper bounds
    types.float64[:, :, ::1],  # A (2, 6, 6)
    types.float64[:, ::1],  # T (n_joints, 12)
    types.float64[:, ::1],  # F (n_links, 6)
    types.float64[::1],  # tau scratch (n_joints,)
    types.float64[:, ::1],  # col (2, 6)
    types.float64[:, ::1],  # Gq (12, 12)
    types.float64[::1],  # av (12,)
    types.float64[:, ::1],  # Ct (rows, 12)
    types.float64[::1],  # b (rows,)
    types.float64[::1],  # x (12,)
    types.float64[:, ::1],  # wg: the legs' weight wrenches (2, 6)
)

_SLOTS: dict = {}
_IDS = itertools.count(1)


def register_qp(owner, qp) -> int:
    """A slot for ``qp`` while ``owner`` (the run's FusedRows) lives."""
    slot = next(_IDS)
    _SLOTS[slot] = qp
    weakref.finalize(owner, _SLOTS.pop, slot, None)
    return slot


def solve_qp(slot, meq, used, f0, f1):
    """ContactQP.solve of the QP the compiled loop has just built in slot ``slot``'s ContactQP,
    after recording what ContactQP.build would have (``meq``, ``rows``, ``first``); its status."""
    qp = _SLOTS[slot]
    qp.meq, qp.rows, qp.first = meq, used, (f0, f1)
    qp.solve()
    return qp.status


@njit(cache=True)
def call_solve(slot, meq, used, f0, f1):  # pragma: no cover - compiled
    """:func:`solve_qp` from compiled code. A function of its own: an ``objmode`` block inside the
    compiled loop itself boxes the loop's live arrays at every entry (measured: 17 us a call, here
    1.5 us)."""
    with objmode():
        solve_qp(slot, meq, used, f0, f1)


def qp_arguments(qp) -> tuple:
    """The QP's arrays in :data:`QP_TYPES`' order (the ContactQP's own), or placeholders without
    a QP."""
    if qp is None:
        z1, z2 = np.zeros(1), np.zeros((1, 1))
        empty = (np.zeros((2, 4, 4)), np.zeros((2, 4)), np.zeros(12), z1, z1, np.zeros((2, 6, 6)))
        return empty + (z2, z2, z1, z2, z2, z1, z2, z1, z1, np.zeros((2, 6)))
    head = (qp._soles, qp._dims, qp._prm, qp._lo, qp._hi, qp.A, qp.T, qp._F)
    return head + (qp._tau, qp._col, qp.Gq, qp.av, qp.Ct, qp.b, qp.x, qp.wg)
