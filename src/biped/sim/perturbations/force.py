"""A force pulse at a point of the body: pushes (Mille et al. 2003; the robotics push tests such as
350 N for 0.15 s at the pelvis) and waist pulls, which are the same thing pulling.

Keys: ``force_n`` (3,) the peak force [N], world frame; ``force_start_s``; ``force_duration_s``;
``force_shape`` ``"rectangular"`` (default: the force is ``force_n`` for the whole duration) or
``"half-sine"`` (``force_n sin(pi (t - start) / duration)``: no jumps, peak ``force_n``, impulse
``2 / pi`` of the rectangle's); ``force_body`` the body pushed (a body of the biped, default the
central body); ``force_point_m`` the point of application in that body's frame [m] or
``"pelvis"`` (default: the midpoint of the hip joints, the central body's point at hip-joint height).

The run starts from quiet stance (the soles on the floor, the controller's set point the starting
pose; :mod:`biped.sim.perturbations.base`), so the response is the pulse's alone.

How: MuJoCo's ``xfrc_applied`` of the body, the force at the body's COM plus the moment
``(p - c) x F`` of the application point p about it, recomputed every control period while the
pulse acts (the body turns), held over the period's physics steps. The pulse starts and ends on
control periods (2 ms at 500 Hz): its duration is ``round(force_duration_s * rate)`` periods, and
the impulse recorded is that of the pulse applied (``summary.json``'s ``perturbation``).
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
    pelvis_point,
    point_track,
    workspace_controller,
    world_direction_deg,
)

SHAPES = ("rectangular", "half-sine")


def pulse_rows(start_s: float, duration_s: float, rate_hz: float) -> tuple[int, int]:
    """(first row, row after the last) of a pulse on control periods."""
    k0 = round(start_s * rate_hz)
    return k0, k0 + max(1, round(duration_s * rate_hz))


def shape_factor(shape: str, k: int, k0: int, k1: int) -> float:
    """The pulse's value (fraction of its peak) over control period ``k`` (its midpoint)."""
    if not k0 <= k < k1:
        return 0.0
    if shape == "rectangular":
        return 1.0
    return math.sin(math.pi * (k - k0 + 0.5) / (k1 - k0))


class ForceDriver(Driver):
    """Row 0: quiet stance (the controller holds the starting pose); the pulse's rows: the force."""

    def __init__(self, scenario, model, body: int, point: np.ndarray, controller=None, central: int = 0):
        self.k0, self.k1 = pulse_rows(
            scenario.force_start_s, scenario.force_duration_s, scenario.control_rate_hz
        )
        self.rows = np.unique(np.r_[0, np.arange(self.k0, self.k1 + 1)]).astype(np.int64)
        self.controller, self.central = controller, central
        self.body, self.point = body, np.asarray(point, dtype=float)
        self.force = np.asarray(scenario.force_n, dtype=float)
        self.shape = scenario.force_shape
        self.period = 1.0 / scenario.control_rate_hz
        self.impulse = np.zeros(3)  # the pulse as applied [N s]

    def apply(self, k: int, t: float, data: mujoco.MjData) -> None:
        if k == 0 and self.controller is not None:
            self.final_target = hold_here(self.controller, data, self.central)
        if not self.k0 <= k <= self.k1:
            return
        f = shape_factor(self.shape, k, self.k0, self.k1) * self.force
        b = self.body
        R = data.xmat[b].reshape(3, 3)
        p = data.xpos[b] + R @ self.point  # the application point, world [m]
        data.xfrc_applied[b, :3] = f
        data.xfrc_applied[b, 3:] = np.cross(p - data.xipos[b], f)
        self.impulse += f * self.period

    def finish(self, data: mujoco.MjData) -> dict:
        return {"impulse_applied_n_s": self.impulse.tolist()}


class Force(Perturbation):
    name = "force"
    keys = ("force_n", "force_start_s", "force_duration_s", "force_shape", "force_body", "force_point_m")
    unit = "N"

    def body_and_point(self, model: mujoco.MjModel) -> tuple[int, np.ndarray]:
        s = self.scenario
        body = model.body(s.force_body).id
        if s.force_point_m != "pelvis":
            return body, np.asarray(s.force_point_m, dtype=float)
        # the pelvis on the central body; another body's own frame origin
        return body, pelvis_point(model, body) if s.force_body == "central_body" else np.zeros(3)

    def driver(self, scene, model, data, policy):
        body, point = self.body_and_point(model)
        ctrl = workspace_controller(policy)
        return ForceDriver(self.scenario, model, body, point, ctrl, scene.central_body)

    def over_row(self) -> int:
        """The row after the pulse's last (the driver zeroes the force there)."""
        s = self.scenario
        return pulse_rows(s.force_start_s, s.force_duration_s, s.control_rate_hz)[1]

    def markers(self) -> list[tuple[float, str]]:
        s = self.scenario
        k0, k1 = pulse_rows(s.force_start_s, s.force_duration_s, s.control_rate_hz)
        f = float(np.linalg.norm(s.force_n))
        return [
            (k0 / s.control_rate_hz, f"force pulse starts ({f:.0f} N)"),
            (k1 / s.control_rate_hz, "force pulse ends"),
        ]

    def arrows(self, scene, result) -> np.ndarray | None:
        """The push while it acts: an arrow ending at the application point, 0.4 m long at the
        peak force, along the force."""
        s = self.scenario
        n = len(result.times)
        out = np.full((n, 2, 3), np.nan)
        k0, k1 = pulse_rows(s.force_start_s, s.force_duration_s, s.control_rate_hz)
        rows = np.arange(k0, min(k1, n))
        f = np.asarray(s.force_n, dtype=float)
        if not len(rows) or not np.linalg.norm(f):
            return out
        body, point = self.body_and_point(scene.model)
        p = point_track(scene, result.qpos, body, point, rows)
        u = f / np.linalg.norm(f)
        for i, k in enumerate(rows):
            out[k] = p[i] - 0.4 * shape_factor(s.force_shape, int(k), k0, k1) * u, p[i]
        return out

    def applied_impulse(self) -> np.ndarray:
        """(3,) the impulse of the pulse as the loop applies it [N s]."""
        s = self.scenario
        k0, k1 = pulse_rows(s.force_start_s, s.force_duration_s, s.control_rate_hz)
        w = sum(shape_factor(s.force_shape, k, k0, k1) for k in range(k0, k1))
        return np.asarray(s.force_n, dtype=float) * w / s.control_rate_hz

    def size(self, total_mass_kg: float) -> Size:
        f = self.scenario.force_n
        J = self.applied_impulse()
        jh = math.hypot(J[0], J[1])
        return Size(
            self.name, math.hypot(f[0], f[1]), self.unit, world_direction_deg(f), jh, jh / total_mass_kg
        )

    @classmethod
    def sized(cls, base, magnitude: float, direction_deg: float) -> dict:
        f = magnitude * horizontal(direction_deg)
        return {"force_n": (float(f[0]), float(f[1]), float(base.force_n[2]))}
