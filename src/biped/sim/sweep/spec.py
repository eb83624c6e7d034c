"""The definition of a sweep: its axes, its base scenario, its trials, and how each trial's block is
aimed. Pure Python (no MuJoCo): a sweep is checked and its trials listed before any work starts.

Conventions: ``direction_deg`` is the direction the block *travels* in the horizontal plane,
measured from +x toward +y (W's throw travels at 180 deg, along -x: the biped faces -x, so that
block hits its back and pushes it forward). The block is aimed at the vertical line through the
central body's initial COM (see :func:`aim_block`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from biped import models
from biped.control.limits import KINDS as TORQUE_LIMIT_KINDS
from biped.errors import ScenarioError
from biped.sim.scenario import Scenario, read_toml

#: The swept quantities: name -> (unit, what it means).
AXES: dict[str, str] = {
    "speed_m_s": "horizontal block speed [m/s]",
    "direction_deg": "direction the block travels, from +x toward +y [deg]",
    "block_mass_kg": "block mass [kg]",
    "height_m": "height of the block's aim point above the floor [m]",
    "gain_scale": "factor s on the stiffness gains (kp * s) and sqrt(s) on the damping gains "
    "(kv * sqrt(s)), which keeps every damping ratio",
    "magnitude": "the perturbation's size in its own unit: force N (peak), platform m, release deg "
    "(the block's is speed_m_s; scenario key perturbation, docs/perturbations.md)",
}

#: W's throw (section 4) in sweep coordinates: 1.8 kg at 4.5 m/s along -x, 1.2 m high.
W_THROW = {
    "speed_m_s": 4.5,
    "direction_deg": 180.0,
    "block_mass_kg": 1.8,
    "height_m": 1.2,
    "gain_scale": 1.0,
    "magnitude": 0.0,  # unused by the block; another paradigm's default: its base scenario's size
}
#: The axes a block sweep's trial keys hash (those before the paradigms existed: its keys stay).
#: torque limits of a robot sweep: its joints' ``actuatorfrcrange`` inside the QP, or none.
ROBOT_TORQUE_LIMITS = ("model", "none")
BLOCK_AXES = ("speed_m_s", "direction_deg", "block_mass_kg", "height_m", "gain_scale")

#: Axis values are kept to this many significant digits, so that ``1:2:11`` and the same values
#: typed as a list (1.7, not 1.7000000000000002) are the same trials; two sweeps' values are the
#: same when they agree to :data:`GRID_RTOL` (relative).
AXIS_DIGITS = 12
GRID_RTOL = 1e-9

#: The most trials one sweep may hold (a grid's product or ``samples``): a bound on the work and
#: the memory asked for by a typo such as ``num = 100000000``. Split larger studies into sweeps.
MAX_TRIALS = 1_000_000

GRAVITY = float(-models.gravity("wendlandt")[2])  # [m/s^2], the biped model's, which the scene keeps
SCHEMA_VERSION = 1


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
    magnitude: float = 0.0

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
    #: a robot's MJCF (:mod:`biped.models.robot`) the trial runs on instead of the scenario's
    #: biped ("" for W's structure); its trials run :func:`biped.sim.robot_trial.run_robot_trial`
    robot: str = ""


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def _axis_values(name: str, value: Any) -> tuple[float, ...]:
    if name not in AXES:
        raise ScenarioError(f"unknown sweep axis {name!r}; valid axes: {', '.join(AXES)}")
    if isinstance(value, Mapping):
        value = linspace_spec(name, value)
    if _is_number(value):
        value = (value,)
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        raise ScenarioError(
            f"sweep axis {name} ({AXES[name]}) must be a number, a list of numbers "
            f"or {{start, stop, num}}; got {value!r}"
        )
    out = []
    for v in value:
        if not _is_number(v) or not math.isfinite(float(v)):
            raise ScenarioError(f"sweep axis {name} ({AXES[name]}) must hold finite numbers; got {v!r}")
        out.append(float(f"{float(v):.{AXIS_DIGITS}g}"))
        if len(out) > MAX_TRIALS:
            raise ScenarioError(
                f"sweep axis {name} has more than {MAX_TRIALS} values (the most a sweep may hold)"
            )
    if not out:
        raise ScenarioError(f"sweep axis {name} ({AXES[name]}) is empty; give at least one value")
    lo = min(out)
    if name == "direction_deg" and max(abs(lo), abs(max(out))) > 360:
        bad = lo if abs(lo) > 360 else max(out)
        raise ScenarioError(f"sweep axis {name} ({AXES[name]}) must be in [-360, 360] deg; got {bad:g}")
    if name in ("speed_m_s", "block_mass_kg", "height_m", "gain_scale") and lo <= 0:
        raise ScenarioError(f"sweep axis {name} ({AXES[name]}) must be > 0; got {lo:g}")
    if name == "magnitude" and lo < 0:
        raise ScenarioError(f"sweep axis {name} ({AXES[name]}) must be >= 0; got {lo:g}")
    return tuple(out)


def linspace_spec(name: str, value: Mapping) -> tuple[float, ...]:
    """``{start, stop, num}`` -> ``num`` evenly spaced values from start to stop, both included."""
    keys = {"start", "stop", "num"}
    if set(value) != keys:
        raise ScenarioError(
            f"sweep axis {name}: a range needs exactly the keys start, stop, num; "
            f"got {sorted(map(str, value))}"
        )
    num = value["num"]
    if not isinstance(num, (int, np.integer)) or isinstance(num, bool) or num < 1:
        raise ScenarioError(f"sweep axis {name}: num must be an integer >= 1; got {num!r}")
    if num > MAX_TRIALS:
        raise ScenarioError(
            f"sweep axis {name}: num = {num} is more than {MAX_TRIALS} (the most trials a sweep may hold)"
        )
    for k in ("start", "stop"):
        if not _is_number(value[k]) or not math.isfinite(float(value[k])):
            raise ScenarioError(f"sweep axis {name}: {k} must be a finite number; got {value[k]!r}")
    return tuple(float(x) for x in np.linspace(float(value["start"]), float(value["stop"]), int(num)))


def parse_axis(name: str, text: str) -> tuple[float, ...]:
    """Command-line axis syntax: ``4.5``, ``1,2,4`` or ``START:STOP:NUM`` (both ends included)."""
    text = text.strip()
    try:
        if ":" in text:
            parts = text.split(":")
            if len(parts) != 3:
                raise ValueError
            return _axis_values(
                name, {"start": float(parts[0]), "stop": float(parts[1]), "num": int(parts[2])}
            )
        return _axis_values(name, [float(p) for p in text.split(",") if p.strip()])
    except ScenarioError:  # a number that is out of range: say so (it is also a ValueError)
        raise
    except ValueError:
        raise ScenarioError(
            f"sweep axis {name} ({AXES[name]}): expected a number, a comma list "
            f"such as 1,2,4 or START:STOP:NUM such as 0:315:8; got {text!r}"
        ) from None


def _check_int(name: str, value: Any, lo: int) -> None:
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < lo:
        raise ScenarioError(f"{name} must be an integer >= {lo}; got {value!r}")


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

    At most :data:`MAX_TRIALS` trials.
    """

    axes: Any = dataclasses.field(default_factory=dict)
    base: Scenario = dataclasses.field(default_factory=Scenario)
    samples: int | None = None
    seed: int = 0
    launch_distance_m: float = 0.5
    model: str = "wendlandt"
    torque_limits: str = "none"
    #: a robot's MJCF path (:mod:`biped.models.robot`, ``--model NAME|PATH``): the trials run on it
    #: (W's block moved onto it by ``biped sweep``); "" for W's structure (``base.model``)
    robot: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.base, Scenario):
            raise ScenarioError(f"base must be a biped.sim.scenario.Scenario; got {type(self.base)}")
        if not isinstance(self.axes, (Mapping, Iterable)) or isinstance(self.axes, (str, bytes)):
            raise ScenarioError(f"axes must be a table of sweep axes ({', '.join(AXES)}); got {self.axes!r}")
        given = dict(self.axes.items() if isinstance(self.axes, Mapping) else self.axes)
        for name, value in given.items():
            _axis_values(name, value)  # unknown names and bad values raise here
        # the other paradigm's axes, unless at their defaults (a spec's own axes read back)
        unused = {**W_THROW, "block_mass_kg": self.base.block_mass_kg}
        block_only = [
            n
            for n in ("speed_m_s", "block_mass_kg", "height_m")
            if n in given and _axis_values(n, given[n]) != (float(unused[n]),)
        ]
        if self.base.perturbation != "block" and block_only:
            raise ScenarioError(
                f"sweep axis {block_only[0]} is the block's; perturbation = {self.base.perturbation!r} is "
                "swept by magnitude (--magnitude, in its own unit) and direction_deg"
            )
        if (
            self.base.perturbation == "block"
            and "magnitude" in given
            and _axis_values("magnitude", given["magnitude"]) != (0.0,)
        ):
            raise ScenarioError(
                "sweep axis magnitude is for perturbation = 'force', 'platform' or 'release'; the block's "
                "size is speed_m_s (--speed)"
            )
        defaults = dict(W_THROW, block_mass_kg=self.base.block_mass_kg)
        if self.base.perturbation != "block":
            from biped.sim.perturbations import of

            defaults["magnitude"] = of(self.base).size(1.0).magnitude
        axes = tuple(
            (name, _axis_values(name, given[name]) if name in given else (float(defaults[name]),))
            for name in AXES
        )
        object.__setattr__(self, "axes", axes)
        half = self.base.block_size_m[2] / 2
        low = min(dict(axes)["height_m"])
        if low < half:  # the block starts at the aim height: below half its edge it is in the floor
            raise ScenarioError(
                f"height_m must be >= {half:g} m (half the block's height: it starts at the aim "
                f"height, so lower would start it inside the floor); got {low:g}"
            )
        if self.samples is not None:
            _check_int("samples", self.samples, 1)
            if self.samples > MAX_TRIALS:
                raise ScenarioError(
                    f"samples = {self.samples} is more than {MAX_TRIALS} (the most trials a sweep may hold)"
                )
        else:
            n = math.prod(len(v) for _, v in axes)
            if n > MAX_TRIALS:
                raise ScenarioError(
                    f"the grid has {n} trials, more than {MAX_TRIALS} (the most a "
                    f"sweep may hold): fewer values per axis, or --samples N"
                )
        _check_int("seed", self.seed, 0)
        ld = self.launch_distance_m
        if not (_is_number(ld) and math.isfinite(float(ld)) and float(ld) > 0.2):
            raise ScenarioError(f"launch_distance_m must be a number > 0.2 m (outside the body); got {ld!r}")
        if not isinstance(self.model, str):
            raise ScenarioError(
                f"model must be the name of a shipped model ({', '.join(models.names())}); got {self.model!r}"
            )
        models.path(self.model)  # unknown model names raise ModelError listing the valid ones
        if not isinstance(self.robot, str):
            raise ScenarioError(
                f"robot must be the path of a robot MJCF (docs/robots.md); got {self.robot!r}"
            )
        if self.robot:
            if self.torque_limits not in ROBOT_TORQUE_LIMITS:
                raise ScenarioError(
                    f"torque_limits on a robot must be one of {', '.join(map(repr, ROBOT_TORQUE_LIMITS))} "
                    f"(its joints' actuatorfrcrange, or none); got {self.torque_limits!r}"
                )
        elif not isinstance(self.torque_limits, str) or self.torque_limits not in TORQUE_LIMIT_KINDS:
            raise ScenarioError(
                f"torque_limits must be one of "
                f"{', '.join(map(repr, TORQUE_LIMIT_KINDS))}; "
                f"got {self.torque_limits!r}"
            )
        if self.base.torque_limits != "none" and self.torque_limits != "none":
            # the scenario's own limits (its key, or a neuromotor preset's) apply when the sweep
            # sets none; both at once would be two sets of limits
            raise ScenarioError(
                "give the sweep's torque limits once: the sweep's torque_limits (SweepSpec / "
                "--torque-limits) or the scenario's torque_limits key (here "
                f"{self.base.torque_limits!r}, e.g. from neuromotor = {self.base.neuromotor!r}), not both"
            )

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_dict(cls, values: Mapping) -> SweepSpec:
        """From ``{"grid": {axis: values}, "scenario": {key: value}, "samples": N, "seed": S,
        "launch_distance_m": L}`` (the TOML layout, see :meth:`from_toml`)."""
        valid = {
            "grid",
            "scenario",
            "samples",
            "seed",
            "launch_distance_m",
            "model",
            "torque_limits",
            "robot",
        }
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
        return cls(
            axes=dict(grid),
            base=base,
            samples=values.get("samples"),
            seed=values.get("seed", 0),
            launch_distance_m=values.get("launch_distance_m", 0.5),
            model=values.get("model", "wendlandt"),
            torque_limits=values.get("torque_limits", "none"),
            robot=values.get("robot", ""),
        )

    @classmethod
    def from_toml(cls, path: str | os.PathLike) -> SweepSpec:
        """A sweep from a TOML file (UTF-8)::

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
        return cls.from_dict(read_toml(path, "sweep"))

    def with_axes(self, **axes: Any) -> SweepSpec:
        """A copy with some axes replaced."""
        return dataclasses.replace(self, axes={**dict(self.axes), **axes})

    # ------------------------------------------------------------------ identity
    def to_dict(self) -> dict:
        out = {
            "grid": {k: list(v) for k, v in self.axes},
            "scenario": self.base.to_dict(),
            "samples": self.samples,
            "seed": self.seed,
            "launch_distance_m": self.launch_distance_m,
            "model": self.model,
            "torque_limits": self.torque_limits,
        }
        if self.robot:  # only then: W's sweeps keep their stored layout
            out["robot"] = self.robot
        return out

    @property
    def model_path(self) -> Path:
        """The biped's MJCF: the base scenario's ``model`` when it names another subject."""
        from biped.models.subject import resolve

        return resolve(self.base.model) if self.base.model != "wendlandt" else models.path(self.model)

    @property
    def model_sha256(self) -> str:
        """SHA-256 of the top-level model file's bytes (in the trial keys, so that a file of an
        earlier version resumes; whether a rerun is the same sweep is decided on
        :attr:`model_compiled_sha256`)."""
        return hashlib.sha256(self.model_path.read_bytes()).hexdigest()

    @property
    def model_compiled_sha256(self) -> str:
        """SHA-256 of the compiled model (:func:`biped.models.compiled_sha256`): every included
        file, asset and default folded in, so a change in an ``<include>``d file is a change of
        the sweep's model. Recorded in the sweep's file and manifest; a rerun whose compiled model
        differs is refused (:func:`biped.sim.sweep.store.spec_difference`), so no file ever holds
        rows of two models."""
        return models.compiled_sha256(self.model_path)

    @property
    def identity(self) -> str:
        """Hash of what makes two trials with equal parameters the same experiment."""
        scen = self.base.to_dict()
        if self.base.perturbation == "block":  # a block sweep's identity as before the paradigms
            from biped.sim.perturbations import PARADIGMS

            for cls in PARADIGMS.values():
                if cls.name != "block":
                    for k in cls.keys:
                        scen.pop(k, None)
            scen.pop("perturbation", None)
        # the nervous system's keys at W's ideal values: the identity as before they existed
        for k, ideal in (("neuromotor", "ideal"), ("feedback_delay_s", 0.0), ("activation_time_s", 0.0),
                         ("torque_rate_limit_n_m_s", "none"), ("ankle_only", False)):  # fmt: skip
            if scen.get(k) == ideal:
                scen.pop(k)
        ident = {
            "scenario": scen,
            "launch_distance_m": self.launch_distance_m,
            "model_sha256": self.model_sha256,
            "torque_limits": self.torque_limits,
            "schema": SCHEMA_VERSION,
        }
        if self.robot:  # the robot's file and its bytes (W's sweeps: their identity as before)
            ident["robot"] = self.robot
            ident["robot_sha256"] = hashlib.sha256(Path(self.robot).read_bytes()).hexdigest()
            if Path(self.robot).suffix == ".toml":  # a robot file: the MJCF it names too
                from biped.models.robot_file import read_robot_file

                xml = read_robot_file(self.robot).path
                ident["robot_mjcf_sha256"] = hashlib.sha256(Path(xml).read_bytes()).hexdigest()
        return hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()[:16]

    @property
    def n_trials(self) -> int:
        """Number of trials, without listing them."""
        if self.samples is not None:
            return self.samples
        return math.prod(len(v) for _, v in self.axes)

    # ------------------------------------------------------------------ trials
    def trials(self) -> tuple[Trial, ...]:
        """Every trial of the sweep, in a fixed order (index 0, 1, ...)."""
        names = list(AXES)
        values = dict(self.axes)
        if self.samples is None:
            # direction fastest, then speed, mass, height, gain: a partial sweep covers the polar map
            order = ["magnitude", "gain_scale", "height_m", "block_mass_kg", "speed_m_s", "direction_deg"]
            points = [
                dict(zip(order, combo, strict=True))
                for combo in itertools.product(*(values[n] for n in order))
            ]
        else:
            rng = np.random.default_rng(self.seed)
            draws = {n: rng.uniform(min(values[n]), max(values[n]), self.samples) for n in names}
            points = [{n: float(draws[n][i]) for n in names} for i in range(self.samples)]
        ident = self.identity
        hashed = BLOCK_AXES if self.base.perturbation == "block" else names
        out = []
        for i, p in enumerate(points):
            p = {n: float(p[n]) for n in names}
            key = hashlib.sha256(json.dumps([ident, [repr(p[n]) for n in hashed]]).encode()).hexdigest()[:20]
            out.append(Trial(index=i, key=key, **p))
        return tuple(out)

    def scenario(self, trial: Trial) -> Scenario:
        """The full scenario of one trial: the base with the block aimed and the gains scaled."""
        return trial_scenario(self.base, trial, launch_distance_m=self.launch_distance_m)

    def setup(self, trial: Trial) -> TrialSetup:
        return TrialSetup(self.scenario(trial), trial, self.torque_limits, self.robot)


def hold_scenario(base: Scenario | None = None) -> Scenario:
    """``base`` (W's scenario by default) with the set point moved to the initial state: COM at
    ``initial_com_m``, ``initial_tilt_deg`` about -y. The task of ``biped sweep``'s default
    ``--task hold``: the same job for W's controller and for the joint-space PD baseline (which
    holds the initial joint angles), so their envelopes compare like with like."""
    base = base or Scenario()
    return base.with_overrides(
        target_com_m=base.initial_com_m, target_tilt_deg=base.initial_tilt_deg, target_axis="-y"
    )


def aim_block(
    target_xy: Any,
    speed_m_s: float,
    direction_deg: float,
    height_m: float,
    launch_distance_m: float = 0.5,
    gravity: float = GRAVITY,
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
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
    p0 = (
        float(target_xy[0] - launch_distance_m * ux),
        float(target_xy[1] - launch_distance_m * uy),
        float(height_m),
    )
    v0 = (float(speed_m_s * ux), float(speed_m_s * uy), float(0.5 * gravity * T))
    return p0, v0


def trial_scenario(base: Scenario, trial: Trial, *, launch_distance_m: float = 0.5) -> Scenario:
    """``base`` with the block of ``trial`` aimed at the initial COM line and the gains scaled;
    for another paradigm (``base.perturbation``), its keys set to the trial's magnitude and
    direction (:meth:`biped.sim.perturbations.Perturbation.sized`; the direction is the way the
    perturbation pushes the body, as the block's travel) and the gains scaled."""
    s, r = trial.gain_scale, math.sqrt(trial.gain_scale)
    gains = {
        "kp_com": tuple(k * s for k in base.kp_com),
        "kv_com": tuple(k * r for k in base.kv_com),
        "kp_rot": tuple(k * s for k in base.kp_rot),
        "kv_rot": tuple(k * r for k in base.kv_rot),
    }
    if base.perturbation != "block":
        from biped.sim.perturbations import PARADIGMS

        keys = PARADIGMS[base.perturbation].sized(base, trial.magnitude, trial.direction_deg)
        return base.with_overrides(**keys, **gains)
    p0, v0 = aim_block(
        base.initial_com_m[:2], trial.speed_m_s, trial.direction_deg, trial.height_m, launch_distance_m
    )
    s, r = trial.gain_scale, math.sqrt(trial.gain_scale)
    return base.with_overrides(
        block_mass_kg=trial.block_mass_kg,
        block_position_m=p0,
        block_velocity_m_s=v0,
        kp_com=tuple(k * s for k in base.kp_com),
        kv_com=tuple(k * r for k in base.kv_com),
        kp_rot=tuple(k * s for k in base.kp_rot),
        kv_rot=tuple(k * r for k in base.kv_rot),
    )


__all__ = [
    "AXES",
    "AXIS_DIGITS",
    "GRID_RTOL",
    "MAX_TRIALS",
    "W_THROW",
    "SweepSpec",
    "Trial",
    "TrialSetup",
    "aim_block",
    "hold_scenario",
    "linspace_spec",
    "parse_axis",
    "trial_scenario",
]
