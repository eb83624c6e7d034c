"""The table of a ``biped envelope`` run: per direction the limit found by the search, the first
failing size, the impulse the limit push delivered, the COM velocity change it means and its
share of Hof's feet-in-place bound (:mod:`biped.analysis.feet_in_place`).

The limit is in the search axis's unit: the block's speed [m/s], or another paradigm's size in its
own unit (force N, platform m, release deg; the rows' ``paradigm_unit``). The common sizes are
the rows' (docs/perturbations.md), each horizontal, as Hof's bound is (the extrapolated COM moves
in the floor's plane): the block's horizontal impulse measured from its momentum change (the
rows' ``horizontal_impulse_n_s``; their ``impulse_n_s`` holds its vertical part too); a force's
horizontal impulse applied (``horizontal_impulse_n_s``); a platform's body mass times its peak
velocity (``com_velocity_change_m_s``: the support's velocity change under the COM, the same
COM-relative-to-feet velocity as a push of that momentum); a release none (it starts at rest: NaN).

Pure arithmetic over :class:`biped.sim.sweep.envelope.EnvelopeRun` and the bound; printing and
JSON here, the polar plot in :mod:`biped.viz.envelope` (the run's Parquet file is a sweep file).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from biped.analysis.envelope import horizontal_impulse_n_s
from biped.analysis.feet_in_place import feet_in_place_bound
from biped.sim.perturbations import PARADIGMS

__all__ = ["EnvelopeRow", "EnvelopeTable", "envelope_table"]


@dataclass(frozen=True)
class EnvelopeRow:
    """One direction. limit / first_fail: sizes on the search axis (NaN: none survived / none
    failed); impulse_n_s: the horizontal impulse of the limit's trial (module docstring);
    delta_v_m_s: that impulse over the body's mass (the COM velocity change it causes, J / m);
    j_max_n_s: Hof's bound in that direction; percent_j_max: 100 impulse / J_max; non_monotone:
    a check trial below the first limit failed (limit is then the bisection below the lowest
    failure, first_limit the one before); n_trials: trials this direction used, n_checks of them
    check trials; first_fail_error: the error of the first failure's trial when it raised (a
    release lean friction cannot hold), else None."""

    direction_deg: float
    limit: float
    first_fail: float
    impulse_n_s: float
    delta_v_m_s: float
    j_max_n_s: float
    percent_j_max: float
    non_monotone: bool
    first_limit: float
    check_failures: int
    n_checks: int
    n_trials: int
    complete: bool
    first_fail_error: str | None = None


@dataclass(frozen=True)
class EnvelopeTable:
    axis: str
    criterion: str
    resolution: float
    body_mass_kg: float
    rows: tuple[EnvelopeRow, ...]
    paradigm: str = "block"
    unit: str = "m/s"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (NaN as None)."""

        def clean(v: Any) -> Any:
            return None if isinstance(v, float) and not math.isfinite(v) else v

        return {
            "paradigm": self.paradigm,
            "unit": self.unit,
            "axis": self.axis,
            "criterion": self.criterion,
            "resolution": self.resolution,
            "body_mass_kg": self.body_mass_kg,
            "directions": [{k: clean(v) for k, v in asdict(r).items()} for r in self.rows],
        }

    def format(self) -> str:
        """The table as fixed-width text for the terminal."""
        head = (
            f"{'direction':>9}  {'limit':>7}  {'first fail':>10}  {'impulse':>8}  "
            f"{'COM dv':>7}  {'% J_max':>7}  {'trials':>6}  note"
        )
        units = (
            f"{'[deg]':>9}  {'[' + self.unit + ']':>7}  {'':>10}  {'[N s]':>8}  "
            f"{'[m/s]':>7}  {'':>7}  {'':>6}"
        )
        lines = [head, units]
        # as many decimals as the resolution needs (0.25 m/s: 2; 5 mm: 3), at least 2
        digits = 2
        while digits < 6 and abs(round(self.resolution, digits) - self.resolution) > 1e-9 * self.resolution:
            digits += 1
        for r in self.rows:
            note = ""
            if not r.complete:
                note = "unfinished (a trial was lost twice)"
            elif r.non_monotone:
                note = (
                    f"NOT MONOTONE: {r.check_failures} of {r.n_checks} check trials below "
                    f"{r.first_limit:g} failed; limit is below the lowest failure"
                )
            elif math.isnan(r.first_fail):
                note = "survived the largest size: limit >= it"
            elif math.isnan(r.limit):
                note = "the smallest size failed"
            if r.first_fail_error:
                note = (note + "; " if note else "") + f"first fail is an error: {r.first_fail_error[:70]}"
            pct = f"{r.percent_j_max:6.0f}%" if math.isfinite(r.percent_j_max) else f"{'-':>7}"
            lines.append(
                f"{r.direction_deg:9.1f}  {_f(r.limit, 7, digits)}  {_f(r.first_fail, 10, digits)}  "
                f"{_f(r.impulse_n_s, 8, 1)}  {_f(r.delta_v_m_s, 7, 3)}  {pct}  "
                f"{r.n_trials:6d}  {note}"
            )
        return "\n".join(lines)


def _f(v: float, width: int, digits: int) -> str:
    return f"{'-':>{width}}" if not math.isfinite(v) else f"{v:{width}.{digits}f}"


def envelope_table(run: Any, *, bound: Any = None) -> EnvelopeTable:
    """The :class:`EnvelopeTable` of an :class:`~biped.sim.sweep.envelope.EnvelopeRun`.
    ``bound``: a :class:`~biped.analysis.FeetInPlaceBound` for the run's directions (default:
    :func:`feet_in_place_bound` at the run's base scenario)."""
    dirs = [d.direction_deg for d in run.directions]
    if bound is None:
        bound = feet_in_place_bound(dirs, run.spec.base)
    mass = float(bound.mass_kg)
    rows = []
    sizes = run.sizes
    resolution = float(sizes[1] - sizes[0]) if len(sizes) > 1 else float("nan")
    paradigm = str(run.spec.base.perturbation)
    for d, jmax in zip(run.directions, bound.j_max_n_s, strict=True):
        row = d.rows.get(d.limit) if math.isfinite(d.limit) else None
        j, dv = _momentum(row, paradigm, mass)
        fail = d.rows.get(d.first_fail) if math.isfinite(d.first_fail) else None
        rows.append(
            EnvelopeRow(
                direction_deg=float(d.direction_deg),
                limit=float(d.limit),
                first_fail=float(d.first_fail),
                impulse_n_s=j,
                delta_v_m_s=dv,
                j_max_n_s=float(jmax),
                percent_j_max=100.0 * j / float(jmax),
                non_monotone=bool(d.non_monotone),
                first_limit=float(d.first_limit),
                check_failures=int(d.check_failures),
                n_checks=int(d.n_checks),
                n_trials=int(d.n_trials),
                complete=bool(d.complete),
                first_fail_error=fail.get("error") if fail else None,
            )
        )
    unit = "m/s" if paradigm == "block" else PARADIGMS[paradigm].unit
    return EnvelopeTable(run.axis, run.criterion, resolution, mass, tuple(rows), paradigm, unit)


def _num(row: dict, key: str) -> float:
    v = row.get(key)
    return float(v) if v is not None else float("nan")


def _momentum(row: dict | None, paradigm: str, mass: float) -> tuple[float, float]:
    """(horizontal momentum change [N s], COM velocity change [m/s]) of the limit's row (module
    docstring); NaN without a row."""
    nan = float("nan")
    if row is None:
        return nan, nan
    if paradigm == "platform":
        dv = _num(row, "com_velocity_change_m_s")
        return mass * dv, dv
    if paradigm == "release":
        return nan, nan
    j = horizontal_impulse_n_s(row)  # the polar plot's impulse radius too (biped.viz.envelope)
    return j, j / mass
