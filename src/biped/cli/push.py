"""``biped push``: W's push-recovery experiment (section 4) on MuJoCo.

With no arguments it runs W's scenario and writes summary.json, trajectory.csv, figures/,
video.mp4 and replay.html into a new folder under ``runs/``. Thin: parsing here, the simulation
in :mod:`biped.sim`, the files in :mod:`biped.outputs.push`.
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

from biped.cli._common import (
    add_file_options,
    add_folder_options,
    command_seconds,
    frame_bar,
    keeps_mujoco_log,
    run_dir,
)


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "push",
        help="W's push-recovery experiment: a thrown block vs the workspace controller",
        description="Simulate W section 4 on MuJoCo: the biped rises to its set point while a "
        "1.8 kg block hits it. Every parameter defaults to W's; see docs/push.md.",
    )
    p.add_argument("--scenario", metavar="FILE.toml", help="scenario file (top-level key = value)")
    p.add_argument(
        "--model",
        metavar="FILE.xml",
        help="the biped: an MJCF file with W's structure (e.g. from `biped model`); W's "
        "initial state, set point and block height move onto it (docs/model.md); or a robot "
        "of the optional extra biped[robots]: g1, t1, berkeley_humanoid, apollo, or any other "
        "robot MJCF with two 6-hinge legs and a keyframe (docs/robots.md)",
    )
    p.add_argument("--duration", type=float, metavar="S", help="simulated time [s] (W: 3)")
    p.add_argument(
        "--block-position",
        type=float,
        nargs=3,
        metavar=("X", "Y", "Z"),
        help="block start [m] (W: 0.5 0.1 1.2)",
    )
    p.add_argument(
        "--block-velocity",
        type=float,
        nargs=3,
        metavar=("VX", "VY", "VZ"),
        help="block velocity [m/s] (W: -4.5 0 0.2)",
    )
    p.add_argument("--block-mass", type=float, metavar="KG", help="block mass [kg] (W: 1.8)")
    p.add_argument(
        "--controller",
        choices=("workspace", "joint-pd"),
        help="W's workspace controller (default) or the joint-PD baseline",
    )
    p.add_argument(
        "--physics",
        choices=("faithful", "fast"),
        help="physics preset: faithful (default: 0.5 ms step, 5 ms contacts) or fast "
        "(1 ms, 7.5 ms, sleep, one collision box a sole on W's biped; checked against faithful in "
        "docs/sweep.md)",
    )
    p.add_argument(
        "--distribution",
        choices=("statics", "printed", "qp"),
        help="the workspace controller's wrench distribution: W's min-norm split "
        "(statics, default), W's printed subscripts, or the contact-feasible QP",
    )
    p.add_argument(
        "--stepping",
        action="store_true",
        default=None,
        help="take capture-point steps when the feet cannot hold the push (not in W; "
        "docs/controller.md, 'Stepping')",
    )
    p.add_argument(
        "--perturbation",
        choices=("block", "force", "platform", "release", "pull"),
        help="the experiment: W's thrown block (default), a force pulse, a platform translation, a "
        "lean-and-release or a motor-driven waist pull; its keys with --set (docs/perturbations.md)",
    )
    p.add_argument("--timestep", type=float, metavar="S", help="physics step [s], <= 0.001")
    p.add_argument("--seed", type=int, help="seed of the initial-state noise (joint_noise_deg)")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="any scenario key, TOML value syntax (repeatable), e.g. "
        "--set 'kp_com=[60, 60, 200]' --set target_axis='\"-x\"'",
    )
    add_folder_options(p)
    add_file_options(p)
    p.add_argument("--svg", action="store_true", help="figures as SVG too (default: PNG only)")
    p.add_argument("--viewer", action="store_true", help="show the run live in MuJoCo's viewer")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def build_scenario(args):
    """The scenario from ``--scenario``, then ``--set``, then the named options (last wins), on
    ``--model`` (or the ``model`` key): keys not given take W's values moved onto that biped."""
    from biped.sim.scenario import Scenario, parse_assignment, toml_values

    values = toml_values(args.scenario) if args.scenario else {}
    values.update(parse_assignment(a) for a in args.set)
    named = {
        "duration_s": args.duration,
        "block_position_m": args.block_position,
        "block_velocity_m_s": args.block_velocity,
        "block_mass_kg": args.block_mass,
        "controller": args.controller,
        "physics": args.physics,
        "physics_timestep_s": args.timestep,
        "distribution": args.distribution,
        "seed": args.seed,
        "stepping": getattr(args, "stepping", None),
        "perturbation": getattr(args, "perturbation", None),
    }
    values.update({k: v for k, v in named.items() if v is not None})
    model = getattr(args, "model", None) or values.pop("model", None)
    values.pop("model", None)
    return Scenario.for_model(model, **values) if model else Scenario.from_dict(values)


def _out_dir(args) -> Path:
    return run_dir(args.out, "push", overwrite=args.overwrite)


def _viewer(enabled: bool):
    """A live viewer's (on_step, close) or (None, None) with a one-line reason."""
    if not enabled:
        return None, None
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")) and sys.platform != "darwin":
        print("--viewer: no display (DISPLAY / WAYLAND_DISPLAY unset); running without it")
        return None, None
    try:
        import mujoco.viewer
    except Exception as exc:  # noqa: BLE001
        print(f"--viewer: MuJoCo's viewer is unavailable ({exc}); running without it")
        return None, None
    state = {}

    def on_step(model, data):
        if "v" not in state:
            try:
                state["v"] = mujoco.viewer.launch_passive(model, data)
            except Exception as exc:  # noqa: BLE001
                print(f"--viewer: could not open ({exc}); running without it")
                state["v"] = None
        v = state["v"]
        if v is not None and v.is_running():
            v.sync()

    def close():
        if state.get("v") is not None:
            state["v"].close()

    return on_step, close


def _table(result, out: Path, paths: dict, times: dict | None = None) -> str:
    from biped.outputs.push import judged_set_point

    def f(x, fmt):
        return "n/a" if x is None or math.isnan(x) else format(x, fmt)

    s = result.scenario
    judged = judged_set_point(result)
    status = (
        "recovered"
        if judged["recovered"]
        else "fell"
        if result.fell
        else "diverged"
        if result.diverged
        else "interrupted"
        if result.interrupted
        else "controller error"
        if result.controller_error
        else "not recovered"
    )
    own = s.controller == "joint-pd"
    if own:  # the baseline holds its initial posture: judged against that, said on the line
        status += " (joint-pd judged against its own set point, the initial state it holds)"
    com_err, ori_err = judged["final_com_error_m"], judged["final_orientation_error_deg"]
    rows = [
        ("result", status),
        (
            "final COM error",
            (
                f"{f(None if com_err is None else com_err * 1e3, '.3f')} mm "
                f"(tolerance {s.recovery_com_tol_m * 1e3:g} mm)"
            ),
        ),
        (
            "final orientation error",
            (f"{f(ori_err, '.3f')} deg (tolerance {s.recovery_orientation_tol_deg:g} deg)"),
        ),
        ("block hits the body", f"{f(result.block_contact_time_s, '.3f')} s"),
        ("simulated", f"{result.times[-1] if len(result.times) else 0:.3f} of {s.duration_s:g} s"),
        (
            "simulation time",
            (
                f"{result.wall_time_s:.2f} s ({result.realtime_factor:.1f}x real time, "
                f"physics {s.physics} {s.physics_timestep_s * 1e3:g} ms, control "
                f"{s.control_rate_hz:g} Hz)"
            ),
        ),
    ]
    if own:
        rows.insert(
            3,
            (
                "W's set point",
                (
                    f"{'reached' if result.recovered else 'not reached'} (COM error "
                    f"{f(result.final_com_error_m * 1e3, '.1f')} mm; joint-pd does not try to reach it)"
                ),
            ),
        )
    if result.fell:
        rows.append(("fall", f"{result.fall_time_s:.3f} s: {result.fall_reason}"))
    if result.diverged:
        rows.append(("diverged", result.diverged))
    if result.controller_error:
        rows.append(("controller error", result.controller_error))
    hit = result.block_contact_time_s
    if hit is not None:  # W's timeline: heels rise after the hit, feet back down
        for foot in ("left", "right"):
            after = [e for e in result.events if e.foot == foot and e.time_s >= hit]
            rise = next((e for e in after if e.kind == "lift_off"), None)
            downs = [e for e in after if e.kind == "touch_down"]
            if rise is not None:
                rows.append((f"{foot} foot rises", f"{rise.time_s:.3f} s ({rise.part})"))
            if rise is not None and downs and downs[-1].time_s > rise.time_s:
                last = downs[-1]
                landed = [
                    st["touch_down_s"]
                    for st in result.extra.get("steps", ())
                    if st["foot"] == foot and st.get("touch_down_s") is not None
                ]
                why = ""
                if landed and last.time_s > max(landed) + 1e-9:  # after the step's own landing
                    why = f"; the sole settling after its step landed at {max(landed):.3f} s"
                rows.append((f"{foot} foot back down", f"{last.time_s:.3f} s ({last.part}{why})"))
    for k, st in enumerate(result.extra.get("steps", ()), 1):
        pos = st.get("position_m")
        where = (
            "no touchdown"
            if pos is None
            else f"lands {st['touch_down_s']:.3f} s at ({pos[0]:.3f}, {pos[1]:.3f}) m"
        )
        rows.append((f"step {k}", f"{st['foot']} foot, lifts {f(st.get('lift_off_s'), '.3f')} s, {where}"))
    resp = _response(out)
    if resp is not None:
        pert, r = resp
        if pert.get("paradigm") != "block":
            rows.insert(0, ("perturbation", f"{pert['paradigm']}, {pert['magnitude']:.4g} {pert['unit']} toward "
                                            f"{pert['direction_deg']:.0f} deg"))  # fmt: skip
        rows.insert(1, ("strategy", f"{r['strategy']} (torque reading: {r['strategy_torque']}); "
                                    f"margin of stability min {f(r['mos_min_m'], '.3f')} m"))  # fmt: skip
    rows.append(("outputs", str(out)))
    if times:
        rows.append(
            (
                "wall time",
                (
                    f"{times['total']:.1f} s, the whole command (simulation "
                    f"{result.wall_time_s:.1f} s, writing outputs "
                    f"{times['write']:.1f} s)"
                ),
            )
        )
    w = max(len(k) for k, _ in rows)
    return "\n".join(f"  {k:<{w}}  {v}" for k, v in rows)


def _response(out: Path):
    """(perturbation, response) entries of the run's summary.json, or None."""
    import json

    try:
        data = json.loads((out / "summary.json").read_text())
        return data["perturbation"], data["response"]
    except (OSError, ValueError, KeyError):
        return None


def _writer_progress(quiet: bool):
    """(on_stage, on_frame, on_figure, close) that tell what is being written after the
    simulation, with a counter for the figures and the video's frames (a bar on a terminal,
    lines otherwise); with ``quiet``, nothing."""
    if quiet:
        return None, lambda *_: None, lambda *_: None, lambda: None
    from biped._progress import progress_bar

    on_frame, close_frames = frame_bar()
    bars: dict = {}

    def on_figure(done, total):
        if bars.get("figures") is not None:
            bars["figures"].update(done - bars["figures"].n)

    def close():
        close_frames()
        if bars.get("figures") is not None:
            bars.pop("figures").close()

    def on_stage(name):
        close()
        if name == "figures":
            from biped.viz.push_figures import FIGURES

            bars["figures"] = progress_bar(total=len(FIGURES), desc="figures", unit="figure")
        what = {
            "trajectory.csv": "trajectory.csv, columns.json, summary.json (contact forces from MuJoCo)",
            "figures": "figures/ (W's Figs. 3-6)",
            "video.mp4": "video.mp4 (rendered meanwhile by a child process)",
            "replay.html": "replay.html",
        }.get(name, name)
        print(f"writing {what} ...", flush=True)
        if name == "figures":
            bars["figures"].update(0)  # a line "figures: 0/4" (a bar on a terminal)

    return on_stage, on_frame, on_figure, close


@keeps_mujoco_log
def run(args) -> int:
    import time

    from biped.models.robot import robot_for
    from biped.outputs.push import write_outputs
    from biped.sim.jit import kernels_for, warm_up
    from biped.sim.mjlog import count_warnings, route_to, summary
    from biped.sim.push import simulate
    from biped.sim.scene import build_scene

    robot = robot_for(getattr(args, "model", None))  # None: W's structure (checked below)
    if robot is not None:
        from biped.cli.push_robot import run_robot

        return run_robot(args, robot, _out_dir)
    t_start = time.perf_counter()
    scenario = build_scenario(args)  # validated before anything is simulated
    out = _out_dir(args)
    route_to(out / "mujoco.log")  # MuJoCo's warnings, if any, go to the run's folder
    warned_before = count_warnings(out / "mujoco.log")
    if not args.no_video:  # the renderer's process starts (imports) on the idle core meanwhile
        from biped.viz.video import prewarm

        prewarm()
    scene = build_scene(scenario)
    warm_up(
        kernels_for(scenario.controller, scenario.distribution, stepping=scenario.stepping),
        log=lambda line: print(line, file=sys.stderr),
        tick=sys.stderr,
    )
    on_step, close = _viewer(args.viewer)
    bar = None
    progress = None
    if not args.quiet:
        from biped._progress import progress_bar

        bar = progress_bar(
            total=round(scenario.duration_s, 6),
            unit="s sim",
            desc="biped push",
            line_format="{:.2f}",
            bar_format="{l_bar}{bar}| {n:.2f}/{total:.2f} s sim [{elapsed}<{remaining}]",
        )

        def progress(t):
            bar.update(max(0.0, t - bar.n))

    try:
        result = simulate(scenario, progress=progress, scene=scene, on_step=on_step)
    finally:
        if bar is not None:
            bar.close()
        if close is not None:
            close()
    t_write = time.perf_counter()
    on_stage, on_frame, on_figure, close_bar = _writer_progress(args.quiet)
    try:
        paths = write_outputs(
            result,
            out,
            figures=not args.no_figures,
            video=not args.no_video,
            replay=not args.no_replay,
            scene=scene,
            on_stage=on_stage,
            on_frame=on_frame,
            on_figure=on_figure,
            figure_formats=("png", "svg") if args.svg else ("png",),
        )
    finally:
        close_bar()
    t_end = time.perf_counter()
    print(_table(result, out, paths, {"total": command_seconds(t_start), "write": t_end - t_write}))
    said = summary(out / "mujoco.log", warned_before)
    if said:
        print(said, file=sys.stderr)
    if result.interrupted:
        return 130
    return 0
