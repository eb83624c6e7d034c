"""Push-recovery sweeps: many push trials on every local core or a Dask cluster.

A sweep is a grid (or a uniform random sample) over the block's horizontal speed, its direction
of travel, its mass, its height and a scale on the controller gains, around one base
:class:`~biped.sim.scenario.Scenario` (every other key keeps its value: W's by default).

>>> from biped.sim.sweep import SweepSpec, run_sweep
>>> spec = SweepSpec(axes={"speed_m_s": (2, 4, 6), "direction_deg": range(0, 360, 45)})
>>> spec.n_trials
24

then (minutes of simulation, so not a doctest)::

    summary = run_sweep(spec, "runs/sweep.parquet")     # all local cores, processes
    summary = run_sweep(spec, "runs/sweep.parquet", scheduler="tcp://10.0.0.5:8786")   # Dask

One concept per module:

- :mod:`.spec` the sweep's definition (grid or sample, TOML, identity, trial keys), :mod:`.axes`
  its axes and their values, :mod:`.aim` how each trial's block is aimed (its scenario);
- :mod:`.record` the row of one trial (:class:`Measured`) and the file's Arrow schema;
- :mod:`.store` the lock, the part files and the one consolidated Parquet file;
- :mod:`.runner`, :mod:`.pool` and :mod:`.cluster` running ``trial_fn(setup) -> row`` here, on
  local worker processes or on Dask (no MuJoCo in any);
- :mod:`.trial` the push trial itself (MuJoCo) and its measurements.

Envelopes and Hof's feet-in-place bound are analysis of the results: :mod:`biped.analysis`.
"""

from __future__ import annotations

from biped.sim.sweep.record import MEASURED, Measured
from biped.sim.sweep.runner import (
    SweepSummary,
    Terminated,
    check_run_args,
    check_setups,
    connect_scheduler,
    default_workers,
    execute_trial,
    run_sweep,
)
from biped.sim.sweep.spec import (
    AXES,
    MAX_TRIALS,
    W_THROW,
    SweepSpec,
    Trial,
    TrialSetup,
    aim_block,
    hold_scenario,
    parse_axis,
    trial_scenario,
)
from biped.sim.sweep.store import SweepData, load, parts_dir
from biped.sim.sweep.trial import ballistic_impulse, make_policy, measure, run_trial

__all__ = [
    "AXES",
    "MAX_TRIALS",
    "MEASURED",
    "W_THROW",
    "Measured",
    "SweepData",
    "SweepSpec",
    "SweepSummary",
    "Terminated",
    "Trial",
    "TrialSetup",
    "aim_block",
    "ballistic_impulse",
    "check_run_args",
    "check_setups",
    "connect_scheduler",
    "default_workers",
    "execute_trial",
    "hold_scenario",
    "load",
    "make_policy",
    "measure",
    "parse_axis",
    "parts_dir",
    "run_sweep",
    "run_trial",
    "trial_scenario",
]
