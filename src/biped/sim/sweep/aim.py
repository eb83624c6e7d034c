"""How a sweep's trial becomes a scenario: the block aimed at the body's initial COM line on a flat
ballistic arc (or another paradigm's keys sized), the gains scaled, and the ``hold`` task's set
point. Conventions: ``direction_deg`` is the direction the block *travels* in the horizontal plane,
measured from +x toward +y (W's throw travels at 180 deg, along -x)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from biped import models
from biped.sim.scenario import Scenario

if TYPE_CHECKING:
    from biped.sim.sweep.spec import Trial

GRAVITY = float(-models.gravity("wendlandt")[2])  # [m/s^2], the biped model's, which the scene keeps


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
    return base.with_overrides(
        block_mass_kg=trial.block_mass_kg, block_position_m=p0, block_velocity_m_s=v0, **gains
    )


__all__ = ["GRAVITY", "aim_block", "hold_scenario", "trial_scenario"]
