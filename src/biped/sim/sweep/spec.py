"""The definition of a sweep: its axes, its base scenario, its trials and their keys. Pure Python
(no MuJoCo): a sweep is checked and its trials listed before any work starts.

The axes' values and defaults are :mod:`.axes`'s; how each trial's block is aimed (and its
scenario made) is :mod:`.aim`'s, whose names this module still offers.
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
from biped.sim.scenario import CHANGED_DEFAULTS, Scenario, read_toml
from biped.sim.sweep.aim import GRAVITY, aim_block, hold_scenario, trial_scenario
from biped.sim.sweep.axes import (
    AXES,
    AXIS_DIGITS,
    BLOCK_AXES,
    GRID_RTOL,
    MAX_TRIALS,
    W_THROW,
    _axis_values,
    _check_int,
    _is_number,
    linspace_spec,
    parse_axis,
)

#: torque limits of a robot sweep: its joints' ``actuatorfrcrange`` inside the QP, or none.
ROBOT_TORQUE_LIMITS = ("model", "none")
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
        # the nervous system's keys at W's ideal values, and the keys whose default changed at
        # their old default (CHANGED_DEFAULTS: a file of that time keeps its trials' keys): the
        # identity as before they existed
        for k, ideal in (("neuromotor", "ideal"), ("feedback_delay_s", 0.0), ("activation_time_s", 0.0),
                         ("torque_rate_limit_n_m_s", "none"), ("ankle_only", False),
                         *((k, old) for k, (_, _, old) in CHANGED_DEFAULTS.items())):  # fmt: skip
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


__all__ = [
    "AXES",
    "GRAVITY",
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
