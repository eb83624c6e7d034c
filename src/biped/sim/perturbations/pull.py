"""A motor-driven waist pull that imposes a displacement (Mille et al. 2003, J Neurophysiol
90:666-674: standing subjects pulled forward at the waist, the pull's size its displacement
relative to the base of support, at a set velocity).

Keys: ``pull_displacement_m`` (x, y) [m], world frame (the motor end's travel; -x pulls the biped
forward, the way it faces); ``pull_velocity_m_s`` the motor's speed; ``pull_start_s``.

A stiff cable from the pelvis (the central body's point between the hip joints) to a motor: the
motor end moves along the displacement on the platform's trapezoidal ramp
(:func:`biped.sim.perturbations.platform.profile`: a quarter of the time accelerating, half at
the peak velocity ``pull_velocity_m_s``, a quarter decelerating; a motor cannot jump to its
speed, and a jump would jolt the pelvis through the cable's damping), then the cable is let go.
The cable pulls only (no push), with tension ``max(0, k e + c e')``, ``e`` the motor end's
travel minus the pelvis's along the pull (the cable taut, unstretched, at the start), ``k`` =
:data:`CABLE_STIFFNESS_N_M`, ``c`` = :data:`CABLE_DAMPING_N_S_M`. With a stiff cable the pelvis
is carried the displacement: the pull imposes a displacement, not a force (compare ``force``,
which imposes a force). What Mille's motor
did after its travel is not in the abstract; letting the cable go leaves the biped to recover
from where and how fast the pull left it.

The tension is recomputed every control period while the pull acts (held over the period's
physics steps, like the force pulse's ``xfrc_applied``); the pelvis velocity is the change of
its position over the last period. The run starts from quiet stance
(:mod:`biped.sim.perturbations.base`).
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
from biped.sim.perturbations.platform import profile

#: The cable's stiffness [N/m]: 1 cm of stretch per 200 N; the explicit update (2 ms periods)
#: keeps omega dt = sqrt(k / 73 kg) 2 ms = 0.03, far below its stability limit 2.
CABLE_STIFFNESS_N_M = 20000.0
#: The cable's damping [N s/m] (damping ratio ~0.5 with the body's 73 kg).
CABLE_DAMPING_N_S_M = 1200.0


def pull_rows(scenario) -> tuple[int, int]:
    """(first row, row the cable is let go) of the pull on control periods: the motor's travel
    takes ``d / (0.75 v)`` (the platform's trapezoid with peak velocity ``v``)."""
    d = math.hypot(*scenario.pull_displacement_m)
    k0 = round(scenario.pull_start_s * scenario.control_rate_hz)
    return k0, k0 + max(1, round(d / (0.75 * scenario.pull_velocity_m_s) * scenario.control_rate_hz))


class PullDriver(Driver):
    """Row 0: quiet stance; the pull's rows: the cable's tension at the pelvis."""

    def __init__(self, scenario, model, body: int, point: np.ndarray, controller=None):
        self.k0, self.k1 = pull_rows(scenario)
        self.rows = np.unique(np.r_[0, np.arange(self.k0, self.k1 + 1)]).astype(np.int64)
        self.controller, self.body, self.point = controller, body, np.asarray(point, dtype=float)
        d = np.asarray(scenario.pull_displacement_m, dtype=float)
        self.length = float(np.linalg.norm(d))
        self.u = np.r_[d / self.length, 0.0] if self.length > 0 else np.zeros(3)
        self.duration = (self.k1 - self.k0) / scenario.control_rate_hz
        self.period = 1.0 / scenario.control_rate_hz
        self.p0: np.ndarray | None = None
        self.p_prev: np.ndarray | None = None
        self.peak_tension = 0.0
        self.impulse = np.zeros(3)
        self.pelvis_travel = 0.0
        # the motor end's travel and speed at each row of the pull, computed once
        travel, speed, _ = profile(np.arange(self.k1 - self.k0 + 1) * self.period, self.length, self.duration)
        self.motor = list(zip(travel.tolist(), speed.tolist(), strict=True))

    def _pelvis(self, data) -> np.ndarray:
        b = self.body
        return data.xpos[b] + data.xmat[b].reshape(3, 3) @ self.point

    def apply(self, k: int, t: float, data: mujoco.MjData) -> None:
        if k == 0 and self.controller is not None:
            self.final_target = hold_here(self.controller, data, self.body)
        if not self.k0 <= k <= self.k1:
            return
        b = self.body
        p = self._pelvis(data)
        if self.p0 is None:
            self.p0 = p.copy()
            self.p_prev = p.copy()
        assert self.p_prev is not None
        if k == self.k1:  # the motor has travelled the displacement: the cable is let go
            data.xfrc_applied[b] = 0.0
            self.pelvis_travel = float((p - self.p0) @ self.u)
            return
        travel, speed = self.motor[k - self.k0]
        e = travel - float((p - self.p0) @ self.u)
        e_dot = speed - float((p - self.p_prev) @ self.u) / self.period
        tension = max(0.0, CABLE_STIFFNESS_N_M * e + CABLE_DAMPING_N_S_M * e_dot) if k > self.k0 else 0.0
        f = tension * self.u
        data.xfrc_applied[b, :3] = f
        (r0, r1, r2), (f0, f1, f2) = (p - data.xipos[b]).tolist(), f.tolist()
        data.xfrc_applied[b, 3:] = (r1 * f2 - r2 * f1, r2 * f0 - r0 * f2, r0 * f1 - r1 * f0)  # np.cross's
        self.p_prev = p.copy()
        self.peak_tension = max(self.peak_tension, tension)
        self.impulse += f * self.period

    def finish(self, data: mujoco.MjData) -> dict:
        return {
            "peak_tension_n": self.peak_tension,
            "impulse_applied_n_s": self.impulse.tolist(),
            "pelvis_travel_m": self.pelvis_travel,
        }


class Pull(Perturbation):
    name = "pull"
    keys = ("pull_displacement_m", "pull_velocity_m_s", "pull_start_s")
    unit = "m"

    def driver(self, scene, model, data, policy):
        body = scene.central_body
        return PullDriver(self.scenario, model, body, pelvis_point(model, body), workspace_controller(policy))

    def over_row(self) -> int:
        """The row the cable is let go (the driver zeroes its force there; nothing acts after)."""
        return pull_rows(self.scenario)[1]

    def markers(self) -> list[tuple[float, str]]:
        s = self.scenario
        k0, k1 = pull_rows(s)
        d = math.hypot(*s.pull_displacement_m)
        return [
            (k0 / s.control_rate_hz, f"waist pull starts ({d:.3f} m at {s.pull_velocity_m_s:g} m/s)"),
            (k1 / s.control_rate_hz, "cable let go"),
        ]

    def arrows(self, scene, result) -> np.ndarray | None:
        """The cable while it pulls: 0.5 m from the pelvis along the pull."""
        s = self.scenario
        n = len(result.times)
        out = np.full((n, 2, 3), np.nan)
        k0, k1 = pull_rows(s)
        rows = np.arange(k0, min(k1, n))
        d = np.asarray(s.pull_displacement_m, dtype=float)
        if not len(rows) or not np.linalg.norm(d):
            return out
        cb = scene.central_body
        p = point_track(scene, result.qpos, cb, pelvis_point(scene.model, cb), rows)
        u = np.r_[d / np.linalg.norm(d), 0.0]
        out[rows, 0] = p
        out[rows, 1] = p + 0.5 * u
        return out

    def size(self, total_mass_kg: float) -> Size:
        d = self.scenario.pull_displacement_m
        return Size(self.name, math.hypot(*d), self.unit, world_direction_deg((d[0], d[1], 0.0)),
                    extra={"velocity_m_s": float(self.scenario.pull_velocity_m_s)})  # fmt: skip

    @classmethod
    def sized(cls, base, magnitude: float, direction_deg: float) -> dict:
        v = magnitude * horizontal(direction_deg)
        return {"pull_displacement_m": (float(v[0]), float(v[1]))}
