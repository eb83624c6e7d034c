"""W section 4 closed loop on MuJoCo: the biped rises to its set point while the block hits it.

>>> from biped.sim import Scenario, simulate, write_outputs
>>> result = simulate(Scenario())          # W's defaults, 3 s
>>> result.recovered, result.final_com_error_m
>>> write_outputs(result, "runs/mine")      # summary.json, trajectory.csv, figures, video, replay

Loop (one control period ``1 / control_rate_hz``): read the biped's qpos/qvel (its own layout,
picked out of the scene by name), compute the torques, hold them for ``control_substeps``
physics steps (zero-order hold), record. Row k of the trajectory is the state at ``t_k = k / rate``
and the torques computed from it (applied on [t_k, t_k+1)). A fall ends the run early; it is a
result (``fell = True``), not an exception.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from biped.errors import BipedError
from biped.sim.contact import SOLE_GEOMS, ContactMonitor
from biped.sim.scenario import Scenario
from biped.sim.scene import Scene, build_scene, initial_state, tilt_quat

_BADQACC = int(mujoco.mjtWarning.mjWARN_BADQACC)

__all__ = [
    "PushResult",
    "make_controller",
    "replay_torques",
    "simulate",
    "summary_dict",
    "write_outputs",
    "write_trajectory_csv",
]


@dataclass(frozen=True, eq=False)
class PushResult:
    """One push run, sampled at the control rate (n rows; world frame, SI units).

    times (n,) [s]; qpos (n, nq_scene) the scene's qpos (biped + block, for replays);
    com (n, 3) central-body COM [m]; quat (n, 4) its orientation (w, x, y, z);
    joint_angles (n, 12) [rad] and torques (n, 12) [N m] in ``joint_names`` order (row k's torques
    are those held on [t_k, t_k+1)); block (n, 3) block centre [m]; contacts (n, 4) bool sole-part
    contacts in :data:`biped.sim.contact.SOLE_GEOMS` order.
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
    extra: dict = field(default_factory=dict)

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
    return math.degrees(2.0 * math.acos(min(1.0, c)))


def workspace_policy(scenario: Scenario, tree=None):
    """W's controller for ``scenario``'s set point, gains and support, and its policy
    ``raw(qpos_biped, qvel_biped, feet) -> torques`` in ``ctrl.joint_names`` order (a view into the
    controller's buffer). The feet flags are used when ``scenario.support`` is "sensed"; with
    "fixed" both feet are taken as fixed (W). ``tree`` defaults to ``scenario.model``'s."""
    from biped.control import Gains, Target, WorkspaceController
    from biped.model import TreeModel
    from biped.models.subject import resolve

    target = Target.wendlandt(com=scenario.target_com_m, tilt_deg=scenario.target_tilt_deg,
                              axis=scenario.target_axis)
    gains = Gains(kp_com=scenario.kp_com, kv_com=scenario.kv_com, kp_rot=scenario.kp_rot,
                  kv_rot=scenario.kv_rot)
    tree = tree or TreeModel.from_mjcf(resolve(scenario.model))
    ctrl = WorkspaceController(tree, target=target, gains=gains)
    if scenario.support == "sensed":
        return ctrl, lambda q, v, feet: ctrl.torques(q, v, feet_in_contact=feet)
    return ctrl, lambda q, v, feet: ctrl.torques(q, v)


def make_controller(scenario: Scenario, scene: Scene) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """``policy(qpos_biped (19,), qvel_biped (18,), feet (left, right) on the floor) -> torques
    (12,)`` in ``scene.joint_names`` order, for ``scenario.controller`` with the scenario's set
    point and gains (see :func:`workspace_policy` for the feet flags)."""
    if scenario.controller == "workspace":
        ctrl, raw = workspace_policy(scenario)
    else:  # the project's joint-space PD baseline (the same as ``biped sweep``'s)
        from biped.control.joint_pd import JointPDController
        from biped.models.subject import resolve

        ctrl = JointPDController.from_mjcf(resolve(scenario.model),
                                           q_ref_deg=scenario.initial_joint_angles_deg,
                                           control_period_s=1.0 / scenario.control_rate_hz)
        raw = lambda q, v, feet: ctrl.compute(q, v).torques
    names = tuple(ctrl.joint_names)
    if sorted(names) != sorted(scene.joint_names):
        raise BipedError(f"controller joints {names} differ from the scene's {scene.joint_names}")
    order = np.array([names.index(n) for n in scene.joint_names])
    return lambda q, v, feet: raw(q, v, feet)[order]


def _limits(scenario: Scenario) -> np.ndarray | None:
    tl = scenario.torque_limits
    if tl == "none":
        return None
    return np.broadcast_to(np.asarray(tl, dtype=float), (12,)).copy()


def _run(scenario: Scenario, scene: Scene, policy, *, progress=None, on_step=None) -> PushResult:
    """The loop shared by :func:`simulate` (policy = a controller) and :func:`replay_torques`
    (policy = a row index into recorded torques)."""
    m = scene.model
    d = mujoco.MjData(m)
    qpos0, qvel0 = initial_state(scene, scenario)
    d.qpos[:] = qpos0
    d.qvel[:] = qvel0
    mujoco.mj_forward(m, d)
    monitor = ContactMonitor(m, floor_geom=scene.floor_geom, block_geom=scene.block_geom,
                             sole_geoms=scene.sole_geoms, biped_geoms=scene.biped_geoms,
                             central_body=scene.central_body, fall_height_m=scenario.fall_height_m)
    n_ctrl = scenario.control_steps
    sub = scenario.control_substeps
    period = 1.0 / scenario.control_rate_hz
    n = n_ctrl + 1
    times = np.zeros(n)
    qpos = np.zeros((n, m.nq))
    com = np.zeros((n, 3))
    quat = np.zeros((n, 4))
    angles = np.zeros((n, 12))
    torques = np.zeros((n, 12))
    block = np.zeros((n, 3))
    contacts = np.zeros((n, len(SOLE_GEOMS)), dtype=bool)
    limits = _limits(scenario)
    iq, iv = scene.biped_qpos_index, scene.biped_qvel_index
    act = scene.actuator_index
    bq = scene.block_qpos_index
    cb = scene.central_body
    jq = scene.joint_qpos_index
    mass_block = m.body_mass[scene.block_body]
    p_before = mass_block * d.qvel[scene.block_qvel_index[:3]].copy()
    progress_every = max(1, round(0.05 * scenario.control_rate_hz))
    interrupted = False
    controller_error = None
    diverged = None
    rows = 0
    if not isinstance(policy, np.ndarray):  # compile/warm the controller outside the timer
        try:
            policy(d.qpos[iq], d.qvel[iv], (True, True))
        except BipedError:
            pass
    t0 = time.perf_counter()
    try:
        for k in range(n):
            t = k * period
            q = d.qpos[iq]
            v = d.qvel[iv]
            fell = monitor.update(t, d)
            flags = monitor.flags  # (left heel, left toe, right heel, right toe) on the floor
            feet = (bool(flags[0] or flags[1]), bool(flags[2] or flags[3]))
            try:
                tau = policy(q, v, feet) if not isinstance(policy, np.ndarray) else policy[k]
            except BipedError as exc:  # a singular state is a result, like a fall
                controller_error = f"t = {t:.3f} s: {exc}"
                tau = np.zeros(12)
            if limits is not None:
                tau = np.clip(tau, -limits, limits)
            times[k] = t
            qpos[k] = d.qpos
            com[k] = d.xipos[cb]
            quat[k] = d.qpos[iq[3:7]]
            angles[k] = d.qpos[jq]
            torques[k] = tau
            block[k] = d.qpos[bq[:3]]
            contacts[k] = flags
            rows = k + 1
            if fell or controller_error or k == n_ctrl:
                break
            d.ctrl[act] = tau
            mujoco.mj_step(m, d, sub)
            if d.warning[_BADQACC].number:  # MuJoCo reset the state: the integration diverged
                diverged = (f"MuJoCo's integration diverged (non-finite accelerations) between "
                            f"t = {t:.4f} s and {t + period:.4f} s")
                break
            if on_step is not None:
                on_step(m, d)
            if progress is not None and (k + 1) % progress_every == 0:
                progress((k + 1) * period)
    except KeyboardInterrupt:
        interrupted = True
    wall = time.perf_counter() - t0
    if progress is not None:
        progress(max(rows - 1, 0) * period)
    sl = slice(0, rows)
    target_com = np.array(scenario.target_com_m)
    target_quat = tilt_quat(scenario.target_axis, scenario.target_tilt_deg)
    if rows:
        com_err = float(np.linalg.norm(com[rows - 1] - target_com))
        ori_err = orientation_error_deg(quat[rows - 1], target_quat)
    else:
        com_err = ori_err = float("nan")
    fell = monitor.fall_time_s is not None
    complete = rows == n and not interrupted and controller_error is None and diverged is None
    recovered = bool(complete and not fell and com_err < scenario.recovery_com_tol_m
                     and ori_err < scenario.recovery_orientation_tol_deg)
    sim_time = max(rows - 1, 0) * period
    return PushResult(
        scenario=scenario, joint_names=scene.joint_names, times=times[sl], qpos=qpos[sl],
        com=com[sl], quat=quat[sl], joint_angles=angles[sl], torques=torques[sl],
        block=block[sl], contacts=contacts[sl], events=tuple(monitor.events),
        block_contact_time_s=monitor.block_contact_time_s,
        block_momentum_before=p_before,
        block_momentum_after=mass_block * d.qvel[scene.block_qvel_index[:3]].copy(),
        fell=fell, fall_time_s=monitor.fall_time_s, fall_reason=monitor.fall_reason,
        interrupted=interrupted, target_com=target_com, target_quat=target_quat,
        final_com_error_m=com_err, final_orientation_error_deg=ori_err, recovered=recovered,
        wall_time_s=wall, realtime_factor=sim_time / wall if wall > 0 else float("inf"),
        controller_error=controller_error, diverged=diverged,
    )


def simulate(scenario: Scenario | None = None, *, progress: Callable[[float], None] | None = None,
             scene: Scene | None = None, on_step=None) -> PushResult:
    """Run ``scenario`` (W's defaults if None) closed loop and return its :class:`PushResult`.

    ``progress(t_sim)`` is called every 50 ms of simulated time; ``on_step(model, data)`` after
    every control period (e.g. a live viewer's sync). Ctrl-C stops the run and returns what was
    simulated so far (``interrupted = True``).
    """
    scenario = scenario or Scenario()
    scene = scene or build_scene(scenario)
    policy = make_controller(scenario, scene)
    return _run(scenario, scene, policy, progress=progress, on_step=on_step)


def replay_torques(result: PushResult, *, scene: Scene | None = None) -> PushResult:
    """Open-loop replay: the same scene and initial state driven by ``result.torques``
    (no controller). Used by ``benchmarks/push.py`` to measure the controller's share of the cost."""
    scene = scene or build_scene(result.scenario)
    torques = np.ascontiguousarray(result.torques)
    if len(torques) < result.scenario.control_steps + 1:
        torques = np.vstack([torques, np.zeros((result.scenario.control_steps + 1 - len(torques), 12))])
    return _run(result.scenario, scene, torques)


# ---------------------------------------------------------------------------------------------
# outputs


def _fmt(x: float) -> str:
    return repr(float(x))


def trajectory_columns(joint_names) -> list[str]:
    cols = ["time", "com_x", "com_y", "com_z", "quat_w", "quat_x", "quat_y", "quat_z"]
    cols += [f"q_{n}" for n in joint_names] + [f"tau_{n}" for n in joint_names]
    cols += ["block_x", "block_y", "block_z", "left_contact", "right_contact"]
    cols += [f"{foot}_{part}_contact" for foot, part in SOLE_GEOMS]
    return cols


def write_trajectory_csv(result: PushResult, path: str | Path) -> Path:
    """``trajectory.csv``: one row per control period (columns: :func:`trajectory_columns`;
    angles [rad], torques [N m], positions [m]). Floats are written with ``repr`` (shortest
    round-trip form), so equal runs give byte-identical files."""
    path = Path(path)
    lines = [",".join(trajectory_columns(result.joint_names))]
    lc, rc = result.left_contact, result.right_contact
    for k in range(len(result.times)):
        vals = [_fmt(result.times[k]), *map(_fmt, result.com[k]), *map(_fmt, result.quat[k]),
                *map(_fmt, result.joint_angles[k]), *map(_fmt, result.torques[k]),
                *map(_fmt, result.block[k]), str(int(lc[k])), str(int(rc[k])),
                *(str(int(c)) for c in result.contacts[k])]
        lines.append(",".join(vals))
    tmp = path.with_suffix(".csv.part")
    tmp.write_text("\n".join(lines) + "\n")
    tmp.replace(path)
    return path


def _num(x):
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def summary_dict(result: PushResult) -> dict:
    """The content of ``summary.json``."""
    s = result.scenario
    return {
        "recovered": result.recovered,
        "fell": result.fell,
        "fall_time_s": _num(result.fall_time_s),
        "fall_reason": result.fall_reason,
        "interrupted": result.interrupted,
        "controller_error": result.controller_error,
        "diverged": result.diverged,
        "simulated_time_s": _num(result.times[-1]) if len(result.times) else 0.0,
        "final_com_error_m": _num(result.final_com_error_m),
        "final_orientation_error_deg": _num(result.final_orientation_error_deg),
        "final_com_m": result.com[-1].tolist() if len(result.com) else None,
        "final_quat": result.quat[-1].tolist() if len(result.quat) else None,
        "target_com_m": result.target_com.tolist(),
        "target_quat": result.target_quat.tolist(),
        "block_contact_time_s": _num(result.block_contact_time_s),
        "block_momentum_before_kg_m_s": result.block_momentum_before.tolist(),
        "block_momentum_after_kg_m_s": result.block_momentum_after.tolist(),
        "events": [e.to_dict() for e in result.events],
        "wall_time_s": result.wall_time_s,
        "realtime_factor": _num(result.realtime_factor),
        "control_rate_hz": s.control_rate_hz,
        "physics_timestep_s": s.physics_timestep_s,
        "scenario": s.to_dict(),
    }


def write_summary(result: PushResult, path: str | Path, extra: dict | None = None) -> Path:
    path = Path(path)
    data = summary_dict(result)
    if extra:
        data.update(extra)
    tmp = path.with_suffix(".json.part")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    tmp.replace(path)
    return path


def _markers(result: PushResult) -> list[dict]:
    out = []
    if result.block_contact_time_s is not None:
        out.append({"time_s": result.block_contact_time_s, "label": "block hits the body"})
    for e in result.events:
        out.append({"time_s": e.time_s, "label": f"{e.foot} {e.part} {e.kind.replace('_', ' ')}"})
    if result.fall_time_s is not None:
        out.append({"time_s": result.fall_time_s, "label": f"fall: {result.fall_reason}"})
    return out


def write_outputs(result: PushResult, out_dir: str | Path, *, figures: bool = True,
                  video: bool = True, replay: bool = True, scene: Scene | None = None,
                  log: Callable[[str], None] = print) -> dict:
    """Write every output of a run into ``out_dir`` (created if needed); returns ``{name: path}``.

    Order: ``trajectory.csv`` and ``summary.json`` first (atomic writes), then ``scenario.toml``,
    ``figures/``, ``video.mp4``, ``replay.html``. A failing optional output (no OpenGL, viz module
    missing...) is reported through ``log`` in one line and never removes what was written.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = {"trajectory": write_trajectory_csv(result, out / "trajectory.csv"),
               "summary": write_summary(result, out / "summary.json")}
    (out / "scenario.toml").write_text(result.scenario.to_toml())
    written["scenario"] = out / "scenario.toml"
    if figures:
        try:
            from biped.viz.push_figures import plot_push

            written["figures"] = plot_push(result, out / "figures")
        except Exception as exc:  # noqa: BLE001 - an optional output must not lose the run
            log(f"figures: not written ({type(exc).__name__}: {exc})")
    if video or replay:
        scene = scene or build_scene(result.scenario)
    if video:
        try:
            from biped.viz.video import render_video
        except ImportError as exc:
            log(f"video: skipped, the video module is not available ({exc})")
        else:
            try:
                res = render_video(scene.model, result.times, result.qpos, out / "video.mp4",
                                   fps=30, track_body="central_body", distance=3.0)
                if getattr(res, "path", None):
                    written["video"] = Path(res.path)
                else:
                    log(f"video: not written ({getattr(res, 'reason', 'no reason given')})")
            except Exception as exc:  # noqa: BLE001
                log(f"video: not written ({type(exc).__name__}: {exc})")
    if replay:
        try:
            from biped.viz.replay import replay_from_mujoco, write_replay
        except ImportError as exc:
            log(f"replay: skipped, the replay module is not available ({exc})")
        else:
            try:
                info = {"recovered": result.recovered, "fell": result.fell,
                        "final COM error [m]": round(result.final_com_error_m, 4),
                        "final orientation error [deg]": round(result.final_orientation_error_deg, 3)}
                rp = replay_from_mujoco(scene.model, result.times, result.qpos,
                                        title="W section 4: push recovery", info=info,
                                        markers=_markers(result), follow="trunk")
                written["replay"] = write_replay(rp, out / "replay.html") or out / "replay.html"
            except Exception as exc:  # noqa: BLE001
                log(f"replay: not written ({type(exc).__name__}: {exc})")
    return written
