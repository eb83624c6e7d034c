"""The files of a robot's push run (``biped push --model g1|t1|berkeley_humanoid|apollo``):
``summary.json`` (the robot, the block, the result), ``trajectory.csv`` (time, central-body
COM, whole-body COM, leg torques as commanded), ``replay.html`` (the 3D replay, the robot's
meshes drawn: :mod:`biped.viz.replay_mesh`) and ``video.mp4`` (MuJoCo's offscreen renderer, the
camera on the robot's floating body)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from biped.files import write_text
from biped.models.robot import RobotDescription
from biped.outputs._json import write_json
from biped.sim.robot import Block, ForcePulse, PlatformMove, PullMove, RobotRun, robot_plant
from biped.viz.replay import write_replay
from biped.viz.replay_mujoco import replay_from_mujoco
from biped.viz.video import VideoResult, render_video


def robot_summary(
    desc: RobotDescription,
    run: RobotRun,
    block: Block | None,
    distribution: str,
    force: ForcePulse | None = None,
    platform: PlatformMove | None = None,
    pull: PullMove | None = None,
    release=None,
) -> dict:
    """The run's numbers (SI units); ``recovered``: did not fall and its central-body COM ended
    within 1 cm of the set point horizontally."""
    vx = np.gradient(run.com[:, 0], run.t) if len(run.t) > 2 else np.zeros(1)
    return {
        "model": str(desc.path),
        "robot_mass_kg": desc.mass,
        "feet": list(desc.feet),
        "leg_joints": list(desc.leg_joints),
        "held_joints": list(desc.held_joints),
        "keyframe": desc.keyframe,
        "distribution": distribution,
        "torque_limits": "model (the joints' actuatorfrcrange)",
        "block": dataclasses.asdict(block) if block is not None else None,
        "force": dataclasses.asdict(force) if force is not None else None,
        "platform": dataclasses.asdict(platform) if platform is not None else None,
        "pull": dataclasses.asdict(pull) if pull is not None else None,
        **({"release": dataclasses.asdict(release)} if release is not None else {}),
        "pull_impulse_n_s": (
            run.force_impulse_n_s.tolist() if pull is not None and run.force_impulse_n_s is not None else None
        ),
        "force_impulse_n_s": (
            run.force_impulse_n_s.tolist()
            if force is not None and run.force_impulse_n_s is not None
            else None
        ),
        "block_momentum_per_kg_m_s": (
            block.mass_kg * float(np.linalg.norm(block.velocity_m_s)) / desc.mass if block else None
        ),
        "simulated_s": float(run.t[-1]) if len(run.t) else 0.0,
        "fell": run.fell,
        "fall_time_s": run.fall_time_s,
        "recovered": (not run.fell) and run.final_offset_m < 0.01,
        "final_com_offset_m": run.final_offset_m,
        "peak_com_velocity_x_m_s": float(np.max(vx)),
        "peak_torque_fraction_of_limit": run.max_torque_fraction,
        # with --stepping: the steps (foot, start, lift-off, touchdown, where; the set point moved)
        **({"steps": run.steps, "set_point_com_m": run.target_com.tolist()} if run.steps is not None else {}),
    }


def write_robot_outputs(
    out: Path,
    desc: RobotDescription,
    run: RobotRun,
    block,
    distribution: str,
    force: ForcePulse | None = None,
    platform: PlatformMove | None = None,
    pull: PullMove | None = None,
    release=None,
) -> dict:
    summary = robot_summary(desc, run, block, distribution, force, platform, pull, release)
    write_json(out / "summary.json", summary)
    head = "t_s,central_com_x_m,central_com_y_m,central_com_z_m,com_x_m,com_y_m,com_z_m," + ",".join(
        f"tau_{j}_n_m" for j in desc.leg_joints
    )
    rows = np.column_stack([run.t, run.central_com, run.com, run.torques])
    body = "\n".join(",".join(f"{x:.9g}" for x in r) for r in rows)
    write_text(out / "trajectory.csv", head + "\n" + body + "\n")
    return summary


def write_robot_replay(
    out: Path,
    desc: RobotDescription,
    run: RobotRun,
    block: Block | None,
    summary: dict,
    platform: PlatformMove | None = None,
) -> Path:
    """``replay.html``: the run (:attr:`RobotRun.qpos`, recorded with ``record_qpos``) on the plant
    it ran on, its meshes drawn, the camera on the robot's root body."""
    if run.qpos is None:
        raise ValueError("the run has no qpos record: run robot_push with record_qpos=True")
    m = robot_plant(desc, block, None, None if platform is None else platform.axis)
    info = {
        "robot": desc.path.stem,
        "mass [kg]": desc.mass,
        "recovered": summary["recovered"],
        "final COM offset [m]": summary["final_com_offset_m"],
    }
    markers = [{"time_s": run.fall_time_s, "label": "fell"}] if run.fall_time_s is not None else []
    replay = replay_from_mujoco(
        m, run.t, run.qpos, title=f"{desc.path.stem}: push", info=info, markers=markers
    )
    return write_replay(replay, out / "replay.html")


def write_robot_video(
    out: Path,
    desc: RobotDescription,
    run: RobotRun,
    block: Block | None,
    log,
    platform: PlatformMove | None = None,
    what: str | None = None,
) -> VideoResult:
    """``video.mp4`` of the run (:attr:`RobotRun.qpos`), the tracking camera on the floating body,
    ``log`` told the frames rendered every 4 % (a robot's meshes take ~0.4 s of CPU a frame: a
    line every ~1.5 s for a 3 s run's 90 frames)."""
    from biped.outputs.push import _frame_log

    if run.qpos is None:
        raise ValueError("the run has no qpos record: run robot_push with record_qpos=True")
    m = robot_plant(desc, block, None, None if platform is None else platform.axis)
    what = what or (
        "W's block" if block is not None else "platform" if platform is not None else "force pulse"
    )
    title = f"{desc.path.stem}: {what}"
    return render_video(
        m,
        run.t,
        run.qpos,
        out / "video.mp4",
        track_body=desc.root,
        title=title,
        progress=_frame_log(log, 0.04),
    )
