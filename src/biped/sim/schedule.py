"""A perturbation driver's inputs as data: :class:`Schedule`, rows ``first`` to ``last`` of a run,
each writing fixed ``ctrl`` values (the paradigm's own actuators) and, optionally, moving the
controller's COM set point along an axis by a joint's position (the platform's feet ride with it).

The compiled loop of :func:`biped.sim.push.run_closed_loop` applies a driver's schedule at the top
of each of those rows itself, without returning to Python (a return costs ~30-80 us: 150 of them,
a 0.3 s platform ramp at 500 Hz, were ~12 % of a 3 s run); the Python loop applies it through the
driver's ``apply``. Both call the same compiled :func:`apply_row`, so the two loops stay bit for
bit the same. :func:`merged_inputs` rebuilds the ``inputs`` records (``PushResult.extra``) of the
rows the compiled loop applied, as the Python loop records them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit, types

#: The compiled loop's arguments of a schedule (:func:`biped.sim.fused._run_rows`, after its rows
#: p[P_SK0] to p[P_SK1] and follow_qpos p[P_SFQ]): the actuators, their values a row, the set
#: point's offsets a row, its axis, its base, the controller's target array it writes.
SCHEDULE_TYPES = (types.int64[::1], types.float64[:, ::1], *(types.float64[::1],) * 4)


@njit(cache=True)
def apply_row(
    k, first, last, act, values, follow_q, axis, base, follow, qpos, ctrl, target
):  # pragma: no cover
    """Row ``k``'s inputs, if ``first <= k <= last``: ``ctrl[act] = values[k - first]``; with
    ``follow_q >= 0``, ``target[:2] = base[:2] + o axis[:2]``, the offset ``o = follow[k - first]``,
    or ``qpos[follow_q]`` where that is NaN."""
    if k < first or k > last:
        return
    i = k - first
    for j in range(act.shape[0]):
        ctrl[act[j]] = values[i, j]
    if follow_q >= 0:
        o = follow[i]
        if np.isnan(o):
            o = qpos[follow_q]
        for j in range(2):
            target[j] = base[j] + o * axis[j]


@dataclass
class Schedule:
    """Rows ``first`` .. ``last`` (inclusive) of a driver's inputs; see the module docstring.
    ``python_rows``: the driver's rows that still need its Python ``apply`` in the compiled loop
    (e.g. row 0, where it reads the starting state)."""

    first: int
    actuators: np.ndarray  # (na,) int64: the actuators it writes
    values: np.ndarray  # (last - first + 1, na) their ctrl at each row
    python_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    follow_qpos: int = -1  # the joint's qpos address the set point rides with; -1: none
    axis: np.ndarray = field(default_factory=lambda: np.zeros(3))  # (3,) the set point's axis
    base: np.ndarray = field(default_factory=lambda: np.zeros(3))  # (3,) the set point at offset 0
    follow: np.ndarray = field(default_factory=lambda: np.zeros(1))  # (rows,) offsets; NaN: the joint's
    target: np.ndarray = field(default_factory=lambda: np.zeros(3))  # the controller's target array

    @property
    def last(self) -> int:
        return self.first + len(self.values) - 1

    def apply(self, k: int, qpos: np.ndarray, ctrl: np.ndarray) -> None:
        """Row ``k``'s inputs (the Python loop's way, the compiled function)."""
        apply_row(k, self.first, self.last, self.actuators, self.values, self.follow_qpos, self.axis,
                  self.base, self.follow, qpos, ctrl, self.target)  # fmt: skip


def kernel_arguments(s: Schedule | None) -> tuple:
    """The arrays of :data:`SCHEDULE_TYPES` for ``s`` (the live arrays, not copies: the driver
    fills ``base`` at row 0), or placeholders for no schedule; LookupError if an array is not of
    its type."""
    if s is None:
        return (np.zeros(0, dtype=np.int64), np.zeros((1, 0)), *(np.zeros(3) for _ in range(4)))
    arrays = (s.actuators, s.values, s.follow, s.axis, s.base, s.target)
    for x, dtype in zip(arrays, (np.int64,) + (np.float64,) * 5, strict=True):
        if x.dtype != dtype or not x.flags.c_contiguous:
            raise LookupError(f"a schedule's array is not a contiguous {dtype.__name__} array")
    return arrays


def merged_inputs(inputs: list, schedule: Schedule, rows, ctrl0, xfrc0, torques, act) -> list:
    """``inputs`` (row, ctrl, xfrc_applied), recorded by the Python ``apply`` calls of a compiled
    run, with the schedule's ``rows`` (those the run reached, sorted) added as the Python loop
    records them: the ctrl and xfrc_applied of the last recorded row before (``ctrl0``, ``xfrc0``
    before the run's first), the schedule's values, the biped's actuators ``act`` holding the
    previous row's ``torques``."""
    py = sorted(inputs, key=lambda e: e[0])
    done = {e[0] for e in py}
    out: list = []
    i, c_prev, x_prev = 0, ctrl0, xfrc0
    for k in rows:
        if k in done:
            continue
        while i < len(py) and py[i][0] < k:
            out.append(py[i])
            c_prev, x_prev = py[i][1], py[i][2]
            i += 1
        c = c_prev.copy()
        c[schedule.actuators] = schedule.values[k - schedule.first]
        if k > 0:
            c[act] = torques[k - 1]
        out.append((k, c, x_prev.copy()))
    out.extend(py[i:])
    return out


__all__ = ["SCHEDULE_TYPES", "Schedule", "apply_row", "kernel_arguments", "merged_inputs"]
