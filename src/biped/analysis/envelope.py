"""Recovery envelopes of a sweep: per push direction, how hard a push the biped survived.

Pure numpy over the sweep's rows (a ``pyarrow.Table``, a :class:`~biped.sim.sweep.SweepData` or a
``{column: list}``); plots in :mod:`biped.viz.envelope`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from biped.errors import ScenarioError
from biped.sim.sweep.store import SweepData, load


@dataclass(frozen=True)
class Envelope:
    """Per push direction, the largest tested ``by`` value (speed [m/s] or impulse [N s]) below
    which every trial survived, and the smallest one that did not.

    directions_deg (k,); survived_max (k,) (NaN if the weakest push already failed);
    failed_min (k,) (NaN if none failed: the envelope is then at least survived_max);
    n_trials (k,).
    """

    by: str
    criterion: str
    directions_deg: np.ndarray
    survived_max: np.ndarray
    failed_min: np.ndarray
    n_trials: np.ndarray


def survived(table_or_data: Any, criterion: str = "survived") -> np.ndarray:
    """(n,) bool per row. ``"survived"``: the trial ran to its end without error, did not fall,
    its controller never hit a singular state and the integration did not diverge;
    ``"recovered"``: the simulator's ``recovered`` (survived and back within the tolerances of
    the set point at the end)."""
    data = _columns(table_or_data)
    ok = np.array([e is None for e in data["error"]])
    if criterion == "recovered":
        return ok & np.array([bool(r) for r in data["recovered"]], dtype=bool)
    if criterion != "survived":
        raise ScenarioError(f"criterion must be 'survived' or 'recovered'; got {criterion!r}")
    fell = np.array([bool(f) if f is not None else True for f in data["fell"]])
    done = np.array([bool(c) for c in data["completed"]], dtype=bool)
    cerr = np.array([c is not None for c in data["controller_error"]])
    div = np.array([c is not None for c in data["diverged"]])
    return ok & done & ~fell & ~cerr & ~div


def _columns(table_or_data: Any) -> dict:
    table = getattr(table_or_data, "table", table_or_data)
    if isinstance(table, Mapping):
        return dict(table)
    return {name: table.column(name).to_pylist() for name in table.column_names}


def envelope(
    table_or_data: Any, by: str = "speed_m_s", criterion: str = "survived", bin_deg: float | None = None
) -> Envelope:
    """The recovery envelope of a sweep (see :class:`Envelope`); ``by`` is ``"speed_m_s"`` or
    ``"impulse_n_s"`` (rows without a measured impulse are left out). ``bin_deg`` groups the
    directions of a random sample into bins of that width (a grid needs none)."""
    if by not in (
        "speed_m_s",
        "impulse_n_s",
        "impulse_horizontal_n_s",
        "magnitude",
        "horizontal_impulse_n_s",
    ):
        raise ScenarioError(
            "by must be 'speed_m_s', 'impulse_n_s', 'impulse_horizontal_n_s', 'magnitude' or "
            f"'horizontal_impulse_n_s'; got {by!r}"
        )
    cols = _columns(table_or_data)
    ok = survived(cols, criterion)
    direction = np.mod(np.array(cols["direction_deg"], dtype=float), 360.0)
    value = np.array([np.nan if x is None else x for x in cols[by]], dtype=float)
    if bin_deg:
        direction = np.mod(np.round(direction / bin_deg) * bin_deg, 360.0)
    direction = np.round(direction, 6)
    dirs = np.unique(direction)
    smax, fmin, count = [], [], []
    for a in dirs:
        sel = (direction == a) & np.isfinite(value)
        v, s = value[sel], ok[sel]
        order = np.argsort(v, kind="stable")
        v, s = v[order], s[order]
        bad = np.flatnonzero(~s)
        first_bad = v[bad[0]] if len(bad) else np.nan
        good = v[s & (v < first_bad)] if len(bad) else v[s]
        smax.append(good.max() if len(good) else np.nan)
        fmin.append(first_bad)
        count.append(int(sel.sum()))
    return Envelope(by, criterion, dirs, np.array(smax), np.array(fmin), np.array(count))


def horizontal_impulse_n_s(row: Mapping) -> float:
    """The perturbation's horizontal impulse [N s] of one sweep row, the impulse of ``biped
    envelope``'s table and of the polar plot's impulse radius (Hof's bound is horizontal: the
    extrapolated COM moves in the floor's plane): the row's ``horizontal_impulse_n_s`` (a block's
    measured from its momentum change, a force's applied; NaN for a platform or a release); a row
    written before that column, the block's ``hypot(impulse_x_n_s, impulse_y_n_s)``; else NaN.
    Never ``impulse_n_s``, which holds the vertical part of a block's hit too."""
    v = row.get("horizontal_impulse_n_s")
    if v is not None:
        return float(v)
    x, y = row.get("impulse_x_n_s"), row.get("impulse_y_n_s")
    return float(np.hypot(x, y)) if x is not None and y is not None else float("nan")


def sweep_data(source: Any) -> SweepData:
    """A sweep file's :class:`~biped.sim.sweep.SweepData` from its path (or itself)."""
    return source if isinstance(source, SweepData) else load(source)


__all__ = ["Envelope", "envelope", "horizontal_impulse_n_s", "survived", "sweep_data"]
