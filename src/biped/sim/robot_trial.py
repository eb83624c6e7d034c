"""One sweep trial on a robot's own MJCF (``biped sweep --model NAME``, ``biped envelope --model
NAME``): the sweep's trial (:class:`~biped.sim.sweep.spec.TrialSetup`, its scenario aimed at W's
biped) moved onto the robot (:func:`biped.sim.robot.robot_push`), measured into the sweep's row.

- **Block**: the scenario's block (its mass, the sweep's ``block_mass_kg``; its velocity; its start
  point relative to the aim line, ``launch_distance_m`` before it at ``height_m``) with the aim
  line moved to the robot's central-body COM at its standing pose. ``biped sweep`` scales the
  block's mass with the robot's mass and its height with the central-body COM height
  (:func:`robot_block_defaults`). The impulse is the block's own momentum change
  (:func:`biped.sim.sweep.trial.ballistic_impulse`).
- **Force**: the scenario's pulse (``force_n``, ``force_start_s``, ``force_duration_s``,
  ``force_shape``) at the midpoint of the robot's hip joints on its floating body
  (:class:`~biped.sim.robot.ForcePulse`; W's ``force_point_m = "pelvis"``).
- **Platform**: W's support-surface translation under the robot's feet
  (:class:`~biped.sim.robot.PlatformMove`), its size W's (displacement, peak velocity).
- **Pull**: W's waist pull (:class:`~biped.sim.robot.PullMove`) from the hip joints' midpoint;
  its impulse the cable's, as applied.
- **Release**: W's lean-and-release (:mod:`biped.sim.robot_release`): the lean's world
  direction is the sweep's (``world_direction(release_direction_deg)``, as on W's biped; the
  robots face +x, so 0 deg is a forward lean); its size the lean [deg], no impulse. A lean the
  feet cannot hold or the legs cannot reach raises (the sweep's row holds the error).
- **Stepping** (scenario key ``stepping``): the capture-point steps of
  :mod:`biped.sim.robot_stepping` (the scenario's ``step_trigger`` and ``max_steps``; W's
  parameters scaled to the robot's legs); recovered is then judged against the set point moved
  with the feet, and the rows carry the stepping columns (``step_count``, the recovery steps as
  on W's biped; ``closing_steps`` apart; ...).

The robot's controller is W's with the QP by default, the limits the sweep's ``torque_limits``
(``"model"``: the joints' ``actuatorfrcrange``). Survived: the central-body COM never 0.15 m below
its set point; recovered: survived and back within 1 cm of it horizontally at the end. With
``early_stop`` (on in sweeps and envelopes, as on W's biped) a trial also ends as recovered once
the robot is at rest near its set point after the perturbation (:class:`biped.sim.robot.RobotRest`).
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from biped.errors import ScenarioError
from biped.models.robot import RobotDescription, robot_for
from biped.sim.robot import (
    Block,
    ForcePulse,
    PlatformMove,
    PullMove,
    RobotRun,
    block_for,
    robot_controller,
    robot_push,
    standing_qpos,
)
from biped.sim.robot_rest import RECOVERED_WITHIN_M
from biped.sim.sweep.record import Measured
from biped.sim.sweep.spec import TrialSetup
from biped.sim.sweep.trial import _step_columns, ballistic_impulse

#: Perturbations a robot takes.
ROBOT_PERTURBATIONS = ("block", "force", "platform", "pull", "release")


def check_robot_scenario(scenario) -> None:
    """Refuse, before any work, what a robot trial cannot do (one line, what is valid)."""
    s = scenario
    if s.perturbation not in ROBOT_PERTURBATIONS:
        raise ScenarioError(
            f"perturbation {s.perturbation!r} is not available on robots; "
            f"valid on robots: {', '.join(ROBOT_PERTURBATIONS)}"
        )
    if s.controller != "workspace":
        raise ScenarioError(f"controller {s.controller!r} is not available on robots; valid: 'workspace'")
    if s.stepping and s.step_program != "feedback":
        raise ScenarioError(f"step_program {s.step_program!r} is not available on robots; valid: 'feedback'")
    if s.stepping and s.perturbation == "platform":
        raise ScenarioError("stepping on a moving platform is not available on robots yet")
    if s.perturbation == "force" and (s.force_body != "central_body" or s.force_point_m != "pelvis"):
        raise ScenarioError(
            "on robots the force pulse acts at the hip joints' midpoint on the floating body: "
            "force_body = 'central_body' and force_point_m = 'pelvis' only"
        )
    size = s.block_size_m
    if s.perturbation == "block" and not (size[0] == size[1] == size[2]):
        raise ScenarioError(f"on robots the block is a cube: block_size_m must be 3 equal edges; got {size}")


@functools.cache
def _robot(path: str) -> tuple[RobotDescription, np.ndarray]:
    """The robot and its central-body COM [m] at the standing pose (once per process)."""
    desc = robot_for(path)
    if desc is None:
        raise ScenarioError(f"{path!r} is not a robot (docs/robots.md)")
    ctrl = robot_controller(desc, "statics", "none")
    return desc, ctrl.link_poses(standing_qpos(desc, ctrl))[0][:3, 3].copy()


def robot_block_defaults(path: str, w_mass_kg: float) -> tuple[float, float]:
    """(block mass [kg], aim height [m]) of W's block moved onto the robot at ``path``: W's mass
    times the robot's mass over W's biped's (``w_mass_kg``), W's aim height times the robot's
    central-body COM height over W's (:data:`biped.sim.robot.W_BLOCK`)."""
    desc, _ = _robot(path)
    b = block_for(desc, w_mass_kg, robot_controller(desc, "statics", "none"))
    return b.mass_kg, b.position_m[2]


def run_robot(setup: TrialSetup) -> RobotRun:
    """The trial's run on the robot ``setup.robot``."""
    sc = setup.scenario
    check_robot_scenario(sc)
    desc, c = _robot(setup.robot)
    kw: dict[str, Any] = {}
    if sc.perturbation == "block":
        offset = np.asarray(sc.block_position_m[:2]) - np.asarray(sc.initial_com_m[:2])
        kw["block"] = Block(
            (float(c[0] + offset[0]), float(c[1] + offset[1]), float(sc.block_position_m[2])),
            tuple(float(v) for v in sc.block_velocity_m_s),
            float(sc.block_mass_kg),
            float(sc.block_size_m[0]),
        )
    elif sc.perturbation == "pull":
        kw["pull"] = PullMove(tuple(sc.pull_displacement_m), sc.pull_velocity_m_s, sc.pull_start_s)
    elif sc.perturbation == "release":
        from biped.sim.perturbations.release import world_direction
        from biped.sim.robot_release import ReleaseLean

        rd = world_direction(sc.release_direction_deg)  # the sweep's direction (W's key convention)
        kw["release"] = ReleaseLean(float(sc.release_lean_deg), rd, float(sc.release_time_s))
    elif sc.perturbation == "platform":
        kw["platform"] = PlatformMove(
            tuple(sc.platform_displacement_m), sc.platform_start_s, sc.platform_duration_s
        )
    else:
        kw["force"] = ForcePulse(tuple(sc.force_n), sc.force_start_s, sc.force_duration_s, sc.force_shape)
    if sc.stepping:  # capture-point steps (biped.sim.robot_stepping: W's parameters scaled)
        from biped.control.stepping_config import SteppingConfig

        kw["stepping"] = SteppingConfig.for_trigger(sc.step_trigger, max_steps=sc.max_steps)
    return robot_push(
        desc,
        sc.duration_s,
        distribution=sc.distribution,
        torque_limits=setup.torque_limits,
        early_stop=bool(sc.early_stop),
        qp_floor_friction=bool(sc.qp_floor_friction),
        **kw,
    )


def run_robot_trial(setup: TrialSetup) -> dict[str, Any]:
    """The sweep's row of one robot trial (:class:`~biped.sim.sweep.record.Measured`'s columns)."""
    sc, tr = setup.scenario, setup.trial
    run = run_robot(setup)
    desc, c = _robot(setup.robot)
    size = None
    if sc.perturbation == "block":
        assert run.block_velocity is not None
        J, t_hit = ballistic_impulse(run.t, run.block_velocity, sc.block_mass_kg)
        magnitude, unit = tr.speed_m_s, "m/s"
    elif sc.perturbation == "platform":  # W's platform's size (peak velocity; no impulse applied)
        from biped.sim.perturbations import of

        size = of(sc).size(desc.mass)
        J, t_hit = np.full(3, math.nan), sc.platform_start_s
        magnitude, unit = size.magnitude, size.unit
    elif sc.perturbation == "release":  # the lean [deg]; nothing is applied at the release
        J, t_hit = np.full(3, math.nan), sc.release_time_s
        magnitude, unit = float(sc.release_lean_deg), "deg"
    elif sc.perturbation == "pull":  # the cable's applied impulse; the size is the displacement
        J, t_hit = np.asarray(run.force_impulse_n_s, float), sc.pull_start_s
        magnitude, unit = float(np.hypot(*sc.pull_displacement_m)), "m"
    else:
        J, t_hit = np.asarray(run.force_impulse_n_s, float), sc.force_start_s
        magnitude, unit = float(np.hypot(sc.force_n[0], sc.force_n[1])), "N"
    jh = float(np.hypot(J[0], J[1]))
    excursion = np.linalg.norm(run.com[:, :2] - run.com[0, :2], axis=1)
    recovered = (not run.fell) and run.final_offset_m < RECOVERED_WITHIN_M
    return Measured(
        recovered=recovered,
        fell=run.fell,
        impulse_n_s=float(np.linalg.norm(J)),
        impulse_horizontal_n_s=jh,
        impulse_x_n_s=float(J[0]),
        impulse_y_n_s=float(J[1]),
        impulse_z_n_s=float(J[2]),
        block_contact_time_s=float(t_hit) if t_hit is not None else math.nan,
        max_com_excursion_m=float(excursion.max()),
        final_com_error_m=run.final_offset_m,
        peak_torque_n_m=float(np.max(np.abs(run.torques))),
        simulated_time_s=float(run.t[-1]) if len(run.t) else 0.0,
        completed=True,
        fall_reason="fell" if run.fell else None,
        paradigm=sc.perturbation,
        paradigm_magnitude=float(magnitude),
        paradigm_unit=unit,
        push_direction_deg=float(tr.direction_deg),
        horizontal_impulse_n_s=jh,
        com_velocity_change_m_s=jh / desc.mass if size is None else size.com_velocity_change_m_s,
        stop_reason=run.stop_reason,
        stopped_at_s=float(run.t[-1]) if run.stop_reason is not None and len(run.t) else math.nan,
        # the recovery steps (those max_steps counts); closing steps are the closing_steps column
        step_count=sum(1 for s in run.steps or () if not s.get("closing")),
        **_step_columns(run.steps or ()),
    ).row()
