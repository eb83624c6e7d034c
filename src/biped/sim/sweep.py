"""Push-recovery envelopes: many push trials on every local core or a Dask cluster.

A sweep is a grid (or a uniform random sample) over the block's horizontal speed, its direction
of travel, its mass, its height and a scale on the controller gains, around one base
:class:`~biped.sim.scenario.Scenario` (every other key keeps its value: W's by default).

>>> from biped.sim.sweep import SweepSpec, run_sweep
>>> spec = SweepSpec(axes={"speed_m_s": (2, 4, 6), "direction_deg": range(0, 360, 45)})
>>> summary = run_sweep(spec, "sweep.parquet")          # all local cores, processes
>>> summary = run_sweep(spec, "sweep.parquet", scheduler="tcp://10.0.0.5:8786")   # Dask

Conventions: ``direction_deg`` is the direction the block *travels* in the horizontal plane,
measured from +x toward +y (W's throw travels at 180 deg, along -x: the biped faces -x, so that
block hits its back and pushes it forward). The block is aimed at the
vertical line through the central body's initial COM (see :func:`aim_block`).

Storage: finished trials are written every few seconds as small Parquet files in
``<out>.parts/`` (one row per trial); when every trial is done they are consolidated into ONE
Parquet file ``<out>`` whose schema metadata holds the base scenario, the sweep definition, the
SHA-256 of the model file and the package version, and the parts directory is removed. An
interrupted sweep (Ctrl-C, a killed worker) keeps every finished trial; running the same command
again skips them. A trial that raises is recorded with its error string (and not retried unless
``retry_failed=True``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import os
import shutil
import socket
import time
import tomllib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from biped.errors import ScenarioError
from biped.sim.scenario import Scenario

#: The swept quantities: name -> (unit, what it means).
AXES: dict[str, str] = {
    "speed_m_s": "horizontal block speed [m/s]",
    "direction_deg": "direction the block travels, from +x toward +y [deg]",
    "block_mass_kg": "block mass [kg]",
    "height_m": "height of the block's aim point above the floor [m]",
    "gain_scale": "factor s on the stiffness gains (kp * s) and sqrt(s) on the damping gains "
                  "(kv * sqrt(s)), which keeps every damping ratio",
}

#: W's throw (section 4) in sweep coordinates: 1.8 kg at 4.5 m/s along -x, 1.2 m high.
W_THROW = {"speed_m_s": 4.5, "direction_deg": 180.0, "block_mass_kg": 1.8, "height_m": 1.2,
           "gain_scale": 1.0}

GRAVITY = 9.81  # [m/s^2], the scene's (W section 4)
SCHEMA_VERSION = 1


# ---------------------------------------------------------------------------------------------
# the sweep definition

@dataclass(frozen=True)
class Trial:
    """One push of a sweep: its place in the sweep, its parameters and a stable key.

    ``key`` is a hash of the parameters and of the sweep's identity (base scenario, model file,
    launch distance): the same command makes the same keys, which is how a rerun skips what is
    done.
    """

    index: int
    speed_m_s: float
    direction_deg: float
    block_mass_kg: float
    height_m: float
    gain_scale: float
    key: str

    def params(self) -> dict[str, float]:
        return {name: getattr(self, name) for name in AXES}


@dataclass(frozen=True)
class TrialSetup:
    """Everything a trial function needs: the full scenario (block aimed, workspace gains
    scaled), the trial, and the sweep's torque-limit set (``"none"`` or ``"human"``, see
    :mod:`biped.control.limits`) applied to either controller."""

    scenario: Scenario
    trial: Trial
    torque_limits: str = "none"


def _axis_values(name: str, value) -> tuple[float, ...]:
    if name not in AXES:
        raise ScenarioError(f"unknown sweep axis {name!r}; valid axes: {', '.join(AXES)}")
    if isinstance(value, Mapping):
        value = linspace_spec(name, value)
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = (value,)
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        raise ScenarioError(f"sweep axis {name} ({AXES[name]}) must be a number, a list of numbers "
                            f"or {{start, stop, num}}; got {value!r}")
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) \
                or not math.isfinite(float(v)):
            raise ScenarioError(f"sweep axis {name} ({AXES[name]}) must hold finite numbers; "
                                f"got {v!r}")
        out.append(float(v))
    if not out:
        raise ScenarioError(f"sweep axis {name} ({AXES[name]}) is empty; give at least one value")
    lo = min(out)
    if name in ("speed_m_s", "block_mass_kg", "height_m", "gain_scale") and lo <= 0:
        raise ScenarioError(f"sweep axis {name} ({AXES[name]}) must be > 0; got {lo}")
    return tuple(out)


def linspace_spec(name: str, value: Mapping) -> tuple[float, ...]:
    """``{start, stop, num}`` -> ``num`` evenly spaced values from start to stop, both included."""
    keys = {"start", "stop", "num"}
    if set(value) != keys:
        raise ScenarioError(f"sweep axis {name}: a range needs exactly the keys start, stop, num; "
                            f"got {sorted(value)}")
    num = value["num"]
    if not isinstance(num, int) or isinstance(num, bool) or num < 1:
        raise ScenarioError(f"sweep axis {name}: num must be an integer >= 1; got {num!r}")
    return tuple(float(x) for x in np.linspace(float(value["start"]), float(value["stop"]), num))


def parse_axis(name: str, text: str) -> tuple[float, ...]:
    """Command-line axis syntax: ``4.5``, ``1,2,4`` or ``START:STOP:NUM`` (both ends included)."""
    text = text.strip()
    try:
        if ":" in text:
            parts = text.split(":")
            if len(parts) != 3:
                raise ValueError
            return _axis_values(name, {"start": float(parts[0]), "stop": float(parts[1]),
                                       "num": int(parts[2])})
        return _axis_values(name, [float(p) for p in text.split(",") if p.strip()])
    except ValueError:
        raise ScenarioError(f"sweep axis {name} ({AXES[name]}): expected a number, a comma list "
                            f"such as 1,2,4 or START:STOP:NUM such as 0:315:8; got {text!r}") from None


@dataclass(frozen=True)
class SweepSpec:
    """A sweep: axes (name -> values), a base scenario, grid or random sample.

    axes: any of :data:`AXES`; a missing axis takes W's throw (:data:`W_THROW`), except
        ``block_mass_kg`` which takes the base scenario's. Values are numbers, lists or
        ``{start, stop, num}``.
    base: every scenario key that is not swept (duration, controller, torque limits, ...).
    samples: ``None`` for the full grid (the Cartesian product, direction varying fastest);
        an integer N for N trials drawn uniformly between each axis's smallest and largest
        value, from ``numpy.random.default_rng(seed)``.
    launch_distance_m: horizontal distance from the aim line at which the block starts (W's
        block starts 0.51 m from the body's COM line).
    torque_limits: ``"none"`` (W) or ``"human"`` (:mod:`biped.control.limits`), clipping the
        torques of either controller (``base.controller``: ``"workspace"`` or ``"joint-pd"``).
    """

    axes: Any = dataclasses.field(default_factory=dict)
    base: Scenario = dataclasses.field(default_factory=Scenario)
    samples: int | None = None
    seed: int = 0
    launch_distance_m: float = 0.5
    model: str = "wendlandt"
    torque_limits: str = "none"

    def __post_init__(self):
        if not isinstance(self.base, Scenario):
            raise ScenarioError(f"base must be a biped.sim.scenario.Scenario; got {type(self.base)}")
        given = dict(self.axes.items() if isinstance(self.axes, Mapping) else self.axes)
        defaults = dict(W_THROW, block_mass_kg=self.base.block_mass_kg)
        axes = tuple((name, _axis_values(name, given[name]) if name in given else
                      (float(defaults[name]),)) for name in AXES)
        for name, value in given.items():
            _axis_values(name, value)  # unknown names raise here
        object.__setattr__(self, "axes", axes)
        if self.samples is not None and (not isinstance(self.samples, int)
                                         or isinstance(self.samples, bool) or self.samples < 1):
            raise ScenarioError(f"samples must be None (full grid) or an integer >= 1; "
                                f"got {self.samples!r}")
        if not isinstance(self.seed, int) or self.seed < 0:
            raise ScenarioError(f"seed must be an integer >= 0; got {self.seed!r}")
        if not (math.isfinite(self.launch_distance_m) and self.launch_distance_m > 0.2):
            raise ScenarioError(f"launch_distance_m must be > 0.2 m (outside the body); "
                                f"got {self.launch_distance_m!r}")
        from biped import models
        from biped.control.limits import KINDS
        models.path(self.model)  # unknown model names raise ModelError listing the valid ones
        if self.torque_limits not in KINDS:
            raise ScenarioError(f"torque_limits must be one of {', '.join(map(repr, KINDS))}; "
                                f"got {self.torque_limits!r}")
        if self.base.torque_limits != "none":
            raise ScenarioError("set the sweep's torque limits with torque_limits = 'none' | "
                                "'human' (SweepSpec / --torque-limits), not the scenario's "
                                f"torque_limits key (got {self.base.torque_limits!r})")

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_dict(cls, values: Mapping) -> SweepSpec:
        """From ``{"grid": {axis: values}, "scenario": {key: value}, "samples": N, "seed": S,
        "launch_distance_m": L}`` (the TOML layout, see :meth:`from_toml`)."""
        valid = {"grid", "scenario", "samples", "seed", "launch_distance_m", "model",
                 "torque_limits"}
        for k in values:
            if k not in valid:
                raise ScenarioError(f"unknown sweep key {k!r}; valid keys: {', '.join(sorted(valid))}")
        grid = values.get("grid", {})
        if not isinstance(grid, Mapping):
            raise ScenarioError(f"[grid] must be a table of axes ({', '.join(AXES)}); got {grid!r}")
        scen = values.get("scenario", {})
        if not isinstance(scen, Mapping):
            raise ScenarioError(f"[scenario] must be a table of scenario keys; got {scen!r}")
        base = Scenario.from_dict(dict(scen))
        return cls(axes=dict(grid), base=base, samples=values.get("samples"),
                   seed=values.get("seed", 0), launch_distance_m=values.get("launch_distance_m", 0.5),
                   model=values.get("model", "wendlandt"),
                   torque_limits=values.get("torque_limits", "none"))

    @classmethod
    def from_toml(cls, path: str | os.PathLike) -> SweepSpec:
        """A sweep from a TOML file::

            samples = 200            # optional: a random sample instead of the full grid
            seed = 0
            [grid]
            speed_m_s = {start = 1.0, stop = 8.0, num = 8}
            direction_deg = [0, 45, 90, 135, 180, 225, 270, 315]
            block_mass_kg = 1.8
            [scenario]               # any key of biped.sim.scenario.Scenario
            duration_s = 3.0
            controller = "workspace"
        """
        path = Path(path)
        try:
            values = tomllib.loads(path.read_text())
        except OSError as exc:
            raise ScenarioError(f"cannot read sweep file {str(path)!r}: {exc.strerror}") from None
        except tomllib.TOMLDecodeError as exc:
            raise ScenarioError(f"sweep file {str(path)!r} is not valid TOML: {exc}") from None
        return cls.from_dict(values)

    def with_axes(self, **axes) -> SweepSpec:
        """A copy with some axes replaced."""
        return dataclasses.replace(self, axes={**dict(self.axes), **axes})

    # ------------------------------------------------------------------ identity
    def to_dict(self) -> dict:
        return {"grid": {k: list(v) for k, v in self.axes}, "scenario": self.base.to_dict(),
                "samples": self.samples, "seed": self.seed,
                "launch_distance_m": self.launch_distance_m, "model": self.model,
                "torque_limits": self.torque_limits}

    @property
    def model_path(self) -> Path:
        from biped import models
        from biped.models.subject import resolve
        return resolve(self.base.model) if self.base.model != "wendlandt" else models.path(self.model)

    @property
    def model_sha256(self) -> str:
        return hashlib.sha256(self.model_path.read_bytes()).hexdigest()

    @property
    def identity(self) -> str:
        """Hash of what makes two trials with equal parameters the same experiment."""
        ident = {"scenario": self.base.to_dict(), "launch_distance_m": self.launch_distance_m,
                 "model_sha256": self.model_sha256, "torque_limits": self.torque_limits,
                 "schema": SCHEMA_VERSION}
        return hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()[:16]

    # ------------------------------------------------------------------ trials
    def trials(self) -> tuple[Trial, ...]:
        """Every trial of the sweep, in a fixed order (index 0, 1, ...)."""
        names = list(AXES)
        values = dict(self.axes)
        if self.samples is None:
            # direction fastest, then speed, mass, height, gain: a partial sweep covers the polar map
            order = ["gain_scale", "height_m", "block_mass_kg", "speed_m_s", "direction_deg"]
            points = [dict(zip(order, combo))
                      for combo in itertools.product(*(values[n] for n in order))]
        else:
            rng = np.random.default_rng(self.seed)
            draws = {n: rng.uniform(min(values[n]), max(values[n]), self.samples) for n in names}
            points = [{n: float(draws[n][i]) for n in names} for i in range(self.samples)]
        ident = self.identity
        out = []
        for i, p in enumerate(points):
            p = {n: float(p[n]) for n in names}
            key = hashlib.sha256(json.dumps([ident, [repr(p[n]) for n in names]]).encode()
                                 ).hexdigest()[:20]
            out.append(Trial(index=i, key=key, **p))
        return tuple(out)

    def scenario(self, trial: Trial) -> Scenario:
        """The full scenario of one trial: the base with the block aimed and the gains scaled."""
        return trial_scenario(self.base, trial, launch_distance_m=self.launch_distance_m)

    def setup(self, trial: Trial) -> TrialSetup:
        return TrialSetup(self.scenario(trial), trial, self.torque_limits)


def hold_scenario(base: Scenario | None = None) -> Scenario:
    """``base`` (W's scenario by default) with the set point moved to the initial state: COM at
    ``initial_com_m``, ``initial_tilt_deg`` about -y. The task of ``biped sweep``'s default
    ``--task hold``: the same job for W's controller and for the joint-space PD baseline (which
    holds the initial joint angles), so their envelopes compare like with like."""
    base = base or Scenario()
    return base.with_overrides(target_com_m=base.initial_com_m,
                               target_tilt_deg=base.initial_tilt_deg, target_axis="-y")


def aim_block(target_xy, speed_m_s: float, direction_deg: float, height_m: float,
              launch_distance_m: float = 0.5, gravity: float = GRAVITY):
    """Start position [m] and velocity [m/s] (world frame) of a block aimed at a vertical line.

    The block travels in direction ``u = (cos a, sin a, 0)`` (a = direction_deg) at horizontal
    speed v. It starts ``L = launch_distance_m`` before the aim line, ``p0 = (target_xy - L u,
    height_m)``, with the vertical velocity ``v_z = g T / 2``, ``T = L / v``, that brings it back
    to ``height_m`` on the aim line at ``T`` under gravity (a flat ballistic arc; the body's
    surface is reached a little earlier and a little higher).
    """
    a = math.radians(direction_deg)
    ux, uy = math.cos(a), math.sin(a)
    T = launch_distance_m / speed_m_s
    p0 = (float(target_xy[0] - launch_distance_m * ux), float(target_xy[1] - launch_distance_m * uy),
          float(height_m))
    v0 = (float(speed_m_s * ux), float(speed_m_s * uy), float(0.5 * gravity * T))
    return p0, v0


def trial_scenario(base: Scenario, trial: Trial, *, launch_distance_m: float = 0.5) -> Scenario:
    """``base`` with the block of ``trial`` aimed at the initial COM line and the gains scaled."""
    p0, v0 = aim_block(base.initial_com_m[:2], trial.speed_m_s, trial.direction_deg,
                       trial.height_m, launch_distance_m)
    s, r = trial.gain_scale, math.sqrt(trial.gain_scale)
    return base.with_overrides(
        block_mass_kg=trial.block_mass_kg, block_position_m=p0, block_velocity_m_s=v0,
        kp_com=tuple(k * s for k in base.kp_com), kv_com=tuple(k * r for k in base.kv_com),
        kp_rot=tuple(k * s for k in base.kp_rot), kv_rot=tuple(k * r for k in base.kv_rot))


# ---------------------------------------------------------------------------------------------
# one row per trial

def _schema():
    import pyarrow as pa

    f64, b = pa.float64(), pa.bool_()
    return pa.schema([
        ("trial_key", pa.string()), ("index", pa.int64()),
        ("speed_m_s", f64), ("direction_deg", f64), ("block_mass_kg", f64), ("height_m", f64),
        ("gain_scale", f64), ("controller", pa.string()), ("torque_limits", pa.string()),
        ("recovered", b), ("fell", b),
        ("impulse_n_s", f64), ("impulse_horizontal_n_s", f64),
        ("impulse_x_n_s", f64), ("impulse_y_n_s", f64), ("impulse_z_n_s", f64),
        ("block_contact_time_s", f64), ("max_com_excursion_m", f64), ("time_to_recover_s", f64),
        ("final_com_error_m", f64), ("final_orientation_error_deg", f64),
        ("left_lift_off", b), ("right_lift_off", b), ("lift_off_count", pa.int64()),
        ("max_foot_lift_m", f64), ("left_slip_m", f64), ("right_slip_m", f64),
        ("peak_torque_n_m", f64), ("simulated_time_s", f64),
        ("completed", b), ("fall_reason", pa.string()), ("controller_error", pa.string()),
        ("diverged", pa.string()),
        ("error", pa.string()), ("wall_time_s", f64), ("worker", pa.string()),
    ])


#: Columns a trial function returns (the measured ones); every other column comes from the sweep.
MEASURED = ("recovered", "fell", "impulse_n_s", "impulse_horizontal_n_s", "impulse_x_n_s",
            "impulse_y_n_s", "impulse_z_n_s", "block_contact_time_s", "max_com_excursion_m",
            "time_to_recover_s", "final_com_error_m", "final_orientation_error_deg",
            "left_lift_off", "right_lift_off", "lift_off_count", "max_foot_lift_m",
            "left_slip_m", "right_slip_m", "peak_torque_n_m", "simulated_time_s", "completed",
            "fall_reason", "controller_error", "diverged")


def execute_trial(trial_fn: Callable[[TrialSetup], Mapping], setup: TrialSetup) -> dict:
    """Run one trial and return its row. An exception of the trial becomes the row's ``error``
    (``"ExceptionType: message"``) with the measured columns empty; it is never lost.
    (KeyboardInterrupt and SystemExit are not trial errors: they propagate.)"""
    t0 = time.perf_counter()
    trial = setup.trial
    row: dict[str, Any] = {"trial_key": trial.key, "index": trial.index, **trial.params(),
                           "controller": setup.scenario.controller,
                           "torque_limits": setup.torque_limits}
    try:
        measured = dict(trial_fn(setup))
        unknown = set(measured) - set(MEASURED)
        if unknown:
            raise ScenarioError(f"trial function returned unknown columns {sorted(unknown)}; "
                                f"valid: {', '.join(MEASURED)}")
        row.update(measured)
        row["error"] = None
    except Exception as exc:  # noqa: BLE001 - a crashed trial is a result, recorded with its error
        row["error"] = f"{type(exc).__name__}: {exc}"
    row["wall_time_s"] = time.perf_counter() - t0
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return row


def _execute_many(trial_fn, setups) -> list[dict]:
    return [execute_trial(trial_fn, s) for s in setups]


# ---------------------------------------------------------------------------------------------
# storage: parts, then one consolidated file

def parts_dir(out: Path) -> Path:
    return out.with_name(out.name + ".parts")


class _PartsWriter:
    """Buffers rows and writes them as small Parquet files (write to a temporary name, then an
    atomic rename: a part is either complete or absent)."""

    def __init__(self, directory: Path, flush_rows: int, flush_s: float):
        self.dir = directory
        self.rows: list[dict] = []
        self.flush_rows, self.flush_s = flush_rows, flush_s
        self.last = time.monotonic()
        self.seq = 0

    def add(self, row: dict) -> None:
        self.rows.append(row)
        if len(self.rows) >= self.flush_rows or time.monotonic() - self.last >= self.flush_s:
            self.flush()

    def flush(self) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        self.last = time.monotonic()
        if not self.rows:
            return
        table = pa.Table.from_pylist(self.rows, schema=_schema())
        name = f"part-{time.time_ns():020d}-{os.getpid()}-{self.seq:06d}.parquet"
        self.seq += 1
        tmp = self.dir / (name + ".tmp")
        pq.write_table(table, tmp)
        os.replace(tmp, self.dir / name)
        self.rows = []


def _metadata(spec: SweepSpec) -> dict[bytes, bytes]:
    from biped import __version__

    return {b"biped.sweep": json.dumps(spec.to_dict()).encode(),
            b"biped.scenario": spec.base.to_toml().encode(),
            b"biped.model": (spec.model if spec.base.model == "wendlandt" else spec.base.model).encode(),
            b"biped.model_sha256": spec.model_sha256.encode(),
            b"biped.version": __version__.encode(),
            b"biped.sweep_id": spec.identity.encode()}


def _read_rows(paths: Iterable[Path]):
    import pyarrow as pa
    import pyarrow.parquet as pq

    tables = [pq.read_table(p, schema=_schema()) for p in paths]
    return pa.concat_tables(tables) if tables else _schema().empty_table()


def _part_files(directory: Path) -> list[Path]:
    return sorted(directory.glob("part-*.parquet")) if directory.is_dir() else []


def _check_same_sweep(spec: SweepSpec, out: Path, overwrite: bool) -> None:
    import pyarrow.parquet as pq

    pdir = parts_dir(out)
    if overwrite:
        if out.exists():
            out.unlink()
        if pdir.exists():
            shutil.rmtree(pdir)
        return
    ident = spec.identity
    if out.exists():
        try:
            meta = pq.read_schema(out).metadata or {}
        except Exception as exc:  # noqa: BLE001
            raise ScenarioError(f"--out {str(out)!r} exists and is not a readable Parquet file "
                                f"({exc}); choose another path or overwrite it") from None
        if meta.get(b"biped.sweep_id", b"").decode() != ident:
            raise ScenarioError(
                f"--out {str(out)!r} holds a different sweep (another base scenario, launch "
                f"distance or model file); choose another path or pass --overwrite")
    manifest = pdir / "sweep.json"
    if manifest.exists() and json.loads(manifest.read_text()).get("sweep_id") != ident:
        raise ScenarioError(
            f"{str(pdir)!r} holds the unfinished parts of a different sweep; choose another "
            f"--out or pass --overwrite")


def _done_rows(out: Path):
    files = ([out] if out.exists() else []) + _part_files(parts_dir(out))
    return _read_rows(files)


def _consolidate(spec: SweepSpec, out: Path, trials: tuple[Trial, ...]) -> int:
    """Write every finished trial (last record of each key) into ONE Parquet file, sorted by
    trial index, with the sweep's metadata; remove the parts. Returns the number of rows."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    rows = _done_rows(out).to_pylist()
    last = {r["trial_key"]: r for r in rows}
    wanted = {t.key for t in trials}
    rows = sorted((r for k, r in last.items() if k in wanted), key=lambda r: r["index"])
    schema = _schema().with_metadata(_metadata(spec))
    table = pa.Table.from_pylist(rows, schema=schema)
    tmp = out.with_name(out.name + ".tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, out)
    shutil.rmtree(parts_dir(out), ignore_errors=True)
    return table.num_rows


# ---------------------------------------------------------------------------------------------
# running

@dataclass(frozen=True)
class SweepSummary:
    """What :func:`run_sweep` did.

    path: the consolidated Parquet file (written only when ``complete``).
    total: trials in the sweep; skipped: already done before this run; ran: finished in this run;
    failed: trials of this run that raised (recorded with their error); lost: trials whose
    worker died (not recorded: rerun the same command to finish them); complete: every trial
    has a row; wall_time_s: this run's wall time.
    """

    path: Path
    total: int
    skipped: int
    ran: int
    failed: int
    lost: int
    complete: bool
    wall_time_s: float
    backend: str


def default_workers() -> int:
    """Usable local cores (the process's CPU affinity where the OS tells it)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def run_sweep(spec: SweepSpec, out: str | os.PathLike, *, workers: int | None = None,
              scheduler: Any = None, trial_fn: Callable[[TrialSetup], Mapping] | None = None,
              progress: bool = True, retry_failed: bool = False, overwrite: bool = False,
              batch: int = 1, flush_rows: int = 64, flush_s: float = 2.0) -> SweepSummary:
    """Run every trial of ``spec`` that ``out`` does not hold yet; write ONE Parquet file.

    workers: local processes (default: every usable core); 1 runs in this process.
    scheduler: a Dask scheduler address (``"tcp://host:8786"``) or a ``dask.distributed.Client``;
        when given, trials run on that cluster instead (every worker needs ``biped`` installed).
    trial_fn: ``f(setup: TrialSetup) -> {column: value}`` for the columns in :data:`MEASURED`;
        default :func:`run_trial` (the push simulation, then :func:`measure`). It must be
        importable by name (a module-level function) for processes and Dask.
    retry_failed: rerun trials recorded with an error.
    batch: trials per task (more amortises the task overhead on a remote cluster).
    Interrupting (Ctrl-C) flushes every finished trial before the exception propagates.
    """
    out = Path(out)
    if out.suffix != ".parquet":
        raise ScenarioError(f"--out must name a .parquet file; got {str(out)!r}")
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise ScenarioError(f"workers must be an integer >= 1; got {workers!r}")
    if not isinstance(batch, int) or batch < 1:
        raise ScenarioError(f"batch must be an integer >= 1; got {batch!r}")
    trial_fn = trial_fn or run_trial
    t_start = time.perf_counter()
    out.parent.mkdir(parents=True, exist_ok=True)
    _check_same_sweep(spec, out, overwrite)
    trials = spec.trials()
    done_rows = _done_rows(out)
    done = {}
    for key, err in zip(done_rows.column("trial_key").to_pylist(), done_rows.column("error").to_pylist()):
        done[key] = err
    wanted = {t.key for t in trials}
    todo = [t for t in trials
            if t.key not in done or (retry_failed and done[t.key] is not None)]
    skipped = len(trials) - len(todo)
    pdir = parts_dir(out)
    if todo:
        pdir.mkdir(exist_ok=True)
        (pdir / "sweep.json").write_text(json.dumps({"sweep_id": spec.identity,
                                                     "sweep": spec.to_dict()}))
    failed_before = sum(1 for k, e in done.items() if k in wanted and e is not None
                        and not retry_failed)
    writer = _PartsWriter(pdir, flush_rows, flush_s)
    bar = None
    if progress:
        from tqdm.auto import tqdm
        bar = tqdm(total=len(trials), initial=skipped, unit="trial", desc="sweep", smoothing=0.05)
        bar.set_postfix(failed=failed_before)
    counts = {"ran": 0, "failed": 0}

    def record(rows):
        for row in rows:
            writer.add(row)
            counts["ran"] += 1
            counts["failed"] += row["error"] is not None
        if bar is not None:
            bar.update(len(rows))
            bar.set_postfix(failed=failed_before + counts["failed"])

    chunks = [todo[i:i + batch] for i in range(0, len(todo), batch)]
    lost = 0
    try:
        if not chunks:
            backend = "none"
        elif scheduler is not None:
            backend = "dask"
            lost = _run_dask(scheduler, trial_fn, spec, chunks, record)
        elif (workers or default_workers()) == 1 or len(todo) == 1:
            backend = "serial"
            for chunk in chunks:
                record(_execute_many(trial_fn, [spec.setup(t) for t in chunk]))
        else:
            backend = f"processes:{workers or default_workers()}"
            lost = _run_processes(workers or default_workers(), trial_fn, spec, chunks, record)
    finally:
        writer.flush()
        if bar is not None:
            bar.close()
    complete = lost == 0
    if complete:
        _consolidate(spec, out, trials)
    return SweepSummary(path=out, total=len(trials), skipped=skipped, ran=counts["ran"],
                        failed=counts["failed"], lost=lost, complete=complete,
                        wall_time_s=time.perf_counter() - t_start, backend=backend)


def _run_processes(workers: int, trial_fn, spec: SweepSpec, chunks, record) -> int:
    """Local processes ('spawn': no inherited threads or locks). Returns the trials lost to a
    dead worker (all pending ones: a broken pool cannot run anything more)."""
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    lost = 0
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"))
    try:
        pending = {pool.submit(_execute_many, trial_fn, [spec.setup(t) for t in c]): len(c)
                   for c in chunks}
        while pending:
            finished, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in finished:
                n = pending.pop(fut)
                try:
                    rows = fut.result()
                except BrokenProcessPool:
                    lost += n
                    continue
                record(rows)
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)
    return lost


def _run_dask(scheduler, trial_fn, spec: SweepSpec, chunks, record) -> int:
    """Dask: one task per chunk. A task whose workers keep dying (dask's KilledWorker) is lost,
    not recorded; the others go on."""
    from dask.distributed import Client, as_completed

    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    own = client is not scheduler
    lost = 0
    try:
        futures = {client.submit(_execute_many, trial_fn, [spec.setup(t) for t in c],
                                 pure=False): len(c) for c in chunks}
        try:
            for fut in as_completed(list(futures)):
                try:
                    rows = fut.result()
                except Exception:  # noqa: BLE001 - the worker died (trial errors are rows)
                    lost += futures[fut]
                    continue
                record(rows)
        except BaseException:
            client.cancel(list(futures))
            raise
    finally:
        if own:
            client.close()
    return lost


# ---------------------------------------------------------------------------------------------
# reading

@dataclass(frozen=True)
class SweepData:
    """A consolidated sweep file: its table (pyarrow) and metadata."""

    table: Any
    spec: dict
    scenario: Scenario
    model_sha256: str
    version: str

    def column(self, name: str) -> np.ndarray:
        return np.asarray(self.table.column(name).to_numpy(zero_copy_only=False))


def load(path: str | os.PathLike) -> SweepData:
    """Read a sweep's Parquet file (one row per trial) and its metadata."""
    import pyarrow.parquet as pq

    path = Path(path)
    if not path.is_file():
        raise ScenarioError(f"no sweep file at {str(path)!r}")
    table = pq.read_table(path)
    meta = table.schema.metadata or {}
    if b"biped.sweep" not in meta:
        raise ScenarioError(f"{str(path)!r} is not a biped sweep file (no biped.sweep metadata)")
    spec = json.loads(meta[b"biped.sweep"])
    return SweepData(table=table, spec=spec, scenario=Scenario.from_dict(spec["scenario"]),
                     model_sha256=meta[b"biped.model_sha256"].decode(),
                     version=meta[b"biped.version"].decode())


# ---------------------------------------------------------------------------------------------
# the real trial: the push simulation of biped.sim.push, then the measurements

_SCENES: dict = {}
_TREES: dict = {}
_CACHE_SIZE = 16


def _scene_for(scenario: Scenario):
    """A compiled push scene for ``scenario``, cached per process: the scene depends only on the
    keys below (the block's start position and velocity are set in the initial state)."""
    from biped.sim.scene import build_scene

    key = (scenario.physics_timestep_s, scenario.restitution, scenario.contact_timeconst_s,
           scenario.friction, scenario.block_size_m, scenario.block_mass_kg, scenario.model)
    scene = _SCENES.get(key)
    if scene is None:
        if len(_SCENES) >= _CACHE_SIZE:
            _SCENES.pop(next(iter(_SCENES)))
        scene = _SCENES[key] = build_scene(scenario)
    return scene


def _tree(model: str):
    from biped.model import TreeModel
    from biped.models.subject import resolve

    if model not in _TREES:
        _TREES[model] = TreeModel.from_mjcf(resolve(model))
    return _TREES[model]


def make_policy(setup: TrialSetup, scene, model: str | None = None):
    """``policy(qpos_biped, qvel_biped, feet) -> torques (12,)`` in ``scene.joint_names`` order for the
    trial's controller (W's workspace controller with the scenario's set point and gains, or the
    joint-space PD of :mod:`biped.control.joint_pd` holding the initial joint angles, its gains
    times ``gain_scale``), clipped by the sweep's torque limits."""
    from biped.control.limits import clip_torques, torque_limits

    sc = setup.scenario
    model = model or sc.model
    if sc.controller == "workspace":
        from biped.sim.push import workspace_policy

        ctrl, raw = workspace_policy(sc, _tree(model))
    elif sc.controller == "joint-pd":
        from biped.control.joint_pd import JointPDController
        from biped.models.subject import resolve

        ctrl = JointPDController.from_mjcf(
            resolve(model), q_ref_deg=sc.initial_joint_angles_deg,
            gain_scale=setup.trial.gain_scale, control_period_s=1.0 / sc.control_rate_hz)
        raw = lambda q, v, feet: ctrl.compute(q, v).torques
    else:  # pragma: no cover - Scenario validates the name
        raise ScenarioError(f"unknown controller {sc.controller!r}")
    names = tuple(ctrl.joint_names)
    order = np.array([names.index(n) for n in scene.joint_names])
    limits = torque_limits(setup.torque_limits).reorder(scene.joint_names)
    if limits.unlimited:
        return lambda q, v, feet: raw(q, v, feet)[order]
    return lambda q, v, feet: clip_torques(raw(q, v, feet)[order], limits)


def run_trial(setup: TrialSetup) -> dict:
    """Simulate one push (the closed loop of :mod:`biped.sim.push` on its MuJoCo scene) and
    measure it (:func:`measure`). Ctrl-C during the trial propagates (the trial is not recorded)."""
    from biped.sim.push import _run

    sc = setup.scenario
    scene = _scene_for(sc)
    policy = make_policy(setup, scene)
    bv = scene.block_qvel_index[:3]
    vel = [np.array(sc.block_velocity_m_s, dtype=float)]

    def on_step(m, d):
        vel.append(d.qvel[bv].copy())

    result = _run(sc, scene, policy, on_step=on_step)
    if result.interrupted:
        raise KeyboardInterrupt
    n = len(result.times)
    return measure(result, np.array(vel[:n]), scene=scene)


def ballistic_impulse(times, velocity, mass_kg: float, gravity=(0.0, 0.0, -GRAVITY),
                      contact_time_s: float | None = None, tol: float = 1e-6):
    """Impulse [N s] (3,) delivered BY a free-flying block TO what it hits, from its momentum
    change: ``J = -m (u_after - u_before)``, ``u = v - g t``.

    ``times`` (n,) [s], ``velocity`` (n, 3) [m/s] of the block's centre of mass (world frame)
    sampled at a fixed rate. In free flight ``u`` is constant (only gravity acts), so the
    ballistic invariant before the first contact and on the first free-flight stretch after it
    (``u`` constant over 3 samples) give the momentum change due to the contact alone, wherever
    the samples fall relative to the impact. Returns (J, t_first_deviation); J is NaN when the
    block never flies free again (it stays in contact) and zero when it never touches anything.
    ``contact_time_s``, when given, must match the first deviation within two samples (else the
    block hit something else first and J is NaN).
    """
    t = np.asarray(times, dtype=float)
    v = np.asarray(velocity, dtype=float)
    u = v - np.outer(t, np.asarray(gravity, dtype=float))
    dev = np.linalg.norm(u - u[0], axis=1) > tol * max(1.0, float(np.linalg.norm(u[0])))
    if not dev.any():
        return np.zeros(3), None
    k1 = int(np.argmax(dev))
    t1 = float(t[k1])
    if contact_time_s is not None and len(t) > 1:
        dt = float(t[1] - t[0])
        if abs(t1 - contact_time_s) > 2.01 * dt:
            return np.full(3, np.nan), t1
    step = np.linalg.norm(np.diff(u, axis=0), axis=1)
    free = step <= tol * max(1.0, float(np.linalg.norm(u[0])))
    for k in range(k1, len(u) - 2):
        if free[k] and free[k + 1]:
            return -mass_kg * (u[k] - u[0]), t1
    return np.full(3, np.nan), t1


def measure(result, block_velocity: np.ndarray, *, scene=None) -> dict:
    """The sweep's columns (:data:`MEASURED`) from one :class:`biped.sim.push.PushResult`.

    impulse_*: :func:`ballistic_impulse` of the block's velocity at the control rate.
    max_com_excursion_m: largest horizontal distance of the central-body COM from the set
        point after the block's first contact (whole run if it never hits).
    time_to_recover_s: from the first contact to the last moment the COM error reaches
        ``recovery_com_tol_m`` or the orientation error ``recovery_orientation_tol_deg``;
        NaN unless ``recovered``.
    left/right_lift_off, lift_off_count: ``lift_off`` events (heel or toe) after the contact.
    left/right_slip_m, max_foot_lift_m: largest horizontal displacement / rise of each foot
        body (MuJoCo kinematics of the recorded qpos) from where it stood once both its heel
        and toe first touched the floor (a slide or a step).
    """
    from biped.sim.push import orientation_error_deg

    sc = result.scenario
    t = result.times
    n = len(t)
    tc = result.block_contact_time_s
    J, _ = ballistic_impulse(t, block_velocity[:n], sc.block_mass_kg, contact_time_s=tc)
    after = t >= (tc if tc is not None else -np.inf)
    d_xy = np.linalg.norm(result.com[:, :2] - result.target_com[:2], axis=1)
    max_exc = float(d_xy[after].max()) if after.any() else float("nan")
    ttr = float("nan")
    if result.recovered and n:
        com_err = np.linalg.norm(result.com - result.target_com, axis=1)
        ori_err = np.array([orientation_error_deg(q, result.target_quat) for q in result.quat])
        bad = (com_err >= sc.recovery_com_tol_m) | (ori_err >= sc.recovery_orientation_tol_deg)
        t0 = tc if tc is not None else 0.0
        bad &= t >= t0
        ttr = float(t[np.flatnonzero(bad)[-1] + 1] - t0) if bad.any() else 0.0
    t_after = tc if tc is not None else float("inf")
    lifts = [e for e in result.events if e.kind == "lift_off" and e.time_s >= t_after]
    slip, rise = _foot_motion(result, scene)
    return {
        "recovered": bool(result.recovered), "fell": bool(result.fell),
        "impulse_n_s": float(np.linalg.norm(J)), "impulse_horizontal_n_s": float(np.hypot(J[0], J[1])),
        "impulse_x_n_s": float(J[0]), "impulse_y_n_s": float(J[1]), "impulse_z_n_s": float(J[2]),
        "block_contact_time_s": float(tc) if tc is not None else float("nan"),
        "max_com_excursion_m": max_exc, "time_to_recover_s": ttr,
        "final_com_error_m": float(result.final_com_error_m),
        "final_orientation_error_deg": float(result.final_orientation_error_deg),
        "left_lift_off": any(e.foot == "left" for e in lifts),
        "right_lift_off": any(e.foot == "right" for e in lifts),
        "lift_off_count": len(lifts), "max_foot_lift_m": rise,
        "left_slip_m": slip[0], "right_slip_m": slip[1],
        "peak_torque_n_m": float(np.abs(result.torques).max()) if n else float("nan"),
        "simulated_time_s": float(t[-1]) if n else 0.0,
        "completed": bool(n and t[-1] >= sc.duration_s - 0.5 / sc.control_rate_hz
                          and not result.interrupted),
        "fall_reason": result.fall_reason, "controller_error": result.controller_error,
        "diverged": getattr(result, "diverged", None),
    }


def _foot_motion(result, scene) -> tuple[tuple[float, float], float]:
    """((left slip, right slip) [m], max foot rise [m]); see :func:`measure`."""
    import mujoco

    if scene is None:
        scene = _scene_for(result.scenario)
    m = scene.model
    d = mujoco.MjData(m)
    feet = [m.body(f"{side}_foot").id for side in ("left", "right")]
    n = len(result.times)
    pos = np.zeros((n, 2, 3))
    for k in range(n):
        d.qpos[:] = result.qpos[k]
        mujoco.mj_kinematics(m, d)
        pos[k] = d.xpos[feet]
    slips, rise = [], 0.0
    for i, flags in enumerate((result.contacts[:, 0:2], result.contacts[:, 2:4])):
        planted = np.flatnonzero(flags.all(axis=1))
        if not len(planted):
            slips.append(float("nan"))
            continue
        k0 = planted[0]
        ref = pos[k0, i]
        slips.append(float(np.linalg.norm(pos[k0:, i, :2] - ref[:2], axis=1).max()))
        rise = max(rise, float((pos[k0:, i, 2] - ref[2]).max()))
    return (slips[0], slips[1]), rise


# ---------------------------------------------------------------------------------------------
# envelopes and the feet-in-place bound (computing only; plots in biped.viz.envelope)

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


def survived(table_or_data, criterion: str = "survived") -> np.ndarray:
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


def _columns(table_or_data) -> dict:
    table = getattr(table_or_data, "table", table_or_data)
    if isinstance(table, Mapping):
        return dict(table)
    return {name: table.column(name).to_pylist() for name in table.column_names}


def envelope(table_or_data, by: str = "speed_m_s", criterion: str = "survived",
             bin_deg: float | None = None) -> Envelope:
    """The recovery envelope of a sweep (see :class:`Envelope`); ``by`` is ``"speed_m_s"`` or
    ``"impulse_n_s"`` (rows without a measured impulse are left out). ``bin_deg`` groups the
    directions of a random sample into bins of that width (a grid needs none)."""
    if by not in ("speed_m_s", "impulse_n_s", "impulse_horizontal_n_s"):
        raise ScenarioError(f"by must be 'speed_m_s', 'impulse_n_s' or 'impulse_horizontal_n_s'; "
                            f"got {by!r}")
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


@dataclass(frozen=True)
class FeetInPlaceBound:
    """Hof's feet-in-place bound on the impulse (Hof, Gazendam & Sinke, J. Biomech. 38:1-8,
    2005: the extrapolated centre of mass ``xcom = x + v / omega_0`` must stay inside the base
    of support). An impulse J on a body of mass m changes its COM velocity by J / m, moving the
    XCoM by J / (m omega_0); the feet can hold it while that is at most d, the distance from the
    COM's ground projection to the edge of the support polygon in the push direction:

        J_max = m omega_0 d,     omega_0 = sqrt(g / h)

    directions_deg (k,) push directions (the block's travel); d_m (k,) [m]; j_max_n_s (k,)
    [N s]; mass_kg, com_height_m (h: whole-body COM above the soles), omega0 [1/s];
    com_xy (2,) and polygon_xy (p, 2) (counter-clockwise) [m], world frame.
    """

    directions_deg: np.ndarray
    d_m: np.ndarray
    j_max_n_s: np.ndarray
    mass_kg: float
    com_height_m: float
    omega0: float
    com_xy: np.ndarray
    polygon_xy: np.ndarray

    def speed_equivalent(self, block_mass_kg: float, restitution: float) -> np.ndarray:
        """Block speed [m/s] that delivers J_max in a head-on impact on a much heavier body,
        ``v = J_max / ((1 + e) m_block)`` (the point-mass collision law; an approximation)."""
        return self.j_max_n_s / ((1.0 + restitution) * block_mass_kg)


def ray_to_polygon_edge(point, direction_deg, polygon) -> float:
    """Distance [m] from ``point`` (2,) inside a convex ``polygon`` (p, 2) to its edge along
    the direction ``direction_deg`` (from +x toward +y). Raises if the point is outside."""
    p = np.asarray(point, dtype=float)
    poly = np.asarray(polygon, dtype=float)
    a = math.radians(direction_deg)
    u = np.array([math.cos(a), math.sin(a)])
    best = np.inf
    for i in range(len(poly)):
        q0, q1 = poly[i], poly[(i + 1) % len(poly)]
        e = q1 - q0
        den = u[0] * (-e[1]) - u[1] * (-e[0])
        if abs(den) < 1e-15:
            continue
        r = q0 - p
        t = (r[0] * (-e[1]) - r[1] * (-e[0])) / den
        s = (u[0] * r[1] - u[1] * r[0]) / den
        if t >= -1e-12 and -1e-12 <= s <= 1 + 1e-12:
            best = min(best, t)
    if not np.isfinite(best):
        raise ScenarioError(f"the point {p.tolist()} is outside the support polygon")
    return float(max(best, 0.0))


def hof_bound(directions_deg, mass_kg: float, com_height_m: float, com_xy, polygon_xy,
              gravity: float = GRAVITY) -> FeetInPlaceBound:
    """:class:`FeetInPlaceBound` for given body numbers (closed form, no model)."""
    if not (mass_kg > 0 and com_height_m > 0):
        raise ScenarioError("mass_kg and com_height_m must be > 0")
    dirs = np.asarray(directions_deg, dtype=float)
    omega0 = math.sqrt(gravity / com_height_m)
    d = np.array([ray_to_polygon_edge(com_xy, a, polygon_xy) for a in dirs])
    return FeetInPlaceBound(dirs, d, mass_kg * omega0 * d, float(mass_kg), float(com_height_m),
                            omega0, np.asarray(com_xy, float), np.asarray(polygon_xy, float))


def support_polygon(scenario: Scenario | None = None):
    """(com_xy (2,), com height above the soles [m], biped mass [kg], polygon (p, 2)) of the
    biped at the scenario's initial state: whole-body COM from MuJoCo (``subtree_com`` of the
    central body) and the convex hull of the bottom corners of the four sole boxes."""
    import mujoco
    from scipy.spatial import ConvexHull

    from biped.sim.scene import initial_state

    scenario = scenario or Scenario()
    scene = _scene_for(scenario)
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:], _ = initial_state(scene, scenario)
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    corners = []
    for g in scene.sole_geoms:
        half = m.geom_size[g]
        R = d.geom_xmat[g].reshape(3, 3)
        for sx in (-1, 1):
            for sy in (-1, 1):
                for sz in (-1, 1):
                    corners.append(d.geom_xpos[g] + R @ (half * [sx, sy, sz]))
    corners = np.array(corners)
    z_sole = corners[:, 2].min()
    bottom = corners[corners[:, 2] < z_sole + 1e-3]
    hull = ConvexHull(bottom[:, :2])
    polygon = bottom[hull.vertices, :2]  # counter-clockwise
    biped_bodies = [b for b in range(m.nbody) if b != scene.block_body and b != 0]
    mass = float(sum(m.body_mass[b] for b in biped_bodies))
    com = d.subtree_com[scene.central_body]
    return com[:2].copy(), float(com[2] - z_sole), mass, polygon


def feet_in_place_bound(directions_deg, scenario: Scenario | None = None) -> FeetInPlaceBound:
    """Hof's bound for the shipped biped at the scenario's initial state (W's by default)."""
    com_xy, h, mass, polygon = support_polygon(scenario)
    return hof_bound(directions_deg, mass, h, com_xy, polygon)


__all__ = [
    "AXES",
    "MEASURED",
    "W_THROW",
    "Envelope",
    "FeetInPlaceBound",
    "SweepData",
    "SweepSpec",
    "SweepSummary",
    "Trial",
    "TrialSetup",
    "aim_block",
    "ballistic_impulse",
    "default_workers",
    "envelope",
    "execute_trial",
    "feet_in_place_bound",
    "hof_bound",
    "hold_scenario",
    "load",
    "make_policy",
    "measure",
    "parse_axis",
    "parts_dir",
    "ray_to_polygon_edge",
    "run_sweep",
    "run_trial",
    "support_polygon",
    "survived",
    "trial_scenario",
]
