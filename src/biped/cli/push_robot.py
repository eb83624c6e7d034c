"""``biped push --model <robot>``: W's push moved onto a robot's own MJCF (docs/robots.md). Thin:
the options checked, the run (:func:`biped.sim.robot.robot_push`) and its files
(:mod:`biped.outputs.robot`)."""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any


def run_robot(args, desc, out_dir: Callable[[Any], Path]) -> int:
    """``--model <robot>`` (a name or an MJCF path, ``desc`` its mapping): W's push moved onto a
    robot's own MJCF (docs/robots.md): its keyframe stance, the QP with its actuator limits, W's
    block scaled to it, from behind; ``out_dir(args)`` makes the run folder, after every check."""
    from biped.errors import ScenarioError
    from biped.models import total_mass_kg
    from biped.outputs.robot import write_robot_outputs, write_robot_replay, write_robot_video
    from biped.sim.jit import kernels_for, warm_up
    from biped.sim.robot import (
        Block,
        ForcePulse,
        PlatformMove,
        PullMove,
        block_for,
        robot_controller,
        robot_push,
    )
    from biped.sim.scenario import Scenario

    pert = getattr(args, "perturbation", None) or "block"
    values = _set_values(args)
    unsupported = {
        "--scenario": args.scenario,
        # the QP's friction pyramid (qp_floor_friction) on every robot run; release: its keys (below)
        "--set": None if pert == "release" or set(values) <= {"qp_floor_friction"} else args.set,
        "--controller": args.controller,
        "--physics": args.physics,
        "--seed": args.seed,
    }
    if pert not in ("block", "force", "platform", "pull", "release"):
        unsupported[f"--perturbation {pert}"] = True  # W's scene only (docs/robots.md)
    if pert == "platform" and getattr(args, "stepping", None):
        unsupported["--stepping with --perturbation platform"] = True
    given = [k for k, v in unsupported.items() if v]
    if given:
        raise ScenarioError(
            f"--model {args.model}: {', '.join(given)} not supported on robots yet; valid: --duration, "
            f"--distribution, --timestep, --block-position, --block-velocity, --block-mass, --stepping"
        )
    release = _release(args, values) if pert == "release" else None
    distribution = args.distribution or "qp"
    floor_friction = bool(Scenario().with_overrides(**_floor_key(values)).qp_floor_friction)
    seconds = args.duration if args.duration is not None else 3.0
    if not (0 < seconds <= 60):
        raise ScenarioError(f"--duration must be in (0, 60] s, got {seconds}")
    # the controller's and the QP's kernels, with a ticker (a cold cache: ~75 s, silent before)
    warm_up(
        kernels_for("workspace", distribution, robot=True),
        log=lambda s: print(s, file=sys.stderr),
        tick=sys.stderr,
    )
    ctrl = robot_controller(desc, distribution)  # checks the feet, soles and limits first
    if release is not None:  # a lean the feet cannot hold or the legs cannot reach: refused here
        from biped.sim.robot_release import check_release

        check_release(desc, release, ctrl)
    say = f"biped push: {pert} on {args.model} ({desc.mass:.1f} kg), {seconds:g} s, {distribution} ..."
    print(say, file=sys.stderr, flush=True)  # after every check: a refusal stays one line
    out = out_dir(args)  # after every check: a refused run makes no folder
    b = block_for(desc, total_mass_kg(), ctrl)
    block: Block | None = Block(
        tuple(args.block_position) if args.block_position else b.position_m,
        tuple(args.block_velocity) if args.block_velocity else b.velocity_m_s,
        args.block_mass if args.block_mass is not None else b.mass_kg,
    )
    force = platform = pull = None
    if release is not None:
        block = None
    if pert != "block" and (args.block_position or args.block_velocity or args.block_mass is not None):
        raise ScenarioError(f"--perturbation {pert} takes no --block-* options")
    if pert == "platform":  # W's backward translation (5 cm in 0.3 s from 0.1 s); robots face +x
        w = Scenario()
        dx, dy = w.platform_displacement_m
        platform = PlatformMove((-dx, dy), w.platform_start_s, w.platform_duration_s)
        block = None
    if pert == "pull":  # W's waist pull (10 cm at 0.4 m/s from 0.1 s) forward: the robots face +x
        w = Scenario()
        dx, dy = w.pull_displacement_m
        pull = PullMove((-dx, dy), w.pull_velocity_m_s, w.pull_start_s)
        block = None
    if pert == "force":  # W's pulse (60 N from behind for 0.15 s) scaled with the robot's mass
        w = Scenario()
        scale = desc.mass / total_mass_kg()
        force = ForcePulse(
            (-w.force_n[0] * scale, 0.0, 0.0), w.force_start_s, w.force_duration_s, w.force_shape
        )
        block = None
    stepping = None
    if getattr(args, "stepping", None):  # capture-point steps (docs/robots.md, "Stepping")
        from biped.control.stepping_config import SteppingConfig

        stepping = SteppingConfig.for_trigger(Scenario().step_trigger)
    replay, video = not args.no_replay, not args.no_video
    run = robot_push(
        desc,
        seconds,
        distribution=distribution,
        block=block,
        force=force,
        platform=platform,
        pull=pull,
        timestep_s=args.timestep,
        record_qpos=replay or video,
        stepping=stepping,
        release=release,
        qp_floor_friction=floor_friction,
    )
    print(
        f"biped push: simulated {run.t[-1] if len(run.t) else 0.0:.2f} s; writing {out} ...",
        file=sys.stderr,
        flush=True,
    )
    summary = write_robot_outputs(out, desc, run, block, distribution, force, platform, pull, release)
    if replay:
        write_robot_replay(out, desc, run, block, summary, platform)
    if video:
        say_what = "lean-and-release" if release is not None else None
        res = write_robot_video(out, desc, run, block, lambda s: print(s, flush=True), platform, say_what)
        if res.path is None:
            print(f"video.mp4 not written: {res.reason}")
    status = "recovered" if summary["recovered"] else "fell" if run.fell else "not recovered"
    what = (
        f"block {block.mass_kg:.3f} kg at {block.velocity_m_s[0]:g} m/s"
        if block is not None
        else f"force {force.force_n[0]:.1f} N for {force.duration_s:g} s"
        if force is not None
        else f"platform {platform.distance_m:g} m in {platform.duration_s:g} s"
        if platform is not None
        else f"waist pull {math.hypot(*pull.displacement_m):g} m at {pull.velocity_m_s:g} m/s"
        if pull is not None
        else f"lean {release.lean_deg:g} deg toward {release.direction_deg:g} deg released at {release.release_s:g} s"
        if release is not None
        else ""
    )
    if run.steps:
        closing = sum(1 for s in run.steps if s.get("closing"))
        what += f", {len(run.steps) - closing} step(s)" + (f" and {closing} closing" if closing else "")
    print(
        f"{args.model} ({desc.mass:.1f} kg): {status}; {what}, peak COM velocity "
        f"{summary['peak_com_velocity_x_m_s']:.3f} m/s, "
        f"final COM offset {summary['final_com_offset_m'] * 1e3:.2f} mm, peak torque "
        f"{summary['peak_torque_fraction_of_limit'] * 100:.0f}% of the limits -> {out}"
    )
    return 0


def _release(args, values: dict):
    """The lean of ``--perturbation release`` on a robot: W's keys (``--set release_lean_deg=...``,
    ``release_direction_deg``, ``release_time_s``; their defaults and checks; ``values`` the
    parsed ``--set``), the direction in the robot's own terms (0 forward: the robots face +x, so
    the world direction; 90 to its left, +y)."""
    from biped.errors import ScenarioError
    from biped.sim.robot_release import ReleaseLean
    from biped.sim.scenario import Scenario

    keys = ("release_lean_deg", "release_direction_deg", "release_time_s")
    values = {k: v for k, v in values.items() if k != "qp_floor_friction"}
    other = sorted(set(values) - set(keys))
    if other:
        raise ScenarioError(
            f"--model {args.model}: --set {', '.join(other)} not supported on robots; valid with "
            f"--perturbation release: {', '.join(keys)} (and qp_floor_friction)"
        )
    s = Scenario().with_overrides(perturbation="release", **values)
    return ReleaseLean(
        float(s.release_lean_deg), float(s.release_direction_deg) % 360.0, float(s.release_time_s)
    )


def _set_values(args) -> dict:
    """``--set KEY=VALUE`` as a dict (W's parsing)."""
    from biped.sim.scenario import parse_assignment

    return dict(parse_assignment(a) for a in args.set or ())


def _floor_key(values: dict) -> dict:
    """The ``qp_floor_friction`` of ``--set`` (W's key and check), if given."""
    return {k: v for k, v in values.items() if k == "qp_floor_friction"}
