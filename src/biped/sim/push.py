"""W section 4 closed loop on MuJoCo: the biped rises to its set point while the block hits it.

>>> from biped.sim import Scenario, simulate
>>> result = simulate(Scenario(duration_s=0.2))   # W's defaults but 0.2 s (default 3 s)
>>> result.block_contact_time_s, result.fell
(0.082, False)

``biped.outputs.push.write_outputs(result, "runs/mine")`` writes summary.json, trajectory.csv,
the figures, the video and the replay.

Loop (one control period ``1 / control_rate_hz``): read the biped's qpos/qvel (its own layout,
picked out of the scene by name), ask the policy for torques, hold them for ``control_substeps``
physics steps (zero-order hold), record. Row k of the trajectory is the state at ``t_k = k / rate``
and the torques computed from it (applied on [t_k, t_k+1)). A fall ends the run early; it is a
result (``fell = True``), not an exception.

A policy is any callable ``policy(t, qpos_biped (19,), qvel_biped (18,), feet (left, right))
-> torques (12,)`` [N m] in ``scene.joint_names`` order: :func:`controller_policy` (W's controller
or the joint-PD baseline, from :func:`biped.control.policy.make_policy`) or
:class:`RecordedTorques` (an open-loop replay). :func:`run_closed_loop` runs any of them.
"""

from __future__ import annotations

import math
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field

import mujoco
import numpy as np

from biped.errors import BipedError, ScenarioError
from biped.sim import fused as fused_mod
from biped.sim import perturbations
from biped.sim.contact import SOLE_GEOMS, ContactMonitor
from biped.sim.early_stop import AT_REST, EarlyStop
from biped.sim.early_stop import applies as early_stop_applies
from biped.sim.held_signals import HeldSignals
from biped.sim.jit import announce_and_warm, kernels_for
from biped.sim.loop_measures import NCOL, fill_rows, record_python, row_spec
from biped.sim.neuro import neuro_loop
from biped.sim.policies import (  # noqa: F401 - offered here too, as before the split
    ControllerPolicy,
    RecordedTorques,
    controller_policy,
    policy_config,
    scenario_limits,
)
from biped.sim.scenario import Scenario
from biped.sim.scene import Scene, build_scene, initial_state, tilt_quat
from biped.sim.schedule import merged_inputs

_BADQACC = int(mujoco.mjtWarning.mjWARN_BADQACC)

#: The foot bodies whose poses a result records, (left, right).
FOOT_BODIES = ("left_foot", "right_foot")

__all__ = [
    "FOOT_BODIES",
    "PushResult",
    "RecordedTorques",
    "controller_policy",
    "orientation_error_deg",
    "policy_config",
    "replay_torques",
    "run_closed_loop",
    "simulate",
]


@dataclass(frozen=True, eq=False)
class PushResult:
    """One push run, sampled at the control rate (n rows; world frame, SI units).

    times (n,) [s]; qpos (n, nq_scene) / qvel (n, nv_scene) the scene's state (biped + block);
    com (n, 3) central-body COM [m] (MuJoCo's ``xipos`` as left by the last physics step, i.e.
    at t_k - physics_timestep_s for k > 0); quat (n, 4) the central body's orientation (w, x, y, z);
    joint_angles (n, 12) [rad] and torques (n, 12) [N m] in ``joint_names`` order (row k's torques
    are those held on [t_k, t_k+1)); block (n, 3) block centre [m]; block_velocity (n, 3) [m/s];
    contacts (n, 4) bool sole-part contacts in :data:`biped.sim.contact.SOLE_GEOMS` order;
    feet_pos (n, 2, 3) [m] and feet_quat (n, 2, 4) the poses of the :data:`FOOT_BODIES` frames
    (MuJoCo kinematics of ``qpos``); loop_measures (n, :data:`biped.sim.loop_measures.NCOL`) what
    the response needs of each row, from the loop's own forward passes (:mod:`biped.sim.loop_measures`).
    """

    scenario: Scenario
    joint_names: tuple
    times: np.ndarray
    qpos: np.ndarray
    com: np.ndarray
    quat: np.ndarray
    joint_angles: np.ndarray
    torques: np.ndarray
    block: np.ndarray
    contacts: np.ndarray
    events: tuple
    block_contact_time_s: float | None
    block_momentum_before: np.ndarray  # (3,) [kg m/s]
    block_momentum_after: np.ndarray  # (3,) at the end of the run
    fell: bool
    fall_time_s: float | None
    fall_reason: str | None
    interrupted: bool
    target_com: np.ndarray
    target_quat: np.ndarray
    final_com_error_m: float
    final_orientation_error_deg: float
    recovered: bool
    wall_time_s: float
    realtime_factor: float
    controller_error: str | None = None
    diverged: str | None = None
    stop_reason: str | None = None  # "at_rest": ended early by the early_stop rule (biped.sim.early_stop)
    qvel: np.ndarray | None = None
    block_velocity: np.ndarray | None = None
    feet_pos: np.ndarray | None = None
    feet_quat: np.ndarray | None = None
    extra: dict = field(default_factory=dict)
    loop_measures: np.ndarray | None = None

    @property
    def left_contact(self) -> np.ndarray:
        """(n,) bool: the left heel or toe touches the floor."""
        return self.contacts[:, 0] | self.contacts[:, 1]

    @property
    def right_contact(self) -> np.ndarray:
        return self.contacts[:, 2] | self.contacts[:, 3]


def orientation_error_deg(quat, target_quat) -> float:
    """Angle [deg] of the rotation between two unit quaternions (w, x, y, z)."""
    c = abs(float(np.dot(quat, target_quat))) / (np.linalg.norm(quat) * np.linalg.norm(target_quat))
    return math.degrees(2.0 * math.acos(min(1.0, float(c))))


# ---------------------------------------------------------------------------------------------
# the loop


def _as_slice(index: np.ndarray):
    """``index`` as a slice when it is a contiguous range (a view, no copy), else itself."""
    if len(index) and np.array_equal(index, np.arange(index[0], index[0] + len(index))):
        return slice(int(index[0]), int(index[0]) + len(index))
    return index


_KINEMATICS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _feet_poses(scene: Scene, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2, 3) positions and (n, 2, 4) quaternions of :data:`FOOT_BODIES` (mj_kinematics)."""
    m = scene.model
    d = _KINEMATICS.get(m)
    if d is None:  # one MjData per model for this (a sweep calls it once a trial)
        d = _KINEMATICS[m] = mujoco.MjData(m)
    f0, f1 = (m.body(f).id for f in FOOT_BODIES)
    n = len(qpos)
    pos = np.empty((n, 2, 3))
    quat = np.empty((n, 2, 4))
    dq, xpos, xquat, kinematics = d.qpos, d.xpos, d.xquat, mujoco.mj_kinematics
    for k in range(n):  # ~3 us a row: no temporary arrays
        dq[:] = qpos[k]
        kinematics(m, d)
        pos[k, 0] = xpos[f0]
        pos[k, 1] = xpos[f1]
        quat[k, 0] = xquat[f0]
        quat[k, 1] = xquat[f1]
    return pos, quat


def run_closed_loop(
    scenario: Scenario,
    scene: Scene,
    policy,
    *,
    progress: Callable[[float], None] | None = None,
    on_step=None,
    compiled: bool | None = None,
) -> PushResult:
    """Run ``policy`` (see the module docstring) on ``scene`` from ``scenario``'s initial state
    for ``scenario.duration_s`` and return the :class:`PushResult`.

    ``progress(t_sim)`` is called every 50 ms of simulated time; ``on_step(model, data)`` after
    every control period. Ctrl-C stops the run and returns what was simulated so far
    (``interrupted = True``); a :class:`~biped.errors.BipedError` from the policy ends it with
    ``controller_error`` set. The scenario's ``torque_limits`` are the policy's business
    (:func:`controller_policy` applies them).

    ``compiled``: run the policy (:func:`controller_policy` of W's controller, any distribution,
    or the joint PD; a stepping policy's double support, its swings a period at a time in Python:
    :mod:`biped.sim.fused_step`) in :mod:`biped.sim.fused`'s compiled loop, bit for bit the same
    result at a fraction of the Python loop's overhead. None (default): when it can (no
    ``on_step``); False: never; True: or raise ScenarioError.
    """
    m = scene.model
    d = mujoco.MjData(m)
    qpos0, qvel0 = initial_state(scene, scenario)
    d.qpos[:] = qpos0
    d.qvel[:] = qvel0
    mujoco.mj_forward(m, d)
    monitor = ContactMonitor.of_scene(scene, scenario.fall_height_m)
    n_ctrl, sub, period = scenario.control_steps, scenario.control_substeps, 1.0 / scenario.control_rate_hz
    n = n_ctrl + 1
    qpos, qvel, com, torques = np.zeros((n, m.nq)), np.zeros((n, m.nv)), np.zeros((n, 3)), np.zeros((n, 12))
    contacts = np.zeros((n, len(SOLE_GEOMS)), dtype=bool)
    bits = np.zeros(n, dtype=np.int64)  # the monitor's contact bits of each row
    feet_pos, feet_quat = np.zeros((n, 2, 3)), np.zeros((n, 2, 4))
    f0, f1 = (m.body(f).id for f in FOOT_BODIES)
    records: dict = {"qpos": qpos, "qvel": qvel, "com": com, "torques": torques, "bits": bits}
    records.update(feet_pos=feet_pos, feet_quat=feet_quat, feet_bodies=(f0, f1))
    measures = records["measures"] = np.full((n, NCOL), np.nan)  # biped.sim.loop_measures
    spec, f6 = row_spec(scene), np.zeros(6)
    feet_rows = 0  # rows whose foot poses were read in the loop
    iq, iv = _as_slice(scene.biped_qpos_index), _as_slice(scene.biped_qvel_index)
    act = scene.actuator_index
    bq = scene.block_qpos_index
    bv = scene.block_qvel_index[:3]
    cb = scene.central_body
    jq = scene.joint_qpos_index
    mass_block = m.body_mass[scene.block_body]
    p_before = mass_block * d.qvel[bv].copy()
    progress_every = max(1, round(0.05 * scenario.control_rate_hz))
    interrupted = False
    controller_error = None
    diverged = None
    rows = 0
    warnings = d.warning.number  # a live view: MuJoCo counts its warnings there
    dq, dv, xipos = d.qpos, d.qvel, d.xipos  # live views of MuJoCo's buffers, bound once
    xpos, xquat = d.xpos, d.xquat
    live = isinstance(iq, slice) and isinstance(iv, slice)  # then q and v are live views too
    q, v = dq[iq], dv[iv]
    try:  # compile/warm the controller outside the timer
        policy(0.0, d.qpos[iq], d.qvel[iv], (True, True))
    except BipedError:
        pass
    driver = perturbations.of(scenario).driver(scene, m, d, policy)  # the paradigm's run (or None)
    events = driver.rows[driver.rows <= n_ctrl] if driver is not None else np.zeros(0, dtype=np.int64)
    ev = 0  # the next of the rows where the driver acts (before the row's physics steps)
    inputs: list = []  # (row, ctrl, xfrc_applied) after each of its acts: PushResult.extra["inputs"]
    fused = None
    # None: W's ideal controller (no delay, lag or rate limit), or a replay of recorded torques
    neuro = None if isinstance(policy, RecordedTorques) else neuro_loop(scenario, scene)
    records["neuro"] = neuro
    if compiled is not False and on_step is None and live:
        fused = fused_mod.fused_rows(scene, scenario, policy, m, d, monitor, records)
    if compiled and fused is None:
        raise ScenarioError(fused_mod.refusal())
    sched = getattr(driver, "schedule", None) if fused is not None else None
    if sched is not None:  # the compiled loop applies the driver's data itself: fewer stops
        try:
            fused.set_schedule(sched)  # type: ignore[union-attr]
        except LookupError:  # not of the kernel's types: the driver's Python apply at each row
            sched = None
    if sched is not None:
        rows_sched = events[(events >= sched.first) & (events <= sched.last)]
        events = np.union1d(events[(events < sched.first) | (events > sched.last)], sched.python_rows)
        events = events[events <= n_ctrl]
        ctrl0, xfrc0 = d.ctrl.copy(), d.xfrc_applied.copy()
    synced = 0  # rows [0, synced) went through the monitor
    chunk = progress_every if progress is not None else 10 * progress_every  # rows a call
    stopper = EarlyStop(scenario, scene, records, policy, driver) if early_stop_applies(scenario) else None
    if stopper is not None:  # the rule is checked between compiled calls: one check interval a call
        chunk = stopper.every
    stopped = False
    t0 = time.perf_counter()
    held = HeldSignals().__enter__()  # Ctrl-C / SIGTERM between two steps, never inside numba's call
    try:
        k = 0
        while k < n:
            held.deliver()
            t = k * period
            while ev < len(events) and events[ev] <= k:  # the perturbation's inputs from this row on
                if events[ev] == k:
                    driver.apply(k, t, d)  # type: ignore[union-attr]
                    inputs.append((k, d.ctrl.copy(), d.xfrc_applied.copy()))
                ev += 1
            if fused is not None:  # rows up to the next progress report (or perturbation row) in one call
                stop = min(n, (k // chunk + 1) * chunk)
                if ev < len(events):
                    stop = min(stop, int(events[ev]))
                k, why = fused.run(k, stop)
                if why != fused_mod.PYTHON:
                    rows = min(k + 1, n) if why != fused_mod.DONE else k
                    feet_rows = k
                    if why == fused_mod.DONE:
                        if progress is not None and k % progress_every == 0:
                            progress(k * period)
                        if stopper is not None and k < n_ctrl and k % stopper.every == 0 and stopper.check(k):
                            stopped = True
                            break
                        continue
                    if why == fused_mod.DIVERGED:
                        diverged = fused_mod.diverged_message(k * period, period)
                    break
                fused_mod.sync_monitor(monitor, bits, com, period, synced, k, d)
                synced = k + 1  # row k runs in Python below (the policy's error or retry)
                t = k * period
                if not live:
                    q, v = dq[iq], dv[iv]
            elif not live:
                q, v = dq[iq], dv[iv]
            fell = monitor.update(t, d)
            feet = monitor.feet  # (left, right) on the floor
            try:
                if neuro is None:
                    tau = policy(t, q, v, feet)
                else:  # the state of feedback_delay_s ago, the torques filtered
                    neuro.command(k, t, q, v, monitor.bits, policy, torques[k])
                    tau = torques[k]
            except BipedError as exc:  # a singular state is a result, like a fall
                controller_error = f"t = {t:.3f} s: {exc}"
                tau = np.zeros(12)
            qpos[k] = dq  # quat, joint angles and block are read from it after the loop
            qvel[k] = dv
            com[k] = xipos[cb]
            torques[k] = tau
            bits[k] = monitor.bits
            rows = k + 1
            if fell or controller_error or k == n_ctrl:
                break
            d.ctrl[act] = tau
            mujoco.mj_step(m, d, 1)  # its forward pass computed the kinematics of row k's qpos
            feet_pos[k, 0] = xpos[f0]
            feet_pos[k, 1] = xpos[f1]
            feet_quat[k, 0] = xquat[f0]
            feet_quat[k, 1] = xquat[f1]
            record_python(m, d, spec, measures[k], f6)
            feet_rows = k + 1
            if sub > 1:
                mujoco.mj_step(m, d, sub - 1)  # = mj_step(m, d, sub): MuJoCo loops the same way
            if warnings[_BADQACC]:  # MuJoCo reset the state: the integration diverged
                feet_rows = k  # (a reset in the first step left the reset state's kinematics)
                diverged = fused_mod.diverged_message(t, period)
                break
            if on_step is not None:
                on_step(m, d)
            k += 1
            if progress is not None and k % progress_every == 0:
                progress(k * period)
            if stopper is not None and k < n_ctrl and k % stopper.every == 0 and stopper.check(k):
                stopped = True
                break
        held.deliver()
    except KeyboardInterrupt:
        interrupted = True
    finally:
        held.__exit__(None, None, None)
    if fused is not None and synced < rows:
        fused_mod.sync_monitor(monitor, bits, com, period, synced, rows, d)
    contacts[:] = (bits[:, None] >> np.arange(len(SOLE_GEOMS))) & 1
    if sched is not None:  # the inputs of the rows the compiled loop applied, as Python records them
        inputs = merged_inputs(
            inputs, sched, rows_sched[rows_sched < rows].tolist(), ctrl0, xfrc0, torques, act
        )
    wall = time.perf_counter() - t0
    if progress is not None:
        progress(max(rows - 1, 0) * period)
    sl = slice(0, rows)
    times = np.arange(n) * period
    quat = qpos[:, scene.biped_qpos_index[3:7]]
    angles = qpos[:, jq]
    block = qpos[:, bq[:3]]
    block_vel = qvel[:, bv]
    target_com = np.array(scenario.target_com_m)
    target_quat = tilt_quat(scenario.target_axis, scenario.target_tilt_deg)
    if driver is not None and driver.final_target is not None:  # a paradigm that moves the set point
        target_com, target_quat = (np.array(x, dtype=float) for x in driver.final_target)
    if rows:
        com_err = float(np.linalg.norm(com[rows - 1] - target_com))
        ori_err = orientation_error_deg(quat[rows - 1], target_quat)
    else:
        com_err = ori_err = float("nan")
    fell = monitor.fall_time_s is not None
    complete = (rows == n or stopped) and not interrupted and controller_error is None and diverged is None
    recovered = bool(
        complete
        and not fell
        and com_err < scenario.recovery_com_tol_m
        and ori_err < scenario.recovery_orientation_tol_deg
    )
    sim_time = max(rows - 1, 0) * period
    if feet_rows < rows:  # the last row (no step after it) and any row a stop left unread
        feet_pos[feet_rows:rows], feet_quat[feet_rows:rows] = _feet_poses(scene, qpos[feet_rows:rows])
    extra = perturbations.run_extra(scenario, scene, driver, d, inputs)
    redo = np.flatnonzero(np.isnan(measures[:feet_rows, 0])).tolist()  # the compiled loop left (fused)
    fill_rows(scene, qpos, qvel, torques, extra.get("inputs"), redo + list(range(feet_rows, rows)), measures)
    result = PushResult(
        scenario=scenario,
        joint_names=scene.joint_names,
        times=times[sl],
        qpos=qpos[sl],
        com=com[sl],
        quat=quat[sl],
        joint_angles=angles[sl],
        torques=torques[sl],
        block=block[sl],
        contacts=contacts[sl],
        events=tuple(monitor.events),
        block_contact_time_s=monitor.block_contact_time_s,
        block_momentum_before=p_before,
        block_momentum_after=mass_block * d.qvel[bv].copy(),
        fell=fell,
        fall_time_s=monitor.fall_time_s,
        fall_reason=monitor.fall_reason,
        interrupted=interrupted,
        target_com=target_com,
        target_quat=target_quat,
        final_com_error_m=com_err,
        final_orientation_error_deg=ori_err,
        recovered=recovered,
        wall_time_s=wall,
        realtime_factor=sim_time / wall if wall > 0 else float("inf"),
        controller_error=controller_error,
        diverged=diverged,
        stop_reason=AT_REST if stopped else None,
        qvel=qvel[sl],
        block_velocity=block_vel[sl],
        feet_pos=feet_pos[sl],
        feet_quat=feet_quat[sl],
        extra=extra,
        loop_measures=measures[sl],
    )
    if hasattr(policy, "steps"):  # a stepping policy: its steps and its own recovered rule
        from biped.sim.stepping import stepping_outcome

        result = stepping_outcome(result, policy, complete=complete)
    return result


def simulate(
    scenario: Scenario | None = None,
    *,
    progress: Callable[[float], None] | None = None,
    scene: Scene | None = None,
    on_step=None,
) -> PushResult:
    """Run ``scenario`` (W's defaults if None) closed loop with its controller
    (:func:`controller_policy`) and return its :class:`PushResult`; see :func:`run_closed_loop`.
    A first run compiles the numba kernels (~20 s once); a ``logging`` warning says so first."""
    scenario = Scenario() if scenario is None else scenario
    if not isinstance(scenario, Scenario):
        raise ScenarioError(
            f"simulate takes a biped.sim.Scenario (or None: W's); got {type(scenario).__name__}"
        )
    scene = scene or build_scene(scenario)
    # says so when cold
    announce_and_warm(kernels_for(scenario.controller, scenario.distribution, stepping=scenario.stepping))
    return run_closed_loop(
        scenario, scene, controller_policy(scenario, scene), progress=progress, on_step=on_step
    )


def replay_torques(result: PushResult, *, scene: Scene | None = None) -> PushResult:
    """Open-loop replay: the same scene and initial state driven by ``result.torques``
    (:class:`RecordedTorques`, no controller). Used by ``benchmarks/push.py`` to measure the
    controller's share of the cost."""
    scene = scene or build_scene(result.scenario)
    policy = RecordedTorques(result.torques, result.scenario.control_rate_hz)
    return run_closed_loop(result.scenario, scene, policy)
