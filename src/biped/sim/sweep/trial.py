"""One push trial of a sweep and its measurements: the closed loop of :mod:`biped.sim.push` on
its MuJoCo scene (built once per process and reused), then :func:`measure` -> :class:`Measured`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

from biped import models
from biped.control.limits import torque_limits
from biped.model import TreeModel
from biped.models import subject
from biped.sim.push import PushResult, controller_policy, run_closed_loop
from biped.sim.scenario import Scenario
from biped.sim.scene import Scene, build_scene
from biped.sim.sweep.aim import GRAVITY
from biped.sim.sweep.record import Measured
from biped.sim.sweep.spec import TrialSetup

_SCENES: dict[tuple, Scene] = {}
_TREES: dict[str, TreeModel] = {}
_MASSES: dict[str, float] = {}
_CACHE_SIZE = 16


#: Scenario keys that a trial changes and the scene does not depend on (set in the initial state
#: or read by the controller only).
_NOT_SCENE = frozenset(
    {"block_position_m", "block_velocity_m_s", "kp_com", "kv_com", "kp_rot", "kv_rot"}
    | {"force_n", "force_start_s", "force_duration_s", "force_shape", "force_body", "force_point_m"}
    | {
        "release_lean_deg",
        "release_direction_deg",
        "release_time_s",
        "platform_start_s",
        "platform_duration_s",
    }
)


def _scene_for(scenario: Scenario) -> Scene:
    """A compiled push scene for ``scenario``, cached per process and reused by every trial that
    differs only in the block's start state and the gains (any other key builds its own)."""
    key = tuple(sorted((k, repr(v)) for k, v in scenario.to_dict().items() if k not in _NOT_SCENE))
    scene = _SCENES.get(key)
    if scene is None:
        if len(_SCENES) >= _CACHE_SIZE:
            _SCENES.pop(next(iter(_SCENES)))
        scene = _SCENES[key] = build_scene(scenario)
    return scene


def _tree(model: str) -> TreeModel:
    if model not in _TREES:
        _TREES[model] = TreeModel.from_mjcf(subject.resolve(model))
    return _TREES[model]


def _mass_kg(model: str) -> float:
    """The model's total mass, once per worker (a path's file is compiled to read it)."""
    if model not in _MASSES:
        _MASSES[model] = models.total_mass_kg(model)
    return _MASSES[model]


def make_policy(
    setup: TrialSetup, scene: Scene
) -> Callable[[float, np.ndarray, np.ndarray, tuple[bool, bool]], np.ndarray]:
    """The trial's loop policy ``policy(t, qpos_biped, qvel_biped, feet) -> torques (12,)`` in
    ``scene.joint_names`` order (:func:`biped.sim.push.controller_policy`): W's workspace
    controller with the scenario's set point, gains and distribution, or the joint-space PD of
    :mod:`biped.control.joint_pd` holding the initial joint angles (its gains times
    ``gain_scale``); the sweep's torque limits clip the torques and, with the QP distribution,
    are constraints of the QP."""
    limits = torque_limits(setup.torque_limits, body_mass_kg=_mass_kg(setup.scenario.model))
    tree = _tree(setup.scenario.model) if setup.scenario.controller == "workspace" else None
    return controller_policy(
        setup.scenario,
        scene,
        gain_scale=setup.trial.gain_scale,
        torque_limits=None if limits.unlimited else limits,
        tree=tree,
    )


def run_trial(setup: TrialSetup) -> dict[str, Any]:
    """Simulate one push (the closed loop of :mod:`biped.sim.push` on its MuJoCo scene) and
    measure it (:func:`measure`); returns the row of measured columns. Ctrl-C during the trial
    propagates (the trial is not recorded)."""
    sc = setup.scenario
    scene = _scene_for(sc)
    policy = make_policy(setup, scene)
    result = run_closed_loop(sc, scene, policy)
    if result.interrupted:
        raise KeyboardInterrupt
    return measure(result, np.asarray(result.block_velocity), scene=scene).row()


def ballistic_impulse(
    times,
    velocity,
    mass_kg: float,
    gravity=(0.0, 0.0, -GRAVITY),
    contact_time_s: float | None = None,
    tol: float = 1e-6,
):
    """Impulse [N s] (3,) delivered BY a free-flying block TO what it hits, from its momentum
    change: ``J = -m (u_after - u_before)``, ``u = v - g t``.

    ``times`` (n,) [s], ``velocity`` (n, 3) [m/s] of the block's centre of mass (world frame)
    sampled at a fixed rate. In free flight ``u`` is constant (only gravity acts), so the
    ballistic invariant before the first contact and on the first free-flight stretch after it
    (``u`` constant over 3 samples) give the momentum change due to the contact alone, wherever
    the samples fall relative to the impact. Returns (J, t_first_deviation); J is NaN when the
    block never flies free again (it stays in contact) and zero when it never touches anything.
    ``contact_time_s``, when given, must match the first deviation within two samples (else the
    block hit something else first and J is NaN).
    """
    t = np.asarray(times, dtype=float)
    v = np.asarray(velocity, dtype=float)
    u = v - np.outer(t, np.asarray(gravity, dtype=float))
    dev = np.linalg.norm(u - u[0], axis=1) > tol * max(1.0, float(np.linalg.norm(u[0])))
    if not dev.any():
        return np.zeros(3), None
    k1 = int(np.argmax(dev))
    t1 = float(t[k1])
    if contact_time_s is not None and len(t) > 1:
        dt = float(t[1] - t[0])
        if abs(t1 - contact_time_s) > 2.01 * dt:
            return np.full(3, np.nan), t1
    step = np.linalg.norm(np.diff(u, axis=0), axis=1)
    free = step <= tol * max(1.0, float(np.linalg.norm(u[0])))
    for k in range(k1, len(u) - 2):
        if free[k] and free[k + 1]:
            return -mass_kg * (u[k] - u[0]), t1
    return np.full(3, np.nan), t1


def measure(result: PushResult, block_velocity: np.ndarray, *, scene: Scene | None = None) -> Measured:
    """The sweep's measured columns (:class:`Measured`) from one :class:`biped.sim.push.PushResult`.

    impulse_*: :func:`ballistic_impulse` of the block's velocity at the control rate.
    max_com_excursion_m: largest horizontal distance of the central-body COM from the set
        point after the block's first contact (whole run if it never hits).
    time_to_recover_s: from the first contact to the last moment the COM error reaches
        ``recovery_com_tol_m`` or the orientation error ``recovery_orientation_tol_deg``;
        NaN unless ``recovered``.
    left/right_lift_off, lift_off_count: ``lift_off`` events (heel or toe) after the contact.
    left/right_slip_m, max_foot_lift_m: largest horizontal displacement / rise of each foot
        body (MuJoCo kinematics of the recorded qpos) from where it stood once both its heel
        and toe first touched the floor (a slide or a step).
    """
    sc = result.scenario
    t = result.times
    n = len(t)
    tc = result.block_contact_time_s
    J, _ = ballistic_impulse(t, block_velocity[:n], sc.block_mass_kg, contact_time_s=tc)
    after = t >= (tc if tc is not None else -np.inf)
    d_xy = np.linalg.norm(result.com[:, :2] - result.target_com[:2], axis=1)
    max_exc = float(d_xy[after].max()) if after.any() else float("nan")
    ttr = float("nan")
    if result.recovered and n:
        com_err = np.linalg.norm(result.com - result.target_com, axis=1)
        q, qt = result.quat, np.asarray(result.target_quat, dtype=float)
        c = np.abs(q @ qt) / (np.linalg.norm(q, axis=1) * np.linalg.norm(qt))
        ori_err = np.degrees(2.0 * np.arccos(np.minimum(1.0, c)))  # orientation_error_deg, rowwise
        bad = (com_err >= sc.recovery_com_tol_m) | (ori_err >= sc.recovery_orientation_tol_deg)
        t0 = tc if tc is not None else 0.0
        bad &= t >= t0
        ttr = float(t[np.flatnonzero(bad)[-1] + 1] - t0) if bad.any() else 0.0
    t_after = tc if tc is not None else float("inf")
    lifts = [e for e in result.events if e.kind == "lift_off" and e.time_s >= t_after]
    slip, rise = _foot_motion(result, scene)
    ran_out = bool(n and t[-1] >= sc.duration_s - 0.5 / sc.control_rate_hz)
    at_rest = result.stop_reason is not None
    stop_reason = result.stop_reason
    if not ran_out and stop_reason is None:
        stop_reason = (
            "fell"
            if result.fell
            else "diverged"
            if result.diverged
            else "controller_error"
            if result.controller_error
            else None
        )
    return Measured(
        recovered=bool(result.recovered),
        fell=bool(result.fell),
        impulse_n_s=float(np.linalg.norm(J)),
        impulse_horizontal_n_s=float(np.hypot(J[0], J[1])),
        impulse_x_n_s=float(J[0]),
        impulse_y_n_s=float(J[1]),
        impulse_z_n_s=float(J[2]),
        block_contact_time_s=float(tc) if tc is not None else float("nan"),
        max_com_excursion_m=max_exc,
        time_to_recover_s=ttr,
        final_com_error_m=float(result.final_com_error_m),
        final_orientation_error_deg=float(result.final_orientation_error_deg),
        left_lift_off=any(e.foot == "left" for e in lifts),
        right_lift_off=any(e.foot == "right" for e in lifts),
        lift_off_count=len(lifts),
        max_foot_lift_m=rise,
        left_slip_m=slip[0],
        right_slip_m=slip[1],
        peak_torque_n_m=float(np.abs(result.torques).max()) if n else float("nan"),
        simulated_time_s=float(t[-1]) if n else 0.0,
        completed=bool(n and (ran_out or at_rest) and not result.interrupted),
        fall_reason=result.fall_reason,
        controller_error=result.controller_error,
        diverged=getattr(result, "diverged", None),
        step_count=sum(1 for s in result.extra.get("steps", ()) if not s.get("closing")),
        **_step_columns(result.extra.get("steps", ())),
        final_stance_width_m=abs(result.extra.get("final_stance_m", (np.nan, np.nan))[1]),
        **_perturbation_columns(result, scene, float(np.hypot(J[0], J[1]))),
        stop_reason=stop_reason,
        stopped_at_s=float(t[-1]) if n and stop_reason is not None else float("nan"),
    )


def _step_columns(steps) -> dict:
    """The stepping columns of :class:`Measured` from the policy's ``steps`` (docs/controller.md)."""
    off = [s.get("xcom_offset_m") for s in steps if s.get("xcom_offset_m") is not None]
    slip = [s["stance_slip_m"] for s in steps if s.get("stance_slip_m") is not None]
    return {
        "first_step_xcom_offset_m": float(off[0]) if off else float("nan"),
        "max_stance_slip_m": float(max(slip)) if slip else float("nan"),
        "closing_steps": sum(1 for s in steps if s.get("closing")),
    }


def _perturbation_columns(result: PushResult, scene: Scene | None, block_impulse_h: float) -> dict:
    """The paradigm's and the response's columns of :class:`Measured` (docs/perturbations.md)."""
    from dataclasses import fields

    from biped.sim.loop_measures import loop_rows
    from biped.sim.perturbations import of
    from biped.sim.response import ResponseMeasures, measure_response

    sc = result.scenario
    scene = scene if scene is not None else _scene_for(sc)
    mass = float(scene.model.body_subtreemass[scene.model.body_rootid[scene.central_body]])
    size = of(sc).size(mass)
    jh = block_impulse_h if sc.perturbation == "block" else size.impulse_horizontal_n_s
    dv = jh / mass if sc.perturbation == "block" else size.com_velocity_change_m_s
    out = {
        "paradigm": size.paradigm,
        "paradigm_magnitude": size.magnitude,
        "paradigm_unit": size.unit,
        "push_direction_deg": size.direction_deg,
        "horizontal_impulse_n_s": jh,
        "com_velocity_change_m_s": dv,
    }
    # from the loop's own forward passes (biped.sim.loop_measures): a second pass over the rows
    # (measure_rows) cost ~4x an early-stopped block trial
    resp = measure_response(scene, result, loop_rows(scene, result))
    out.update({f.name: getattr(resp, f.name) for f in fields(ResponseMeasures)})  # Measured's own
    return out


def _foot_motion(result, scene) -> tuple[tuple[float, float], float]:
    """((left slip, right slip) [m], max foot rise [m]); see :func:`measure`."""
    pos = result.feet_pos  # MuJoCo kinematics of the recorded qpos (biped.sim.push)
    if pos is None:
        if scene is None:
            scene = _scene_for(result.scenario)
        m = scene.model
        d = mujoco.MjData(m)
        feet = [m.body(f"{side}_foot").id for side in ("left", "right")]
        n = len(result.times)
        pos = np.zeros((n, 2, 3))
        for k in range(n):
            d.qpos[:] = result.qpos[k]
            mujoco.mj_kinematics(m, d)
            pos[k] = d.xpos[feet]
    slips, rise = [], 0.0
    for i, flags in enumerate((result.contacts[:, 0:2], result.contacts[:, 2:4])):
        planted = np.flatnonzero(flags.all(axis=1))
        if not len(planted):
            slips.append(float("nan"))
            continue
        k0 = planted[0]
        ref = pos[k0, i]
        slips.append(float(np.linalg.norm(pos[k0:, i, :2] - ref[:2], axis=1).max()))
        rise = max(rise, float((pos[k0:, i, 2] - ref[2]).max()))
    return (slips[0], slips[1]), rise


__all__ = ["ballistic_impulse", "make_policy", "measure", "run_trial"]
