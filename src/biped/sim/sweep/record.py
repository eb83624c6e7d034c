"""One row per trial: the measured quantities (:class:`Measured`, one dataclass) and the columns the
sweep adds around them. The Arrow schema of the sweep file is generated from these dataclasses,
so a new measurement is one new field.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import pyarrow as pa

from biped.sim.response import ResponseMeasures

# annotation (as written, ``from __future__ import annotations``) -> Arrow type name
_ARROW = {"bool": "bool_", "float": "float64", "int": "int64", "str": "string", "str | None": "string"}


@dataclass(frozen=True)
class _Trial:
    """The columns of :class:`Measured` before the response's: the run and the perturbation."""

    recovered: bool = False
    fell: bool = False
    impulse_n_s: float = math.nan
    impulse_horizontal_n_s: float = math.nan
    impulse_x_n_s: float = math.nan
    impulse_y_n_s: float = math.nan
    impulse_z_n_s: float = math.nan
    block_contact_time_s: float = math.nan
    max_com_excursion_m: float = math.nan
    time_to_recover_s: float = math.nan
    final_com_error_m: float = math.nan
    final_orientation_error_deg: float = math.nan
    left_lift_off: bool = False
    right_lift_off: bool = False
    lift_off_count: int = 0
    max_foot_lift_m: float = math.nan
    left_slip_m: float = math.nan
    right_slip_m: float = math.nan
    peak_torque_n_m: float = math.nan
    simulated_time_s: float = math.nan
    completed: bool = False
    fall_reason: str | None = None
    controller_error: str | None = None
    diverged: str | None = None
    step_count: int = 0  # stepping runs (scenario key stepping): steps taken
    first_step_xcom_offset_m: float = math.nan  # first step: landing beyond the XCoM at touchdown
    max_stance_slip_m: float = math.nan  # stepping: the stance sole's largest slide during a swing
    closing_steps: int = 0  # stepping: closing steps to a comfortable stance (not in step_count)
    final_stance_width_m: float = math.nan  # stepping: across distance of the sole centres at the end
    # the perturbation (biped.sim.perturbations); the response follows (Measured)
    paradigm: str = ""
    paradigm_magnitude: float = math.nan  # in paradigm_unit: block m/s, force N, platform m, release deg
    paradigm_unit: str = ""
    push_direction_deg: float = math.nan  # the way it pushes the body, from +x toward +y
    horizontal_impulse_n_s: float = math.nan  # block: measured; force: applied; else NaN
    com_velocity_change_m_s: float = math.nan  # the impulse / body mass; platform: its peak velocity


@dataclass(frozen=True)
class Measured(ResponseMeasures, _Trial):
    """What one push trial measures (see :func:`biped.sim.sweep.trial.measure` for how): the
    columns of :class:`_Trial`, then the response's (:class:`biped.sim.response.ResponseMeasures`,
    its fields and their order: one list, not a copy), then why the run ended.

    Units in the names: ``_m``, ``_s``, ``_n_s`` (N s), ``_deg``, ``_n_m`` (N m). NaN where a
    quantity does not apply (no block contact, not recovered, a foot never planted).
    """

    # why the run ended before its duration ("at_rest": the early_stop rule, biped.sim.early_stop;
    # "fell", "diverged", "controller_error"), and when [s]; None / NaN: it ran to its duration
    stop_reason: str | None = None
    stopped_at_s: float = math.nan

    def row(self) -> dict[str, Any]:
        """``{column: value}`` for the sweep file."""
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class _Head:
    """The columns before the measurements: the trial (from the sweep)."""

    trial_key: str
    index: int
    speed_m_s: float
    direction_deg: float
    block_mass_kg: float
    height_m: float
    gain_scale: float
    magnitude: float
    controller: str
    torque_limits: str


@dataclass(frozen=True)
class _Tail:
    """The columns after the measurements: how the trial ran."""

    error: str | None
    wall_time_s: float
    worker: str


#: Columns a trial function returns (the measured ones); every other column comes from the sweep.
MEASURED: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(Measured))
#: Every column of the sweep file, in order.
COLUMNS: tuple[str, ...] = tuple(f.name for cls in (_Head, Measured, _Tail) for f in dataclasses.fields(cls))


def row_survived(row: dict[str, Any], criterion: str = "survived") -> bool:
    """One row's verdict, the rule of :func:`biped.analysis.survived` (which works on whole tables):
    ``"survived"``: no error, completed, no fall, no controller error, no divergence;
    ``"recovered"``: no error and the simulator's ``recovered``."""
    if row.get("error") is not None:
        return False
    if criterion == "recovered":
        return bool(row.get("recovered"))
    fell = row.get("fell")
    return bool(
        row.get("completed")
        and fell is not None
        and not fell
        and row.get("controller_error") is None
        and row.get("diverged") is None
    )


def schema() -> pa.Schema:
    """The ``pyarrow.Schema`` of a sweep file (one row per trial), from the dataclasses above."""
    return pa.schema(
        [
            (f.name, getattr(pa, _ARROW[str(f.type)])())
            for cls in (_Head, Measured, _Tail)
            for f in dataclasses.fields(cls)
        ]
    )


__all__ = ["COLUMNS", "MEASURED", "Measured", "row_survived", "schema"]
