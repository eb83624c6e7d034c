"""``biped envelope``: per direction, the largest push survived, by bracket and bisection.

Thin: parsing here, the search in :mod:`biped.sim.sweep.envelope`, the table in
:mod:`biped.analysis.envelope_table`, the plot in :mod:`biped.viz.envelope`. See docs/envelope.md.
Exit status: 0 done; 1 incomplete (a trial was lost twice to a dead worker: rerun to finish);
2 bad input (one line on stderr, before any work); 130 Ctrl-C, 143 SIGTERM (finished trials kept).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from biped.cli._common import check_file_writable, keeps_mujoco_log, stopped_trials
from biped.cli._sweep_args import add_by_option, draw_envelope, warm_up_kernels
from biped.errors import ScenarioError

#: the plot's radii a paradigm's rows hold (docs/perturbations.md: the block's impulse is measured
#: from its momentum; a force's horizontal impulse is the pulse applied; platform and release: none)
_PLOT_BY = {
    "block": ("speed_m_s", "impulse_n_s", "horizontal_impulse_n_s"),
    "force": ("magnitude", "horizontal_impulse_n_s"),
    "platform": ("magnitude",),
    "release": ("magnitude",),
    "pull": ("magnitude",),
}


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "envelope",
        help="push-recovery envelope by bisection: each direction's limit in a few trials",
        description="Per direction, find the largest push survived (block speed, or the size of "
        "--perturbation in its own unit): bracket, bisection to --resolution, then check trials "
        "below the limit. Every trial is a row of a sweep Parquet file (resumable: run the same "
        "command again). See docs/envelope.md.",
    )
    p.add_argument(
        "--perturbation",
        choices=("block", "force", "platform", "release", "pull"),
        default="block",
        help="the experiment (as biped sweep): W's block (default; size: speed m/s), a force pulse "
        "(peak N), a platform move (m), a lean-and-release (deg) or a waist pull (the motor's travel, m); "
        "docs/perturbations.md",
    )
    p.add_argument(
        "--directions",
        default="16",
        metavar="N|LIST",
        help="N directions evenly spaced from 0 deg (default 16), or a list such as 0,90,180 [deg]",
    )
    p.add_argument(
        "--resolution",
        type=float,
        default=None,
        metavar="V",
        help="step of the search (block 0.25 m/s, force 10 N, platform 0.01 m, release 0.5 deg, pull 0.005 m)",
    )
    p.add_argument(
        "--min", type=float, default=None, metavar="V", help="smallest size tried (= --resolution)"
    )
    p.add_argument(
        "--max",
        type=float,
        default=None,
        metavar="V",
        help="largest size tried (block 24 m/s, force 1000 N, platform 1 m, release 14.5 deg, pull 0.5 m)",
    )
    p.add_argument("--start", type=float, default=None, metavar="V", help="first size tried (the middle)")
    p.add_argument(
        "--checks", type=int, default=3, metavar="N", help="check trials below each limit (3; 0: none)"
    )
    p.add_argument(
        "--criterion",
        choices=("survived", "recovered"),
        default="survived",
        help="what counts: survived (completed, no fall; default) or recovered (back at the set point)",
    )
    p.add_argument("--mass", metavar="KG", help="block mass [kg] (W: 1.8)")
    p.add_argument("--height", metavar="M", help="aim height [m] (W: 1.2)")
    p.add_argument("--gain-scale", metavar="S", dest="gain_scale", help="gain factor (kp * s, kv * sqrt(s))")
    p.add_argument("--task", choices=("hold", "wendlandt"), default=None, help="as biped sweep (hold)")
    p.add_argument("--controller", choices=("workspace", "joint-pd"), default=None)
    p.add_argument("--distribution", choices=("statics", "printed", "qp"), default=None)
    p.add_argument("--stepping", action="store_true", default=None, help="capture-point steps")
    p.add_argument("--torque-limits", choices=("none", "human", "model"), default=None)
    p.add_argument("--model", metavar="FILE.xml", help="the biped or a robot (as biped sweep)")
    p.add_argument("--duration", type=float, metavar="S", help="simulated time per trial [s] (3)")
    p.add_argument("--physics", choices=("faithful", "fast"), default=None, help="physics preset (fast)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="any scenario key")
    p.add_argument("--workers", type=int, metavar="N", help="local processes (default: all cores)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="a Dask cluster, e.g. tcp://10.0.0.5:8786")
    p.add_argument("--out", metavar="FILE.parquet", help="trials (default runs/envelope-<controller>...)")
    p.add_argument("--json", metavar="FILE.json", help="also write the envelope table as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="draw the polar envelope")
    add_by_option(p)
    p.add_argument("--overwrite", action="store_true", help="replace an --out that holds a different sweep")
    p.add_argument("--quiet", action="store_true", help="no progress line")
    p.add_argument("--dry-run", action="store_true", help="check everything, run nothing")
    p.set_defaults(func=run)


def directions(text: str) -> tuple[float, ...]:
    """``N`` (an integer: N directions 360/N apart from 0 deg) or a comma list of degrees."""
    text = str(text).strip()
    if text.isdigit():
        n = int(text)
        if not 1 <= n <= 3600:
            raise ScenarioError(f"--directions N must be from 1 to 3600; got {n}")
        import numpy as np  # the values of `biped sweep --direction 0:STOP:N`, so the trial keys match

        return tuple(float(x) for x in np.linspace(0.0, 360.0 - 360.0 / n, n))
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        values = []
    if not values or not all(math.isfinite(v) for v in values):
        raise ScenarioError(
            f"--directions must be a count such as 16 or a list of degrees such as 0,90,180; got {text!r}"
        )
    if len(set(values)) != len(values):
        raise ScenarioError(f"--directions lists a direction twice: {text!r}")
    return tuple(values)


def build(args):
    """(SweepSpec of the lattice x directions, out path)."""
    from biped.cli._sweep_args import _variant_suffix, build_spec, robot_suffix
    from biped.sim.sweep.envelope import lattice, paradigm_lattice

    dirs = directions(args.directions)
    lat = paradigm_lattice(args.perturbation)
    if args.resolution is None:
        args.resolution = lat.resolution
    if args.max is None:
        args.max = lat.max
    if math.isfinite(args.max) and args.max > lat.limit:
        raise ScenarioError(
            f"--max must be at most {lat.limit:g} {lat.unit} for perturbation {args.perturbation} "
            f"({lat.limit_why}); got {args.max:g}"
        )
    lo = args.min if args.min is not None else args.resolution
    sizes = lattice(lo, args.max, args.resolution)
    if args.checks < 0 or args.checks > 20:
        raise ScenarioError(f"--checks must be from 0 to 20; got {args.checks}")
    if args.start is not None and not (math.isfinite(args.start) and lo <= args.start <= args.max):
        raise ScenarioError(
            f"--start must be between --min ({lo:g}) and --max ({args.max:g}); got {args.start:g}"
        )
    ns = argparse.Namespace(**vars(args))
    ns.grid, ns.samples, ns.seed = None, None, None
    values = ",".join(repr(s) for s in sizes)
    ns.direction = ",".join(repr(d) for d in dirs)
    if args.perturbation == "block":
        ns.speed, ns.magnitude, ns.perturbation = values, None, None  # a block file's identity as before
    else:
        ns.speed, ns.magnitude = None, values
    spec = build_spec(ns)
    b = spec.base
    out = (
        Path(args.out)
        if args.out
        else Path("runs")
        / f"envelope-{b.controller}{_variant_suffix(b)}{robot_suffix(spec)}-{spec.torque_limits}.parquet"
    )
    return spec, out


@keeps_mujoco_log
def run(args) -> int:
    from biped.cli._sweep_args import _check_plot
    from biped.sim.early_stop import applies as early_stop_applies
    from biped.sim.sweep import check_run_args
    from biped.sim.sweep.envelope import paradigm_lattice, run_envelope

    _check_plot(args.plot, [])
    valid_by = _PLOT_BY[args.perturbation]
    if args.by is not None and args.by not in valid_by:
        raise ScenarioError(
            f"--by {args.by} has no values for perturbation {args.perturbation}; valid: {', '.join(valid_by)}"
        )
    if args.json and Path(args.json).suffix != ".json":
        raise ScenarioError(f"--json must name a .json file; got {args.json!r}")
    spec, out = build(args)
    check_run_args(out, workers=args.workers, scheduler=args.scheduler)
    check_file_writable(out)
    if args.json:
        check_file_writable(args.json, "--json")
    axes = dict(spec.axes)
    lat = paradigm_lattice(args.perturbation)
    size = axes[lat.axis]
    n_dir, n_size = len(axes["direction_deg"]), len(size)
    where = args.scheduler or f"{args.workers or 'all'} local worker(s)"
    stop = "on" if early_stop_applies(spec.base) else "off"
    physics = "the robot's own" if spec.robot else spec.base.physics
    what = (
        f"{args.perturbation}: {n_dir} directions x {n_size} sizes ({min(size):g}-{max(size):g} {lat.unit} "
        f"by {args.resolution:g}), controller {spec.base.controller}, distribution "
        f"{spec.base.distribution}, torque limits {spec.torque_limits}, physics {physics}, "
        f"early stop {stop}, on {where} -> {out}"
    )
    if args.dry_run:
        print(f"biped envelope (dry run): {what}")
        return 0
    from biped.sim.mjlog import route_to

    route_to(out.with_suffix(".mujoco.log"))
    print(f"biped envelope: {what}", file=sys.stderr)
    if args.scheduler is None:
        warm_up_kernels(spec)

    def progress(done: int, running: int) -> None:
        print(f"\rbiped envelope: {done} trials done, {running} running   ", end="", file=sys.stderr)

    try:
        result = run_envelope(
            spec,
            out,
            axis=lat.axis,
            checks=args.checks,
            start=args.start,
            criterion=args.criterion,
            workers=args.workers,
            scheduler=args.scheduler,
            progress=None if args.quiet else progress,
            overwrite=args.overwrite,
        )
    except KeyboardInterrupt as exc:
        return stopped_trials(exc, "biped envelope", out, "resume", newline=True)
    if not args.quiet:
        print(file=sys.stderr)
    from biped.analysis.envelope_table import envelope_table

    bound = None
    if spec.robot:  # the robot's own mass and Hof bound (docs/robots.md), not W's biped's
        from biped.analysis.robot import robot_hof_bound
        from biped.models.robot import robot_for

        robot = robot_for(spec.robot)
        assert robot is not None  # build_spec took it for a robot
        bound = robot_hof_bound(robot, [d.direction_deg for d in result.directions])
    table = envelope_table(result, bound=bound)
    print(table.format())
    print(
        f"{result.ran} trials run, {result.reused} reused from {out}, wall {result.wall_time_s:.1f} s "
        f"({result.backend})"
    )
    if args.json:
        data = {
            **table.to_dict(),
            "out": str(out),
            "trials_run": result.ran,
            "trials_reused": result.reused,
            "wall_time_s": result.wall_time_s,
            "checks": args.checks,
        }
        Path(args.json).write_text(json.dumps(data, indent=1) + "\n")
        print(f"envelope table: {args.json}")
    if args.plot:
        draw_envelope([out], args.by, args.perturbation, args.plot)
    if not result.complete:
        print(
            "biped envelope: some directions are unfinished (a trial was lost twice to a dead "
            "worker); run the same command again to finish them.",
            file=sys.stderr,
        )
        return 1
    return 0
