"""Support-surface translation (Horak & Nashner 1986; Jensen et al. 2001; Pai et al. 2000;
Koushyar et al. 2019): the floor under both feet moves along a ramp-and-hold path.

Keys: ``platform_displacement_m`` (x, y) [m], world frame; ``platform_duration_s`` the ramp's
duration; ``platform_start_s`` when it starts. The platform is the floor: a 4 m x 4 m slab whose
top is the plane z = 0 (the plane of W's scene stays for the eye and stops colliding), a body of
1000 kg on one slide joint along the displacement, so the feet stand on a moving body and MuJoCo's
contacts see the true relative velocity (friction carries the feet, slips when it must).

The path: ramp-and-hold, as in the papers, with a trapezoidal velocity: the platform accelerates
for the first quarter of the duration, moves at the constant peak velocity
``v = d / (0.75 T)`` for the middle half and decelerates for the last quarter, then holds. The
papers' platforms move at a constant velocity between start and stop (Horak & Nashner's ramps);
a real platform's motor cannot jump to that velocity, and the quarter-duration ramps give a
bounded acceleration ``a = v / (T / 4)`` instead of an impulse, which MuJoCo's soft contacts would
turn into an artificial jolt. The biped's first reaction is to that acceleration, the body
being carried by the feet; its COM moves relative to the feet at up to ``-v``.

The run starts from quiet stance (the soles on the floor, the controller's set point the starting
pose; :mod:`biped.sim.perturbations.base`).

Drive: a stiff servo, not a teleported pose. Three actuators on the slide joint: a position
servo (kp = M w^2, w = 2 pi 15 Hz) and a velocity servo (kv = 2 M w) that MuJoCo evaluates at
every physics step, and a motor carrying the feed-forward force ``M a(t)``. The references are
set each control period during the ramp, from a table computed once (the driver's
:class:`~biped.sim.schedule.Schedule`, which the compiled loop applies without returning to
Python); after it they hold the end position.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from biped.sim.perturbations.base import (
    Driver,
    Perturbation,
    Size,
    hold_here,
    horizontal,
    workspace_controller,
    world_direction_deg,
)
from biped.sim.schedule import Schedule

PLATFORM = "platform"
PLATFORM_JOINT = "platform_slide"
PLATFORM_MASS_KG = 1000.0
#: half the slab's edge [m]; a move may be at most PLATFORM_HALF_M - 1 m (the feet stay on it)
PLATFORM_HALF_M = 2.0
MAX_DISPLACEMENT_M = PLATFORM_HALF_M - 1.0
_SERVO_HZ = 15.0


def profile(t: np.ndarray | float, distance: float, duration: float) -> tuple:
    """(position [m], velocity [m/s], acceleration [m/s^2]) of the trapezoidal ramp-and-hold
    at time ``t`` [s] after its start (0 before it, ``distance`` after it)."""
    t = np.asarray(t, dtype=float)
    T = duration
    ta = 0.25 * T
    v = distance / (0.75 * T)
    a = v / ta
    x = np.where(
        t <= 0,
        0.0,
        np.where(
            t < ta,
            0.5 * a * t**2,
            np.where(
                t < T - ta,
                0.5 * a * ta**2 + v * (t - ta),
                np.where(t < T, distance - 0.5 * a * (T - t) ** 2, distance),
            ),
        ),
    )
    vel = np.where((t <= 0) | (t >= T), 0.0, np.where(t < ta, a * t, np.where(t < T - ta, v, a * (T - t))))
    acc = np.where((t <= 0) | (t >= T), 0.0, np.where(t < ta, a, np.where(t < T - ta, 0.0, -a)))
    return x, vel, acc


def add_platform(spec: mujoco.MjSpec, floor, axis) -> None:
    """The platform (module docstring) added to ``spec``: the slab on its slide joint along
    ``axis`` (3,) and its three actuators; the scene's ``floor`` geom stops colliding and is drawn
    under the slab."""
    floor.contype, floor.conaffinity = 0, 0  # the platform is the floor
    floor.pos = [0.0, 0.0, -0.101]  # drawn under the slab, not through its top
    body = spec.worldbody.add_body(name=PLATFORM, pos=[0.0, 0.0, 0.0])
    body.add_joint(name=PLATFORM_JOINT, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[float(a) for a in axis])
    h = PLATFORM_HALF_M
    body.add_geom(
        name=PLATFORM,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[h, h, 0.05],
        pos=[0.0, 0.0, -0.05],
        mass=PLATFORM_MASS_KG,
        rgba=[0.45, 0.55, 0.7, 1.0],
        contype=1,
        conaffinity=1,
    )
    w = 2 * math.pi * _SERVO_HZ
    kp, kv = PLATFORM_MASS_KG * w**2, 2 * PLATFORM_MASS_KG * w
    t = mujoco.mjtTrn.mjTRN_JOINT
    for name, gain, bias in (
        ("position", [kp], [0.0, -kp, 0.0]),
        ("velocity", [kv], [0.0, 0.0, -kv]),
        ("force", [1.0], [0.0, 0.0, 0.0]),
    ):
        spec.add_actuator(
            name=f"{PLATFORM}_{name}",
            target=PLATFORM_JOINT,
            trntype=t,
            gaintype=mujoco.mjtGain.mjGAIN_FIXED,
            biastype=mujoco.mjtBias.mjBIAS_AFFINE if name != "force" else mujoco.mjtBias.mjBIAS_NONE,
            gainprm=gain + [0.0] * 9,
            biasprm=bias + [0.0] * 7,
            ctrllimited=0,
        )


def ramp_rows(scenario) -> tuple[int, int]:
    """(first row, the row of the ramp's end) of the platform's move on control periods."""
    k0 = round(scenario.platform_start_s * scenario.control_rate_hz)
    return k0, k0 + max(1, round(scenario.platform_duration_s * scenario.control_rate_hz))


class PlatformDriver(Driver):
    """Sets the servo's references each control period of the ramp. With W's workspace
    controller, it also moves the controller's COM set point with the platform (by the platform's
    own measured displacement, each period of the ramp; by the whole move at its end): the set
    point is where the biped wants its COM over its feet, and the feet have moved. Both are data,
    its :attr:`schedule` (computed once), which the compiled loop applies itself; row 0 (the
    quiet stance's set point) is Python's."""

    def __init__(self, scenario, model: mujoco.MjModel, controller=None, central: int = 0):
        s = scenario
        self.period = 1.0 / s.control_rate_hz
        self.k0, self.k1 = ramp_rows(s)
        self.rows = np.unique(np.r_[0, np.arange(self.k0, self.k1 + 1)]).astype(np.int64)
        self.distance = math.hypot(*s.platform_displacement_m)
        self.duration = (self.k1 - self.k0) * self.period
        act = [model.actuator(f"{PLATFORM}_{n}").id for n in ("position", "velocity", "force")]
        self.qadr = int(model.jnt_qposadr[model.joint(PLATFORM_JOINT).id])
        self.axis = np.array(model.jnt_axis[model.joint(PLATFORM_JOINT).id])
        self.controller = controller
        self.target0 = np.zeros(3)
        self.central = central
        # the servo's references of each row of the ramp, at the middle of the period they hold
        # over (the end at the last row)
        k = np.arange(self.k1 - self.k0 + 1)
        tm = np.where(k < self.k1 - self.k0, (k + 0.5) * self.period, self.duration)
        x, v, a = profile(tm, self.distance, self.duration)
        follow = np.full(len(k), np.nan)  # the set point: the platform's measured position ...
        follow[-1] = self.distance  # ... and the whole move at the ramp's end
        self.schedule = Schedule(
            first=self.k0,
            actuators=np.array(act, dtype=np.int64),
            values=np.ascontiguousarray(np.column_stack([x, v, PLATFORM_MASS_KG * a])),
            python_rows=np.zeros(1, dtype=np.int64),
            follow_qpos=self.qadr if controller is not None else -1,
            axis=self.axis.astype(float),
            follow=follow,
            target=controller.target.array if controller is not None else np.zeros(3),
        )

    def apply(self, k: int, t: float, data: mujoco.MjData) -> None:
        sched = self.schedule
        assert sched is not None
        if k == 0 and self.controller is not None:  # quiet stance: hold the starting pose
            self.target0, quat = hold_here(self.controller, data, self.central)
            sched.base[:] = self.target0
            self.final_target = (self.target0 + self.distance * self.axis, quat)
        sched.apply(k, data.qpos, data.ctrl)


class Platform(Perturbation):
    name = "platform"
    keys = ("platform_displacement_m", "platform_start_s", "platform_duration_s")
    unit = "m"
    floor_geom = PLATFORM

    def axis(self) -> np.ndarray:
        d = np.array([*self.scenario.platform_displacement_m, 0.0])
        n = float(np.linalg.norm(d))
        return d / n if n > 0 else np.array([1.0, 0.0, 0.0])

    def edit_spec(self, spec: mujoco.MjSpec) -> None:
        super().edit_spec(spec)
        from biped.sim.scene import FLOOR

        add_platform(spec, spec.geom(FLOOR), self.axis())

    def over_row(self) -> int:
        """The ramp's end: the servo's references (and the controller's set point) hold from
        there; the platform's own motion after it is checked by the rule (every body outside
        the biped at rest)."""
        return ramp_rows(self.scenario)[1]

    def markers(self) -> list[tuple[float, str]]:
        s = self.scenario
        k0, k1 = ramp_rows(s)
        return [
            (k0 / s.control_rate_hz, "platform starts moving"),
            (k1 / s.control_rate_hz, "platform stops"),
        ]

    def driver(self, scene, model, data, policy):
        return PlatformDriver(self.scenario, model, workspace_controller(policy), scene.central_body)

    def size(self, total_mass_kg: float) -> Size:
        s = self.scenario
        d = math.hypot(*s.platform_displacement_m)
        k = max(1, round(s.platform_duration_s * s.control_rate_hz))
        v = d / (0.75 * k / s.control_rate_hz)
        # the body falls the other way: the push's direction is opposite the platform's move
        direction = (world_direction_deg(s.platform_displacement_m) + 180.0) % 360.0
        return Size(
            self.name, d, self.unit, direction, com_velocity_change_m_s=v, extra={"peak_velocity_m_s": v}
        )

    @classmethod
    def sized(cls, base, magnitude: float, direction_deg: float) -> dict:
        u = horizontal(direction_deg + 180.0)  # the platform moves against the push direction
        return {"platform_displacement_m": (float(magnitude * u[0]), float(magnitude * u[1]))}
