"""``biped walk``: Bediz's kinematic figure stepping forward, up stairs and jumping (B IV-B, V-D).

Writes trajectory.csv, summary.json, figures/, replay.html and video.mp4 into ``--out``. Thin:
parsing here, the motion in :mod:`biped.kinematic`, the files in :mod:`biped.outputs.walk`; see
docs/walk.md.
"""

from __future__ import annotations

import math
from pathlib import Path

from biped.cli._common import add_file_options, add_folder_options, check_range, keeps_mujoco_log, run_dir
from biped.errors import ScenarioError

_DEFAULT_STEPS = {"forward": 6, "upstairs": 5}
#: Human walking speeds [m/s] (slow shuffle to the walk-run transition and a brisk walk beyond it);
#: outside them B's kinematic gait leaves the figure's physics (stance slip, friction > 5).
SPEED_RANGE = (0.1, 2.5)
MAX_STEPS = 100  # footfalls of one run
MAX_SAMPLES = 200_000  # duration x rate: bounds the run's time and memory
#: Longest motion [s] of one run: the video renders every frame of it (docs/walk.md: 79 s in all
#: for the 15.5 s demo on a 2-core machine, ~5 s per second of motion), so this keeps a run
#: within about half an hour.
MAX_MOTION_S = 300.0


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "walk",
        help="B's kinematic figure: step forward, climb stairs, jump (inverse kinematics)",
        description="Bediz's 15-part kinematic figure moved by leg inverse kinematics (B eq. "
        "4.12-4.19) with its stance feet held on the ground, and the joint torques and "
        "ground forces the motion would need on W's biped (MuJoCo mj_inverse). "
        "Every parameter defaults to B's; see docs/walk.md.",
    )
    p.add_argument(
        "--gait",
        choices=("forward", "upstairs", "jump", "demo"),
        default="demo",
        help="forward, upstairs, jump, or B's demo: 6 forward, 5 up, a jump, 4 forward (default demo)",
    )
    p.add_argument(
        "--steps",
        type=int,
        metavar="N",
        help=f"footfalls for forward (default 6) and upstairs (default 5), 1..{MAX_STEPS}; "
        "not used by jump and demo",
    )
    p.add_argument(
        "--speed",
        type=float,
        default=1.0,
        metavar="M/S",
        help=f"forward walking speed, {SPEED_RANGE[0]:g}..{SPEED_RANGE[1]:g} m/s; sets the "
        f"pace of every gait (default 1.0)",
    )
    p.add_argument(
        "--stair-rise",
        type=float,
        metavar="M",
        help="stair rise (default eq. 4.23 at 30 deg: (l1 + l2)(1 - cos 30 deg) = 0.111 m)",
    )
    p.add_argument(
        "--stair-run",
        type=float,
        metavar="M",
        help="stair run (default 0.540 m: B's -10..+30 deg leg angles)",
    )
    p.add_argument(
        "--no-somersault", action="store_true", help="jump without B's 360 deg turn along the semicircle"
    )
    p.add_argument(
        "--rate",
        type=float,
        default=200.0,
        metavar="HZ",
        help="samples per second of trajectory.csv and the dynamics (default 200)",
    )
    p.add_argument(
        "--model",
        metavar="FILE.xml",
        help="the biped (MJCF with W's structure, e.g. from `biped model`): the figure "
        "takes its legs and the inverse dynamics its masses (default: W's shipped biped)",
    )
    add_folder_options(p)
    p.add_argument("--no-dynamics", action="store_true", help="skip the inverse dynamics")
    add_file_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def build_plan(args):
    """The :class:`~biped.kinematic.gaits.Plan` the arguments ask for (validated)."""
    from dataclasses import replace

    from biped.kinematic import FigureDims, GaitParams, demo, jump, step_forward, step_upward

    if args.steps is not None and args.gait in ("jump", "demo"):
        raise ScenarioError(
            f"--steps applies to --gait forward and upstairs, not {args.gait} "
            f"(B's demo is 6 forward, 5 up, a jump, 4 forward)"
        )
    if (args.stair_rise is not None or args.stair_run is not None) and args.gait not in ("upstairs", "demo"):
        raise ScenarioError(f"--stair-rise / --stair-run apply to --gait upstairs and demo, not {args.gait}")
    if not (math.isfinite(args.rate) and 20.0 <= args.rate <= 2000.0):
        raise ScenarioError(f"--rate must be in [20, 2000] Hz, got {args.rate!r}")
    if not (math.isfinite(args.speed) and args.speed > 0):
        raise ScenarioError(f"--speed: speed must be a positive number of m/s, got {args.speed!r}")
    check_range("--speed", args.speed, *SPEED_RANGE, "m/s, human walking speeds")
    for opt, v in (("--stair-rise", args.stair_rise), ("--stair-run", args.stair_run)):
        if v is not None:
            check_range(opt, v, 0.0, 2.0, "m", lo_open=True)
    dims = (
        FigureDims.from_mjcf(args.model) if getattr(args, "model", None) else FigureDims.from_anthropometry()
    )
    params = GaitParams()
    if args.no_somersault:
        params = replace(params, somersault=False)
    steps = args.steps if args.steps is not None else _DEFAULT_STEPS.get(args.gait)
    if steps is not None and not 1 <= steps <= MAX_STEPS:
        raise ScenarioError(f"--steps must be in [1, {MAX_STEPS}] (bounds the run), got {steps}")
    try:
        if args.gait == "forward":
            assert steps is not None  # every gait but jump and demo has a default
            plan = step_forward(dims, steps, args.speed, params)
        elif args.gait == "upstairs":
            assert steps is not None
            plan = step_upward(dims, steps, args.speed, params, args.stair_rise, args.stair_run)
        elif args.gait == "jump":
            plan = jump(dims, args.speed, params)
        else:
            plan = demo(dims, args.speed, params, rise=args.stair_rise, run=args.stair_run)
    except ScenarioError as exc:  # the stairs' geometric limits: name the options
        text = str(exc)
        flag = (
            "--stair-rise / --stair-run"
            if text.startswith("stair rise") and " and run " in text
            else "--stair-rise"
            if text.startswith("stair rise")
            else "--stair-run"
            if text.startswith("stair run")
            else None
        )
        if flag is None:
            raise
        raise ScenarioError(f"{flag}: {text}") from None
    if plan.duration > MAX_MOTION_S:
        raise ScenarioError(
            f"the motion lasts {plan.duration:.1f} s, more than the limit of "
            f"{MAX_MOTION_S:g} s (bounds the run: every second is simulated, "
            f"drawn and rendered); use fewer --steps or a higher --speed"
        )
    samples = plan.duration * args.rate
    if samples > MAX_SAMPLES:
        raise ScenarioError(
            f"the motion lasts {plan.duration:.1f} s: at --rate {args.rate:g} Hz that "
            f"is {samples:,.0f} samples, more than the limit of {MAX_SAMPLES:,}; use "
            f"fewer --steps, a higher --speed or a lower --rate"
        )
    return plan


def _out_dir(args) -> Path:
    return run_dir(args.out, f"walk-{args.gait}", overwrite=args.overwrite)


@keeps_mujoco_log
def run(args) -> int:
    import time

    from biped._progress import progress_bar
    from biped.cli._common import command_seconds, frame_bar
    from biped.outputs.walk import walk_stages, write_walk
    from biped.sim.mjlog import route_to

    t_start = time.perf_counter()
    plan = build_plan(args)
    out = _out_dir(args)  # checked and created before any work
    route_to(out / "mujoco.log")  # MuJoCo's warnings, if any, go to the run's folder
    flags = {
        "dynamics": not args.no_dynamics,
        "figures": not args.no_figures,
        "replay": not args.no_replay,
        "video": not args.no_video,
    }
    bar = progress_bar(
        total=len(walk_stages(**flags)), desc=f"biped walk {args.gait}", disable=args.quiet, unit="stage"
    )

    started: list[str] = []

    # the video stage draws push's frame bar under the stage bar (gone when the stage ends)
    on_frame, close_frames = (lambda *_: None, lambda: None) if args.quiet else frame_bar(leave=False)

    def on_stage(stage):  # the bar counts finished stages and names the running one
        close_frames()
        if started:
            bar.update(1)
        started.append(stage)
        bar.set_postfix_str("inverse dynamics, inverse_dynamics.csv" if stage == "dynamics" else stage)

    try:
        walk = write_walk(
            plan,
            out,
            gait=args.gait,
            speed=args.speed,
            rate=args.rate,
            stair_rise=args.stair_rise,
            stair_run=args.stair_run,
            on_stage=on_stage,
            model=args.model,
            on_frame=on_frame,
            **flags,
        )
    finally:
        close_frames()
    bar.update(1)
    bar.close()
    metrics, idyn, summary, notes = walk.metrics, walk.idyn, walk.summary, walk.notes
    rows = [
        ("gait", args.gait),
        ("duration", f"{metrics.duration_s:.2f} s"),
        ("distance travelled", f"{metrics.distance_m:.3f} m"),
        ("height climbed", f"{metrics.height_climbed_m:.3f} m"),
        ("max penetration", f"{metrics.max_penetration_m * 1e3:.3g} mm"),
        ("max stance slip", f"{metrics.max_stance_slip_m * 1e3:.3g} mm"),
        ("min swing clearance", f"{metrics.min_swing_clearance_m * 100:.2f} cm"),
    ]
    if idyn is not None:
        s = summary["inverse_dynamics"]
        rows += [
            ("peak vertical GRF", f"{s['peak_grf_z_body_weights']:.2f} body weights"),
            ("stance CoP outside the sole", f"{100 * s['fraction_cop_outside_sole']:.0f} % of stance frames"),
            ("peak friction needed", f"{s['peak_friction_ratio']:.2f} (W: 0.3)"),
        ]
    for k, v in notes.items():
        rows.append((k, v))
    rows.append(("outputs", str(out)))
    rows.append(("wall time", f"{command_seconds(t_start):.1f} s, the whole command"))
    w = max(len(k) for k, _ in rows)
    print("\n".join(f"  {k:<{w}}  {v}" for k, v in rows))
    return 0
