"""The rules a :class:`~biped.sim.scenario.Scenario` must satisfy: vector lengths, integer keys,
physical ranges (``RANGES``, docs/push.md "Valid ranges") and :func:`validate`, which raises a
one-line :class:`~biped.errors.ScenarioError` naming the first invalid key and what is valid.

``biped.sim.scenario`` calls :func:`validate` on every scenario it builds and re-exports
``RANGES`` and ``MAX_SEED``; the string choices (controllers, presets, ...) live there.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from typing import TYPE_CHECKING

from biped.errors import ScenarioError
from biped.models import JOINT_NAMES

if TYPE_CHECKING:
    from biped.sim.scenario import Scenario

#: Vector keys: (length, what the numbers are).
VECTORS = {
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
    "force_n": (3, "(Fx, Fy, Fz) in N, world frame"),
    "platform_displacement_m": (2, "(x, y) in m, world frame"),
    "pull_displacement_m": (2, "(x, y) in m, world frame"),
}
#: Integer keys.
INTS = {"seed", "max_steps"}

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
#: The words ``torque_limits`` and ``torque_rate_limit_n_m_s`` take besides numbers: none, the
#: human set (young adults) and the older adults' (biped.control.neuromotor).
LIMIT_WORDS = ("none", "human", "human-older")


def is_number(v) -> bool:
    """A real number: an int or a float, not a bool."""
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _in_range(key: str, v: float, kind: str | None = None, *, lo_open: bool = False) -> None:
    lo, hi, what = RANGES[kind or key]
    if v < lo or (lo_open and v == lo) or v > hi:
        left = "(" if lo_open else "["
        raise ScenarioError(f"{key} must be in {left}{lo:g}, {hi:g}] ({what}); got {v!r}")


def _finite(key: str, v, what: str) -> float:
    if not is_number(v):
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


def validate(s: Scenario, choices: Mapping[str, tuple[str, ...]]) -> None:
    """Raise :class:`ScenarioError` naming the first invalid key of ``s`` and what is valid.

    ``choices`` maps each string key to its valid values (``biped.sim.scenario`` holds that table,
    beside the controllers, supports, distributions and physics presets it names)."""
    for key, (n, what) in VECTORS.items():
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
    speed = math.hypot(*s.block_velocity_m_s)  # scaled: 1e308 m/s is 1e308, not inf
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
    bottom = s.block_position_m[2] - s.block_size_m[2] / 2
    if bottom < 0:
        raise ScenarioError(
            f"block_position_m: the block starts {-bottom * 1e3:.3g} mm inside the floor (its centre at "
            f"z = {s.block_position_m[2]:g} m, half its height {s.block_size_m[2] / 2:g} m); its z must be "
            f">= {s.block_size_m[2] / 2:g} m"
        )
    _in_range("joint_noise_deg", _positive(s, "joint_noise_deg", "standard deviation in deg", zero_ok=True))
    _in_range("initial_tilt_deg", _finite("initial_tilt_deg", s.initial_tilt_deg, "deg about -y"), "tilt_deg")
    _in_range(
        "target_tilt_deg", _finite("target_tilt_deg", s.target_tilt_deg, "deg about target_axis"), "tilt_deg"
    )
    for key, valid in choices.items():
        v = getattr(s, key)
        if v not in valid:
            raise ScenarioError(f"{key} must be one of {', '.join(map(repr, valid))}; got {v!r}")
    tl = s.torque_limits
    if isinstance(tl, tuple):
        if len(tl) != 12:
            raise ScenarioError(
                f"torque_limits must be 'none', 'human', 'human-older', one number or 12 numbers "
                f"({', '.join(JOINT_NAMES)}) in N m; got {len(tl)} numbers"
            )
        for i, x in enumerate(tl):
            if _finite(f"torque_limits[{i}]", x, "N m") <= 0:
                raise ScenarioError(f"torque_limits[{i}] must be > 0 N m; got {x!r}")
    elif tl not in LIMIT_WORDS and (not is_number(tl) or not math.isfinite(tl) or tl <= 0):
        raise ScenarioError(
            f"torque_limits must be 'none', 'human', 'human-older', one positive number or 12 of them "
            f"in N m; got {tl!r}"
        )
    _check_neuromotor(s)
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
    if not isinstance(s.early_stop, bool):
        raise ScenarioError(f"early_stop must be true or false; got {s.early_stop!r}")
    if not isinstance(s.qp_floor_friction, bool):
        raise ScenarioError(f"qp_floor_friction must be true or false; got {s.qp_floor_friction!r}")
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
    _check_perturbation(s)


def _check_perturbation(s: Scenario) -> None:
    """The keys of the perturbation paradigms (docs/perturbations.md); each paradigm's keys are
    checked whichever paradigm runs (a scenario file stays valid when the paradigm changes), the
    force body against the model only when the force runs (that needs the model file)."""
    for key, what in (
        ("force_start_s", "s after the start"),
        ("platform_start_s", "s after the start"),
        ("release_time_s", "s after the start"),
        ("pull_start_s", "s after the start"),
    ):
        if _positive(s, key, what, zero_ok=True) > 60.0:
            raise ScenarioError(f"{key} must be in [0, 60] ({what}); got {getattr(s, key)!r}")
    for key, paradigm in (("force_duration_s", "force"), ("platform_duration_s", "platform")):
        v = _positive(s, key, "duration in s")
        if v > 60.0:
            raise ScenarioError(f"{key} must be in (0, 60] s; got {v!r}")
        # at least one control period, checked when the paradigm runs (an unused paradigm's
        # default must not refuse a scenario that only changed control_rate_hz)
        if s.perturbation == paradigm and v < 1.0 / s.control_rate_hz:
            raise ScenarioError(
                f"{key} must be at least one control period, 1 / control_rate_hz = "
                f"{1.0 / s.control_rate_hz:g} s (and at most 60 s); got {v!r}"
            )
    if math.hypot(*s.force_n) > 1e5:
        raise ScenarioError(f"force_n must be at most 1e5 N in size (a push on a body); got {s.force_n}")
    if not isinstance(s.force_body, str) or not s.force_body.strip():
        raise ScenarioError(f"force_body must be the name of a body of the biped; got {s.force_body!r}")
    fp = s.force_point_m
    if isinstance(fp, tuple):
        if len(fp) != 3:
            raise ScenarioError(
                f"force_point_m must be 'pelvis' or 3 numbers (x, y, z) in m; got {len(fp)} numbers"
            )
        for i, x in enumerate(fp):
            _in_range(f"force_point_m[{i}]", _finite(f"force_point_m[{i}]", x, "m"), "position_m")
    elif fp != "pelvis":
        raise ScenarioError(
            f"force_point_m must be 'pelvis' or 3 numbers (x, y, z) in m, in force_body's frame; got {fp!r}"
        )
    from biped.sim.perturbations.platform import MAX_DISPLACEMENT_M

    if math.hypot(*s.platform_displacement_m) > MAX_DISPLACEMENT_M:
        raise ScenarioError(
            f"platform_displacement_m must be at most {MAX_DISPLACEMENT_M:g} m long (the feet stay on the "
            f"platform, a {2 * MAX_DISPLACEMENT_M + 2:g} m slab); got {s.platform_displacement_m}"
        )
    if math.hypot(*s.pull_displacement_m) > 2.0:
        raise ScenarioError(
            f"pull_displacement_m must be at most 2 m long (a pull at the waist); got {s.pull_displacement_m}"
        )
    v = _positive(s, "pull_velocity_m_s", "the motor's speed in m/s")
    if v > 10.0:
        raise ScenarioError(f"pull_velocity_m_s must be in (0, 10] m/s (the motor's speed); got {v!r}")
    lean = _finite("release_lean_deg", s.release_lean_deg, "deg")
    if not 0.0 <= lean <= 45.0:
        raise ScenarioError(
            f"release_lean_deg must be in [0, 45] deg (a lean about the ankles); got {lean!r}"
        )
    _finite("release_direction_deg", s.release_direction_deg, "deg")
    if s.perturbation == "release" and s.controller != "workspace":
        raise ScenarioError(
            "perturbation = 'release' needs controller = 'workspace', with or without stepping (the controller's "
            "set point holds the lean while the tether acts)"
        )
    if s.perturbation == "force" and s.force_body != "central_body":
        bodies = _biped_bodies(s.model)
        if s.force_body not in bodies:
            raise ScenarioError(
                f"force_body {s.force_body!r} is not a body of the biped; valid: {', '.join(bodies)}"
            )


@functools.lru_cache(maxsize=8)
def _biped_bodies(model: str) -> tuple[str, ...]:
    import mujoco

    from biped.models.subject import resolve

    m = mujoco.MjModel.from_xml_path(str(resolve(model)))
    return tuple(m.body(b).name for b in range(1, m.nbody))


def _check_neuromotor(s: Scenario) -> None:
    """The neuromotor keys: delay, rate limits, activation lag, ankle_only."""
    delay = _positive(s, "feedback_delay_s", "feedback delay in s", zero_ok=True)
    if delay > 1.0:
        raise ScenarioError(f"feedback_delay_s must be in [0, 1] s (human delays are ~0.1 s); got {delay!r}")
    steps = delay * s.control_rate_hz
    if abs(steps - round(steps)) > 1e-6:
        raise ScenarioError(
            f"feedback_delay_s must be a whole number of control periods (1 / control_rate_hz = "
            f"{1.0 / s.control_rate_hz:g} s); got {delay!r} s, i.e. {steps:.6g} periods"
        )
    act = _positive(s, "activation_time_s", "first-order activation time constant in s", zero_ok=True)
    if act > 1.0:
        raise ScenarioError(f"activation_time_s must be in [0, 1] s (muscle: ~0.01-0.1 s); got {act!r}")
    rl = s.torque_rate_limit_n_m_s
    what = "'none', 'human', 'human-older', one positive number or 12 of them in N m/s"
    if isinstance(rl, tuple):
        if len(rl) != 12:
            raise ScenarioError(
                f"torque_rate_limit_n_m_s must be {what} ({', '.join(JOINT_NAMES)}); got {len(rl)} numbers"
            )
        for i, x in enumerate(rl):
            if _finite(f"torque_rate_limit_n_m_s[{i}]", x, "N m/s") <= 0:
                raise ScenarioError(f"torque_rate_limit_n_m_s[{i}] must be > 0 N m/s; got {x!r}")
    elif rl not in LIMIT_WORDS and (not is_number(rl) or not math.isfinite(rl) or rl <= 0):
        raise ScenarioError(f"torque_rate_limit_n_m_s must be {what}; got {rl!r}")
    if not isinstance(s.ankle_only, bool):
        raise ScenarioError(f"ankle_only must be true or false; got {s.ankle_only!r}")
    if s.ankle_only and s.stepping:
        raise ScenarioError(
            "ankle_only = true holds the hips and knees: it cannot be used with stepping = true"
        )
