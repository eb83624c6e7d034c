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
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from biped.control import Gains, Target
from biped.control.workspace import TARGET_AXES, W_TARGET_AXIS, W_TARGET_TILT_DEG
from biped.errors import ScenarioError
from biped.models import (
    JOINT_NAMES,
    LEG_JOINTS,
    W_INITIAL_ANGLES_DEG,
    W_INITIAL_COM_M,
    W_INITIAL_TILT_DEG,
)

#: W's initial joint angles theta_2..theta_13 [deg] (:data:`biped.models.W_INITIAL_ANGLES_DEG`).
W_JOINT_ANGLES_DEG = W_INITIAL_ANGLES_DEG

CONTROLLERS = ("workspace", "joint-pd")
#: Which feet the workspace controller takes as fixed: "fixed" = both, always (W); "sensed" = the
#: feet whose soles touch the floor at each control step (see WorkspaceController.compute).
SUPPORTS = ("fixed", "sensed")
#: The workspace controller's wrench distribution (W Alg. 5): W's min-norm split ("statics", its
#: print's subscripts "printed") or the contact-feasible QP ("qp", biped.control.distribution).
DISTRIBUTIONS = ("statics", "printed", "qp")

#: Physics presets (key ``physics``): the values they give ``physics_timestep_s`` and
#: ``contact_timeconst_s`` when those keys are not set, and whether MuJoCo's sleep flag is on.
#: "faithful" is the reference (0.5 ms step, 5 ms contact time constant); "fast" halves the cost
#: of a step and is checked against it in docs/sweep.md ("Physics presets").
PHYSICS_PRESETS = {
    "faithful": {"physics_timestep_s": 0.0005, "contact_timeconst_s": 0.005, "sleep": False},
    "fast": {"physics_timestep_s": 0.001, "contact_timeconst_s": 0.0075, "sleep": True},
}
PHYSICS = tuple(PHYSICS_PRESETS)
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
    physics: str = "faithful"  # not in W: "fast" = 1 ms step, 7.5 ms contacts, MuJoCo's sleep
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
    kp_com: tuple = Gains().kp_com
    kv_com: tuple = Gains().kv_com
    kp_rot: tuple = Gains().kp_rot
    kv_rot: tuple = Gains().kv_rot
    controller: str = "workspace"
    support: str = "fixed"  # not in W: "sensed" drops a foot off the floor from Alg. 3 and 5
    distribution: str = "statics"  # W's Alg. 5; "qp": not in W (docs/controller.md)
    qp_moment_weight: float = 100.0  # "qp": weight of the moment rows [1/(N m)^2] (force rows: 1 /N^2)
    qp_min_normal_n: float = 10.0  # "qp": minimum normal force of a foot in contact [N]
    qp_cop_scale: float = 1.0  # "qp": the CoP stays in the sole shrunk by this factor
    qp_leg_weight: float = 1.0  # "qp": share of the legs' weight in the cones (0 with stepping = true)
    torque_limits: Any = "none"
    friction: float = 0.3
    restitution: float = 0.2
    # not in W (Impulse is rigid): MuJoCo's contact stiffness [s]; None: from the preset
    contact_timeconst_s: float = None  # type: ignore[assignment]
    # passive damping of every hinge [N m s/rad], as in the shipped models (W: none). Measured
    # (docs/controller.md): W's push recovers without it, but a falling biped's limp, undamped
    # ankles spin up until MuJoCo diverges (2 of 120 QP sweep trials); with 1.0 they are falls
    joint_damping_n_m_s: float = 1.0
    fall_height_m: float = 0.6  # central-body COM below this height = fall
    recovery_com_tol_m: float = 0.02
    recovery_orientation_tol_deg: float = 2.0
    seed: int = 0
    # not in W: the biped, a shipped model's name or an MJCF path (see Scenario.for_model)
    model: str = "wendlandt"
    # not in W: capture-point steps when the feet cannot hold (biped.control.stepping)
    stepping: bool = False
    max_steps: int = 3  # with stepping: most steps per run

    def __post_init__(self):
        preset = PHYSICS_PRESETS.get(self.physics) if isinstance(self.physics, str) else None
        if preset is None:
            raise ScenarioError(
                f"physics must be one of {', '.join(map(repr, PHYSICS))}; got {self.physics!r}"
            )
        for key in _PRESET_KEYS:
            if getattr(self, key) is None:
                object.__setattr__(self, key, preset[key])
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
        from biped.models import subject

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
        return dataclasses.replace(self, **changes)

    @property
    def sleep(self) -> bool:
        """MuJoCo's sleep flag (bodies at rest stop being simulated): on for ``physics="fast"``."""
        return bool(PHYSICS_PRESETS[self.physics]["sleep"])

    # ------------------------------------------------------------------ export
    def to_dict(self) -> dict:
        """Plain ``{key: value}`` (tuples as lists), JSON- and TOML-ready."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
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
    def control_steps(self) -> int:
        """Number of control periods in ``duration_s``."""
        return round(self.duration_s * self.control_rate_hz)


def toml_values(path: str | Path) -> dict:
    """The ``{key: value}`` of a scenario TOML file (top-level ``key = value`` lines; keys
    checked, values not yet)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ScenarioError(f"cannot read scenario file {str(path)!r}: {exc.strerror}") from None
    except UnicodeDecodeError as exc:
        raise ScenarioError(
            f"scenario file {str(path)!r} is not UTF-8 text (byte "
            f"0x{exc.object[exc.start]:02x} at offset {exc.start}); TOML files "
            f"must be UTF-8"
        ) from None
    try:
        values = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"scenario file {str(path)!r} is not valid TOML: {exc}") from None
    for k, v in values.items():
        if isinstance(v, dict):
            raise ScenarioError(
                f"scenario file {str(path)!r}: tables such as [{k}] are not used; write "
                f"top-level 'key = value' lines with keys from: {', '.join(keys())}"
            )
    _check_keys(values)
    return values


# ---------------------------------------------------------------------------------------------
# validation

_VECTORS = {
    "block_position_m": (3, "(x, y, z) in m"),
    "block_velocity_m_s": (3, "(vx, vy, vz) in m/s"),
    "block_size_m": (3, "edge lengths (x, y, z) in m"),
    "initial_com_m": (3, "(x, y, z) in m"),
    "initial_joint_angles_deg": (12, "W's theta_2..theta_13 in deg: " + ", ".join(JOINT_NAMES)),
    "target_com_m": (3, "(x, y, z) in m"),
    "kp_com": (3, "diagonal gains (x, y, z) [1/s^2]"),
    "kv_com": (3, "diagonal gains (x, y, z) [1/s]"),
    "kp_rot": (3, "diagonal gains (x, y, z) [1/s^2]"),
    "kv_rot": (3, "diagonal gains (x, y, z) [1/s]"),
}
_STRINGS = {
    "target_axis": TARGET_AXES,
    "controller": CONTROLLERS,
    "support": SUPPORTS,
    "physics": PHYSICS,
    "distribution": DISTRIBUTIONS,
}
_INTS = {"seed", "max_steps"}

#: Physical ranges [lo, hi] of the numbers (docs/push.md, "Valid ranges"). They keep a run's work
#: bounded (duration, physics step) and its physics meaningful (a thrown block, a standing biped).
RANGES = {
    "duration_s": (0.0, 60.0, "simulated time in s; a push recovery is over in seconds"),
    "physics_timestep_s": (1e-5, 0.001, "physics step in s"),
    "control_rate_hz": (1.0, 100_000.0, "controller calls per second"),
    "block_mass_kg": (0.01, 100.0, "block mass in kg, MuJoCo needs it well above zero"),
    "block_speed_m_s": (
        0.0,
        100.0,
        "block speed |block_velocity_m_s| in m/s at its start: a "
        "thrown, swung or launched object (a sweep's slow hits from "
        "metres away start fast)",
    ),
    "block_size_m": (0.005, 1.0, "edge length in m"),
    "position_m": (-10.0, 10.0, "world coordinate in m, the scene is a few metres wide"),
    "gain": (0.0, 1e6, "PD gain"),
    "tilt_deg": (-90.0, 90.0, "deg"),
    "joint_angle_deg": (-180.0, 180.0, "deg"),
    "joint_noise_deg": (0.0, 30.0, "standard deviation in deg"),
    "friction": (0.0, 10.0, "Coulomb coefficient"),
    "contact_timeconst_s": (0.0, 1.0, "MuJoCo solref time constant in s"),
    "fall_height_m": (0.0, 10.0, "central-body COM height in m"),
    "joint_damping_n_m_s": (0.0, 1000.0, "passive hinge damping in N m s/rad"),
    "qp_moment_weight": (0.0, 1e6, "weight of the QP's moment rows, force rows 1"),
    "qp_min_normal_n": (0.0, 1000.0, "minimum normal force of a foot in contact in N"),
    "recovery_com_tol_m": (0.0, 1.0, "COM distance from the set point in m"),
    "recovery_orientation_tol_deg": (0.0, 180.0, "orientation error in deg"),
}
MAX_SEED = 2**63 - 1


def _in_range(key: str, v: float, kind: str | None = None, *, lo_open: bool = False) -> None:
    lo, hi, what = RANGES[kind or key]
    if v < lo or (lo_open and v == lo) or v > hi:
        left = "(" if lo_open else "["
        raise ScenarioError(f"{key} must be in {left}{lo:g}, {hi:g}] ({what}); got {v!r}")


def keys() -> tuple[str, ...]:
    """Every valid scenario key, in declaration order."""
    return tuple(f.name for f in dataclasses.fields(Scenario))


def _check_keys(values: dict) -> None:
    valid = keys()
    for k in values:
        if k not in valid:
            raise ScenarioError(f"unknown scenario key {k!r}; valid keys: {', '.join(valid)}")


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _coerce(key: str, v):
    """Lists to tuples and ints to floats where a float is meant; type errors name the key."""
    if key in _VECTORS:
        n, what = _VECTORS[key]
        if isinstance(v, (str, bytes)) or not hasattr(v, "__len__"):
            raise ScenarioError(f"{key} must be {n} numbers, {what}; got {v!r}")
        return tuple(float(x) if _is_number(x) else x for x in v)
    if key == "torque_limits":
        if isinstance(v, (list, tuple)):
            return tuple(float(x) if _is_number(x) else x for x in v)
        return float(v) if _is_number(v) else v
    if key in _STRINGS or key in _INTS:
        return v
    if key == "model":
        return str(v) if isinstance(v, Path) else v
    return float(v) if _is_number(v) else v


def _finite(key: str, v, what: str) -> float:
    if not _is_number(v):
        raise ScenarioError(f"{key} must be a number ({what}); got {v!r}")
    if not math.isfinite(v):
        raise ScenarioError(f"{key} must be finite ({what}); got {v!r}")
    return float(v)


def _positive(s: Scenario, key: str, what: str, *, zero_ok: bool = False) -> float:
    v = _finite(key, getattr(s, key), what)
    if v < 0 or (v == 0 and not zero_ok):
        bound = ">= 0" if zero_ok else "> 0"
        raise ScenarioError(f"{key} must be {bound} ({what}); got {v!r}")
    return v


def validate(s: Scenario) -> None:
    """Raise :class:`ScenarioError` naming the first invalid key of ``s`` and what is valid."""
    for key, (n, what) in _VECTORS.items():
        v = getattr(s, key)
        if not isinstance(v, tuple) or len(v) != n:
            got = len(v) if isinstance(v, tuple) else repr(v)
            raise ScenarioError(
                f"{key} must be {n} numbers, {what}; got {got}" + (" numbers" if isinstance(v, tuple) else "")
            )
        for i, x in enumerate(v):
            _finite(f"{key}[{i}]", x, what)
    for key in ("block_size_m",):
        if min(getattr(s, key)) <= 0:
            raise ScenarioError(f"{key} must be 3 positive edge lengths in m; got {getattr(s, key)}")
        for i, x in enumerate(getattr(s, key)):
            _in_range(f"{key}[{i}]", x, "block_size_m")
    for key in ("kp_com", "kv_com", "kp_rot", "kv_rot"):
        if min(getattr(s, key)) < 0:
            raise ScenarioError(f"{key} must be >= 0 (PD gains); got {getattr(s, key)}")
        for i, x in enumerate(getattr(s, key)):
            _in_range(f"{key}[{i}]", x, "gain")
    for key in ("block_position_m", "initial_com_m", "target_com_m"):
        for i, x in enumerate(getattr(s, key)):
            _in_range(f"{key}[{i}]", x, "position_m")
    for i, x in enumerate(s.initial_joint_angles_deg):
        _in_range(f"initial_joint_angles_deg[{i}]", x, "joint_angle_deg")
    _in_range("duration_s", _positive(s, "duration_s", "simulated time in s"), lo_open=True)
    dt = _positive(s, "physics_timestep_s", "physics step in s, at most 0.001")
    if dt > 0.001:
        raise ScenarioError(
            f"physics_timestep_s must be <= 0.001 s (this project's bound, docs/push.md); got {dt}"
        )
    _in_range("physics_timestep_s", dt)
    rate = _positive(s, "control_rate_hz", "controller calls per second")
    _in_range("control_rate_hz", rate)
    ratio = 1.0 / (rate * dt)
    if ratio < 1 - 1e-9 or abs(ratio - round(ratio)) > 1e-6:
        raise ScenarioError(
            f"control_rate_hz must make the control period a whole number of physics steps "
            f"(physics_timestep_s = {dt} s); got {rate} Hz, i.e. {ratio:.6g} steps"
        )
    _in_range("block_mass_kg", _positive(s, "block_mass_kg", "block mass in kg"))
    speed = math.sqrt(sum(x * x for x in s.block_velocity_m_s))
    if not speed <= RANGES["block_speed_m_s"][1]:
        raise ScenarioError(
            f"block_velocity_m_s: the block's speed must be at most "
            f"{RANGES['block_speed_m_s'][1]:g} m/s ({RANGES['block_speed_m_s'][2]}); "
            f"got {speed:g} m/s"
        )
    if speed * dt > min(s.block_size_m) / 2:
        raise ScenarioError(
            f"block_velocity_m_s: at {speed:g} m/s the block moves {speed * dt * 1e3:.3g} mm per "
            f"physics step, more than half its smallest edge ({min(s.block_size_m) * 500:g} mm), so it "
            f"could pass through the body unseen; use a smaller physics_timestep_s or speed"
        )
    _in_range("joint_noise_deg", _positive(s, "joint_noise_deg", "standard deviation in deg", zero_ok=True))
    _in_range("initial_tilt_deg", _finite("initial_tilt_deg", s.initial_tilt_deg, "deg about -y"), "tilt_deg")
    _in_range(
        "target_tilt_deg", _finite("target_tilt_deg", s.target_tilt_deg, "deg about target_axis"), "tilt_deg"
    )
    for key, valid in _STRINGS.items():
        v = getattr(s, key)
        if v not in valid:
            raise ScenarioError(f"{key} must be one of {', '.join(map(repr, valid))}; got {v!r}")
    tl = s.torque_limits
    if isinstance(tl, tuple):
        if len(tl) != 12:
            raise ScenarioError(
                f"torque_limits must be 'none', one number or 12 numbers "
                f"({', '.join(JOINT_NAMES)}) in N m; got {len(tl)} numbers"
            )
        for i, x in enumerate(tl):
            if _finite(f"torque_limits[{i}]", x, "N m") <= 0:
                raise ScenarioError(f"torque_limits[{i}] must be > 0 N m; got {x!r}")
    elif tl != "none" and (not _is_number(tl) or not math.isfinite(tl) or tl <= 0):
        raise ScenarioError(
            f"torque_limits must be 'none', one positive number or 12 of them in N m; got {tl!r}"
        )
    _in_range("friction", _positive(s, "friction", "Coulomb coefficient", zero_ok=True))
    e = _finite("restitution", s.restitution, "coefficient of restitution")
    if not 0.0 <= e <= 0.8:
        raise ScenarioError(f"restitution must be in [0, 0.8] (the calibrated range); got {e!r}")
    tc = _positive(s, "contact_timeconst_s", "MuJoCo solref time constant in s")
    _in_range("contact_timeconst_s", tc)
    if tc < 2 * dt:
        raise ScenarioError(
            f"contact_timeconst_s must be >= 2 physics_timestep_s = {2 * dt} s "
            f"(MuJoCo's stability rule); got {tc}"
        )
    _in_range("fall_height_m", _positive(s, "fall_height_m", "central-body COM height in m"))
    _in_range(
        "joint_damping_n_m_s",
        _positive(s, "joint_damping_n_m_s", "passive hinge damping in N m s/rad", zero_ok=True),
    )
    _in_range(
        "qp_moment_weight", _positive(s, "qp_moment_weight", "weight of the QP's moment rows, force rows 1")
    )
    _in_range("qp_min_normal_n", _positive(s, "qp_min_normal_n", "N", zero_ok=True))
    c = _positive(s, "qp_cop_scale", "fraction of the sole the CoP may use, in (0, 1]")
    if c > 1:
        raise ScenarioError(f"qp_cop_scale must be in (0, 1] (fraction of the sole); got {c!r}")
    lw = _positive(s, "qp_leg_weight", "share of the legs' weight, in [0, 1]", zero_ok=True)
    if lw > 1:
        raise ScenarioError(f"qp_leg_weight must be in [0, 1] (share of the legs' weight); got {lw!r}")
    _in_range("recovery_com_tol_m", _positive(s, "recovery_com_tol_m", "m"))
    _in_range("recovery_orientation_tol_deg", _positive(s, "recovery_orientation_tol_deg", "deg"))
    if not isinstance(s.seed, int) or isinstance(s.seed, bool) or not 0 <= s.seed <= MAX_SEED:
        raise ScenarioError(f"seed must be an integer >= 0 and < 2^63; got {s.seed!r}")
    if not isinstance(s.stepping, bool):
        raise ScenarioError(f"stepping must be true or false; got {s.stepping!r}")
    if not isinstance(s.max_steps, int) or isinstance(s.max_steps, bool) or not 0 <= s.max_steps <= 20:
        raise ScenarioError(f"max_steps must be an integer in [0, 20]; got {s.max_steps!r}")
    if s.stepping and s.controller != "workspace":
        raise ScenarioError(
            "stepping = true needs controller = 'workspace' (the stepping policy wraps W's controller)"
        )
    if not isinstance(s.model, str) or not s.model.strip():
        raise ScenarioError(
            f"model must be a shipped model's name ('wendlandt') or the path of an MJCF file; got {s.model!r}"
        )


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
    "PHYSICS",
    "PHYSICS_PRESETS",
    "TARGET_AXES",
    "W_JOINT_ANGLES_DEG",
    "Scenario",
    "keys",
    "parse_assignment",
    "toml_values",
    "validate",
]
