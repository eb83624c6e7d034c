"""The push-recovery scenario of Wendlandt (1997), section 4, as one frozen dataclass.

Every field defaults to W's value (see ``docs/push.md``). A scenario comes from keyword arguments,
a TOML file (:meth:`Scenario.from_toml`, top-level ``key = value`` lines) or command-line overrides
(:meth:`Scenario.with_overrides`); every route goes through :func:`validate`, which rejects unknown
keys, vectors of the wrong length, non-finite numbers and out-of-range values with a
:class:`~biped.errors.ScenarioError` naming the key and what is valid, before any simulation starts.

Units are in the key names: ``_m`` metres, ``_m_s`` m/s, ``_kg``, ``_s``, ``_hz``, ``_deg`` degrees.
Frames: world, z up, the biped faces -x, its left leg on -y.
"""

from __future__ import annotations

import dataclasses
import difflib
import os
import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from biped.control import Target
from biped.control.neuromotor import NEUROMOTOR
from biped.control.neuromotor import PRESET_KEYS as NEURO_PRESET_KEYS
from biped.control.neuromotor import PRESETS as NEUROMOTOR_PRESETS
from biped.control.workspace import TARGET_AXES, W_TARGET_AXIS, W_TARGET_TILT_DEG
from biped.errors import ScenarioError
from biped.models import (
    JOINT_NAMES,
    LEG_JOINTS,
    W_INITIAL_ANGLES_DEG,
    W_INITIAL_COM_M,
    W_INITIAL_TILT_DEG,
    subject,
)
from biped.sim import scenario_checks
from biped.sim.scenario_checks import INTS, MAX_SEED, RANGES, VECTORS, is_number
from biped.sim.scenario_choices import (
    CONTROLLERS,
    DISTRIBUTIONS,
    PHYSICS,
    PHYSICS_PRESETS,
    STEP_PROGRAMS,
    STEP_REACHES,
    STEP_SWING_PATHS,
    STEP_TRIGGERS,
    STRING_KEYS,
    SUPPORTS,
)

#: W's initial joint angles theta_2..theta_13 [deg] (:data:`biped.models.W_INITIAL_ANGLES_DEG`).
W_JOINT_ANGLES_DEG = W_INITIAL_ANGLES_DEG

#: The keys a physics preset fills when they are not set (:data:`PHYSICS_PRESETS`).
_PRESET_KEYS = ("physics_timestep_s", "contact_timeconst_s")


@dataclass(frozen=True)
class Scenario:
    """W's push-recovery experiment (section 4); every default is W's unless stated.

    Vectors are tuples of floats in world coordinates. ``target_axis="-y"`` is W's text (15 deg
    about -Y); ``"-x"`` is the quaternion W prints, (0.99144486, -0.13052619, 0, 0).
    ``torque_limits`` is ``"none"``, one positive number [N m] for every joint, or 12 of them in
    :data:`JOINT_NAMES` order. ``joint_noise_deg`` adds N(0, sigma^2) to the initial joint angles,
    drawn from ``numpy.random.default_rng(seed)`` (0 = W's exact state).
    ``physics`` names a preset of :data:`PHYSICS_PRESETS`; ``physics_timestep_s`` and
    ``contact_timeconst_s`` left unset (None) take the preset's value, so after construction they
    are always numbers (an explicit value wins over the preset).
    """

    duration_s: float = 3.0
    physics: str = "faithful"  # not in W: "fast" = 1 ms step, 7.5 ms contacts, ... (PHYSICS_PRESETS)
    physics_timestep_s: float = None  # type: ignore[assignment]  # None: from the preset
    control_rate_hz: float = 500.0
    block_mass_kg: float = 1.8
    block_position_m: tuple = (0.5, 0.1, 1.2)
    block_velocity_m_s: tuple = (-4.5, 0.0, 0.2)
    block_size_m: tuple = (0.1, 0.1, 0.1)  # not in W: a 10 cm cube (1.8 kg: a brick's density)
    initial_com_m: tuple = W_INITIAL_COM_M
    initial_tilt_deg: float = W_INITIAL_TILT_DEG  # about -y
    initial_joint_angles_deg: tuple = W_INITIAL_ANGLES_DEG
    joint_noise_deg: float = 0.0
    target_com_m: tuple = Target().com
    target_tilt_deg: float = W_TARGET_TILT_DEG
    target_axis: str = W_TARGET_AXIS
    # W's gains, or the neuromotor preset's when None (NEUROMOTOR_PRESETS)
    kp_com: tuple = None  # type: ignore[assignment]
    kv_com: tuple = None  # type: ignore[assignment]
    kp_rot: tuple = None  # type: ignore[assignment]
    kv_rot: tuple = None  # type: ignore[assignment]
    controller: str = "workspace"
    support: str = "fixed"  # not in W: "sensed" drops a foot off the floor from Alg. 3 and 5
    distribution: str = "statics"  # W's Alg. 5; "qp": not in W (docs/controller.md)
    qp_moment_weight: float = 100.0  # "qp": weight of the moment rows [1/(N m)^2] (force rows: 1 /N^2)
    qp_min_normal_n: float = 10.0  # "qp": minimum normal force of a foot in contact [N]
    qp_cop_scale: float = 1.0  # "qp": the CoP stays in the sole shrunk by this factor
    qp_leg_weight: float = 1.0  # "qp": share of the legs' weight in the cones (0 with stepping = true)
    # "qp": the friction pyramid on the floor's axes, not the sole's (a sole rolled onto its edge);
    # false (the sole's axes) until 2026-11-27: written whenever distribution = "qp" (to_dict)
    qp_floor_friction: bool = True
    torque_limits: Any = None  # None: the neuromotor preset's ("none" for "ideal", W)
    friction: float = 0.3
    restitution: float = 0.2
    # not in W (Impulse is rigid): MuJoCo's contact stiffness [s]; None: from the preset
    contact_timeconst_s: float = None  # type: ignore[assignment]
    # passive damping of every hinge [N m s/rad], as in the shipped models (W: none). Measured
    # (docs/controller.md): W's push recovers without it, but a falling biped's limp, undamped
    # ankles spin up until MuJoCo diverges (2 of 120 QP sweep trials); with 1.0 they are falls.
    # None: the neuromotor preset's (1.0 for "ideal"; muscle's intrinsic damping for the others)
    joint_damping_n_m_s: float = None  # type: ignore[assignment]
    fall_height_m: float = 0.6  # central-body COM below this height = fall
    recovery_com_tol_m: float = 0.02
    recovery_orientation_tol_deg: float = 2.0
    seed: int = 0
    # not in W: the biped, a shipped model's name or an MJCF path (see Scenario.for_model)
    model: str = subject.DEFAULT
    # not in W: capture-point steps when the feet cannot hold (biped.control.stepping)
    stepping: bool = False
    max_steps: int = 3  # with stepping: most steps per run
    # with stepping: how a step is made. "feedback": the task-space swing loop of
    # biped.control.stepping; "program": weight transfer, then a feed-forward swing with feedback
    # against the delayed plan (biped.control.step_program), for a delayed, lagged plant
    step_program: str = "feedback"
    # with stepping: the longest step landed. "fixed": 0.5 m between sole centres; "leg": both legs
    # at the swing's reach from the hips' standing height (docs/validate.md, "The step program")
    step_reach: str = "fixed"
    # with step_program "program*": the swing ankle's path, "min-jerk" (as before) or "s-curve" (the
    # bang-bang jerk path, 0.37 s, with no weight transfer; docs/validate.md)
    swing_path: str = "min-jerk"
    # with stepping: when to step. "qp" (the default): the QP alone until its feet cannot hold;
    # "capture": the capture point leaves the feet (3 cm sideways margin, W's fixed feet and
    # massless legs before the first step; the default before 2026-11-27; docs/controller.md,
    # "Stepping"). A stepping scenario always records it (to_dict): files without it meant "capture"
    step_trigger: str = "qp"
    # not in W: a human nervous system (biped.control.neuromotor; docs/validate.md). The preset
    # fills feedback_delay_s, torque_rate_limit_n_m_s, activation_time_s, torque_limits and the
    # four gains when they are not given; "ideal" is W's controller
    neuromotor: str = "ideal"
    feedback_delay_s: float = None  # type: ignore[assignment]  # [s], a whole number of periods
    torque_rate_limit_n_m_s: Any = None  # "none", "human", "human-older", 1 or 12 numbers [N m/s]
    activation_time_s: float = None  # type: ignore[assignment]  # first-order lag [s], 0 = none
    # hips and knees held at their initial angles by stiff joint springs, the ankles balance
    ankle_only: bool = False
    # not in W: the perturbation paradigm (biped.sim.perturbations, docs/perturbations.md); the
    # block_* keys are the block's, force_* the force pulse's, platform_* and release_* likewise
    perturbation: str = "block"
    force_n: tuple = (-60.0, 0.0, 0.0)  # peak force [N], world frame (-x: pushes the biped forward)
    force_start_s: float = 0.1
    force_duration_s: float = 0.15
    force_shape: str = "rectangular"  # or "half-sine"
    force_body: str = "central_body"  # a body of the biped
    force_point_m: Any = "pelvis"  # "pelvis" or (x, y, z) in force_body's frame [m]
    platform_displacement_m: tuple = (0.05, 0.0)  # (x, y) [m]: +x moves the feet backward
    platform_start_s: float = 0.1
    platform_duration_s: float = 0.3  # the ramp [s]
    pull_displacement_m: tuple = (-0.1, 0.0)  # (x, y) [m], the motor's travel: -x pulls forward
    pull_velocity_m_s: float = 0.4  # the motor's speed [m/s]
    pull_start_s: float = 0.1
    release_lean_deg: float = 5.0
    release_direction_deg: float = 0.0  # 0 forward (world -x), 90 to the biped's left (world -y)
    release_time_s: float = 0.1  # >= duration_s: the tether never goes
    # not in W: end a trial once its outcome is decided (biped.sim.early_stop; sweeps turn it on)
    early_stop: bool = False

    def __post_init__(self):
        preset = PHYSICS_PRESETS.get(self.physics) if isinstance(self.physics, str) else None
        if preset is None:
            raise ScenarioError(
                f"physics must be one of {', '.join(map(repr, PHYSICS))}; got {self.physics!r}"
            )
        for key in _PRESET_KEYS:
            if getattr(self, key) is None:
                object.__setattr__(self, key, preset[key])
        neuro = NEUROMOTOR_PRESETS.get(self.neuromotor) if isinstance(self.neuromotor, str) else None
        if neuro is None:
            raise ScenarioError(
                f"neuromotor must be one of {', '.join(map(repr, NEUROMOTOR))}; got {self.neuromotor!r}"
            )
        for key in NEURO_PRESET_KEYS:
            if getattr(self, key) is None:
                object.__setattr__(self, key, neuro[key])
        validate(self)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_dict(cls, values: dict) -> Scenario:
        """A scenario from ``{key: value}``; unknown keys are an error (listing the valid ones)."""
        _check_keys(values)
        return cls(**{k: _coerce(k, v) for k, v in values.items()})

    @classmethod
    def from_toml(cls, path: str | Path) -> Scenario:
        """A scenario from a TOML file of top-level ``key = value`` lines (others keep W's)."""
        return cls.from_dict(toml_values(path))

    @classmethod
    def for_model(cls, model: str | Path, **values) -> Scenario:
        """W's scenario on another biped (a shipped name or an MJCF path, checked first), then
        ``values`` (any keys, taken as given). For a model other than W's shipped biped, the keys
        W's numbers fix for W's body are moved onto the subject by
        :func:`biped.models.subject.subject_state`: ``initial_com_m`` (W's crouch and tilt, soles
        5 mm up), ``target_com_m`` (W's set point as joint angles, same angles on the subject),
        the block's start height ``block_position_m[2]`` and ``fall_height_m`` times the ratio of
        initial COM heights, and ``block_mass_kg`` times the ratio of total body masses (W's push
        as momentum per kilogram of body; pass ``block_mass_kg=1.8`` for W's block itself).
        ``model`` is recorded as an absolute path."""
        if not isinstance(model, (str, Path)) or not str(model).strip():
            raise ScenarioError(
                f"model must be a shipped model's name ('wendlandt') or the path "
                f"of an MJCF file; got {model!r}"
            )
        path = subject.resolve(str(model) if isinstance(model, Path) else model)
        if isinstance(model, str) and model == subject.DEFAULT:
            return cls.from_dict({**values, "model": model})
        w = cls()
        st = subject.subject_state(
            path,
            initial_tilt_deg=w.initial_tilt_deg,
            joint_angles_deg=w.initial_joint_angles_deg,
            target_com_m=w.target_com_m,
            target_tilt_deg=w.target_tilt_deg,
            reference_com_m=w.initial_com_m,
        )
        bx, by, bz = w.block_position_m
        scaled = {
            "initial_com_m": st.initial_com_m,
            "target_com_m": st.target_com_m,
            "block_position_m": (bx, by, bz * st.height_ratio),
            "block_mass_kg": w.block_mass_kg * st.mass_ratio,
            "fall_height_m": w.fall_height_m * st.height_ratio,
        }
        return cls.from_dict({**scaled, **values, "model": str(path.resolve())})

    def with_overrides(self, **values) -> Scenario:
        """A copy with some keys changed (validated like every other route). Changing ``physics``
        also resets ``physics_timestep_s`` and ``contact_timeconst_s`` to the new preset's values
        unless they are given in the same call."""
        _check_keys(values)
        changes = {k: _coerce(k, v) for k, v in values.items()}
        if "physics" in changes:
            for key in _PRESET_KEYS:
                changes.setdefault(key, None)
        if "neuromotor" in changes:
            for key in NEURO_PRESET_KEYS:
                changes.setdefault(key, None)
        return dataclasses.replace(self, **changes)

    @property
    def sleep(self) -> bool:
        """MuJoCo's sleep flag (bodies at rest stop being simulated): on for ``physics="fast"``."""
        return bool(PHYSICS_PRESETS[self.physics]["sleep"])

    @property
    def sole_box(self) -> bool:
        """Each foot collides as one box, the union of its heel and toe boxes: on for
        ``physics="fast"`` on W's shipped biped without ``stepping`` (see :data:`PHYSICS_PRESETS`
        and :func:`biped.sim.scene.scene_spec`)."""
        preset = bool(PHYSICS_PRESETS[self.physics]["sole_box"])
        return preset and not self.stepping and self.model == subject.DEFAULT

    # ------------------------------------------------------------------ export
    def to_dict(self) -> dict:
        """Plain ``{key: value}`` (tuples as lists), JSON- and TOML-ready."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            changed = CHANGED_DEFAULTS.get(f.name)
            written = changed is not None and changed[0](getattr(self, changed[1]))  # at any value
            if f.name in _OMITTED_AT_DEFAULT and v == f.default and not written:
                continue  # a key added later: its default leaves old files (and W's outputs) as they were
            out[f.name] = list(v) if isinstance(v, tuple) else v
        return out

    def to_toml(self) -> str:
        """TOML text that :meth:`from_toml` reads back to an equal scenario."""
        lines = []
        for k, v in self.to_dict().items():
            lines.append(f"{k} = {_toml_value(v)}")
        return "\n".join(lines) + "\n"

    # ------------------------------------------------------------------ derived
    @property
    def control_substeps(self) -> int:
        """Physics steps per control period (the zero-order hold)."""
        return round(1.0 / (self.control_rate_hz * self.physics_timestep_s))

    @property
    def delay_steps(self) -> int:
        """Control periods of ``feedback_delay_s``."""
        return round(self.feedback_delay_s * self.control_rate_hz)

    @property
    def neuro_ideal(self) -> bool:
        """No delay, no activation lag, no rate limit: W's controller acts on the state at once."""
        return (
            self.feedback_delay_s == 0
            and self.activation_time_s == 0
            and self.torque_rate_limit_n_m_s == "none"
        )

    @property
    def control_steps(self) -> int:
        """Number of control periods in ``duration_s``."""
        return round(self.duration_s * self.control_rate_hz)


def read_toml(path: str | os.PathLike, kind: str) -> dict:
    """The table of the TOML file ``path``; a file that cannot be read, is not UTF-8 or is not
    TOML is a one-line :class:`ScenarioError` naming the ``kind`` of file ("scenario", "sweep"),
    and so is anything but a regular file of at most :data:`biped.files.MAX_TEXT_BYTES` (a device
    such as ``/dev/zero``, a fifo, a folder)."""
    from biped.files import MAX_TEXT_BYTES, read_input

    path = Path(path)
    data = read_input(path, kind, MAX_TEXT_BYTES)  # a regular file of at most 1 MiB
    try:
        return tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise ScenarioError(
            f"{kind} file {str(path)!r} is not UTF-8 text (byte "
            f"0x{exc.object[exc.start]:02x} at offset {exc.start}); TOML files "
            f"must be UTF-8"
        ) from None
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{kind} file {str(path)!r} is not valid TOML: {exc}") from None


def toml_values(path: str | Path) -> dict:
    """The ``{key: value}`` of a scenario TOML file (top-level ``key = value`` lines; keys
    checked, values not yet)."""
    path = Path(path)
    values = read_toml(path, "scenario")
    for k, v in values.items():
        if isinstance(v, dict):
            raise ScenarioError(
                f"scenario file {str(path)!r}: tables such as [{k}] are not used; write "
                f"top-level 'key = value' lines with keys from: {', '.join(keys())}"
            )
    _check_keys(values)
    return values


# ---------------------------------------------------------------------------------------------
# keys and values

#: Keys :meth:`Scenario.to_dict` leaves out at their default value, so that a scenario without
#: them writes the same summary.json / sweep identity as before they existed (except where
#: :data:`CHANGED_DEFAULTS` says they are written).
_OMITTED_AT_DEFAULT = frozenset(
    {
        "early_stop",
        "step_program",
        "step_reach",
        "step_trigger",
        "swing_path",
        "pull_displacement_m",
        "pull_velocity_m_s",
        "pull_start_s",
        "qp_floor_friction",
    }
)


#: Keys whose default changed, ``{key: (applies, on, old default)}``: written whenever
#: ``applies(scenario[on])``, at any value, so that a stored scenario it applies to
#: without them is one written before the change and is read as it was (:func:`stored_values`).
#: ``qp_floor_friction``: false until 2026-11-27 (the QP's pyramid on the sole's axes), then true;
#: ``step_trigger``: "capture" until 2026-11-27, then "qp".
CHANGED_DEFAULTS: dict[str, tuple[Callable[[Any], bool], str, Any]] = {
    "qp_floor_friction": (lambda distribution: distribution == "qp", "distribution", False),
    "step_trigger": (bool, "stepping", "capture"),
}


def stored_values(values: dict) -> dict:
    """``values``, a scenario's :meth:`Scenario.to_dict` as a file stored it (a sweep's Parquet
    metadata, its parts' manifest), with the keys it lacks at their old default: a QP sweep
    stored without ``qp_floor_friction`` ran with the sole's pyramid, a stepping one without
    ``step_trigger`` with ``"capture"``, and is read so (a rerun with
    today's default is then refused as a different sweep, never resumed or merged into it)."""
    out = dict(values)
    for key, (applies, on, old_default) in CHANGED_DEFAULTS.items():
        if applies(out.get(on)):
            out.setdefault(key, old_default)
    return out


def keys() -> tuple[str, ...]:
    """Every valid scenario key, in declaration order."""
    return tuple(f.name for f in dataclasses.fields(Scenario))


def _check_keys(values: dict) -> None:
    valid = keys()
    for k in values:
        if k not in valid:
            close = difflib.get_close_matches(str(k), valid, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise ScenarioError(f"unknown scenario key {k!r}{hint}; valid keys: {', '.join(valid)}")


def _coerce(key: str, v):
    """Lists to tuples and ints to floats where a float is meant; type errors name the key."""
    if key in VECTORS:
        n, what = VECTORS[key]
        if isinstance(v, (str, bytes)) or not hasattr(v, "__len__"):
            raise ScenarioError(f"{key} must be {n} numbers, {what}; got {v!r}")
        return tuple(float(x) if is_number(x) else x for x in v)
    if key in ("torque_limits", "torque_rate_limit_n_m_s", "force_point_m"):
        if isinstance(v, (list, tuple)):
            return tuple(float(x) if is_number(x) else x for x in v)
        return float(v) if is_number(v) else v
    if (
        key in STRING_KEYS
        or key in INTS
        or key in ("stepping", "ankle_only", "early_stop", "qp_floor_friction")
    ):  # a bool is checked, not converted
        return v
    if key in ("model", "force_body"):
        return str(v) if isinstance(v, Path) else v
    return float(v) if is_number(v) else v


def validate(s: Scenario) -> None:
    """Raise :class:`ScenarioError` naming the first invalid key of ``s`` and what is valid
    (the rules: :func:`biped.sim.scenario_checks.validate`)."""
    scenario_checks.validate(s, STRING_KEYS)


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def parse_assignment(text: str) -> tuple[str, Any]:
    """``"key=value"`` (value in TOML syntax, e.g. ``block_mass_kg=2.5`` or
    ``kp_com=[60, 60, 200]``) -> ``(key, value)``; for the command line's ``--set``."""
    if "=" not in text or not text.split("=", 1)[0].strip():
        raise ScenarioError(f"--set expects KEY=VALUE with a key from: {', '.join(keys())}; got {text!r}")
    key, raw = (p.strip() for p in text.split("=", 1))
    _check_keys({key: None})
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw  # a bare word such as joint-pd or none
    return key, value


__all__ = [
    "CONTROLLERS",
    "DISTRIBUTIONS",
    "JOINT_NAMES",
    "LEG_JOINTS",
    "MAX_SEED",
    "PHYSICS",
    "PHYSICS_PRESETS",
    "RANGES",
    "STEP_PROGRAMS",
    "STEP_REACHES",
    "STEP_SWING_PATHS",
    "STEP_TRIGGERS",
    "SUPPORTS",
    "TARGET_AXES",
    "W_JOINT_ANGLES_DEG",
    "Scenario",
    "keys",
    "parse_assignment",
    "read_toml",
    "stored_values",
    "CHANGED_DEFAULTS",
    "toml_values",
    "validate",
]
