"""``biped sweep``: push-recovery envelopes, many push trials on every local core or a Dask cluster.

Thin: parsing here, work in :mod:`biped.sim.sweep`, plots in :mod:`biped.viz.envelope`.
See docs/sweep.md. Exit status: 0 done; 1 incomplete (a worker died: rerun to finish);
2 bad input (one line on stderr, before any work); 130 Ctrl-C, 143 SIGTERM (finished trials kept).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

from biped.cli._common import check_file_writable, keeps_mujoco_log, stopped_trials
from biped.cli._sweep_args import (  # build_spec: also this module's, as before
    _AXIS_OPTIONS,
    _check_plot,
    _variant_suffix,
    add_by_option,
    build_spec,
    draw_envelope,
    robot_suffix,
    warm_up_kernels,
)
from biped.errors import ScenarioError


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "sweep",
        help="push-recovery envelopes: a grid of pushes on all cores or a Dask cluster",
        description="Run a grid (or random sample) of push trials and write one Parquet file, a row "
        "per trial. Axis values: a number, a list 1,2,4 or START:STOP:NUM (ends "
        "included). Interrupted? Run the same command again: finished trials are "
        "kept and skipped. See docs/sweep.md.",
    )
    p.add_argument(
        "--grid",
        metavar="FILE.toml",
        help="sweep file ([grid] axes, [scenario] keys, samples, seed, torque_limits); "
        "command-line options override it",
    )
    for opt, _, what in _AXIS_OPTIONS:
        p.add_argument(f"--{opt.replace('_', '-')}", metavar="VALUES", dest=opt, help=what)
    p.add_argument(
        "--perturbation",
        choices=("block", "force", "platform", "release", "pull"),
        help="the experiment swept: W's thrown block (default; --speed), a force pulse, a platform "
        "translation, a lean-and-release or a waist pull (--magnitude in its unit; --direction: the way it pushes the "
        "body, from +x toward +y); docs/perturbations.md",
    )
    p.add_argument(
        "--samples",
        type=int,
        metavar="N",
        help="N random trials, uniform between each axis's smallest and largest value",
    )
    p.add_argument("--seed", type=int, metavar="S", help="seed of --samples (default 0)")
    p.add_argument(
        "--task",
        choices=("hold", "wendlandt"),
        default=None,
        help="hold: keep the initial posture (set point = initial state; default, the "
        "same task for both controllers); wendlandt: rise to W's set point",
    )
    p.add_argument(
        "--controller",
        choices=("workspace", "joint-pd"),
        default=None,
        help="W's workspace controller (default) or the joint-space PD baseline",
    )
    p.add_argument(
        "--distribution",
        choices=("statics", "printed", "qp"),
        default=None,
        help="the workspace controller's wrench distribution: W's min-norm split "
        "(statics, default) or the contact-feasible QP (docs/controller.md)",
    )
    p.add_argument(
        "--stepping",
        action="store_true",
        default=None,
        help="capture-point steps when the feet cannot hold (not in W; docs/controller.md)",
    )
    p.add_argument(
        "--torque-limits",
        choices=("none", "human", "model"),
        default=None,
        help="joint torque limits: none (W) or human-like (docs/sweep.md); on a robot model "
        "(default: its joints' actuatorfrcrange) or none",
    )
    p.add_argument(
        "--model",
        metavar="FILE.xml",
        help="the biped: an MJCF file with W's structure (e.g. from `biped model`); W's "
        "initial state, set point and aim height move onto it (docs/model.md); or a robot: g1, "
        "t1, berkeley_humanoid, apollo or a robot MJCF (docs/robots.md)",
    )
    p.add_argument("--duration", type=float, metavar="S", help="simulated time per trial [s] (3)")
    p.add_argument(
        "--physics",
        choices=("faithful", "fast"),
        default=None,
        help="physics preset (default fast: 1 ms step, 7.5 ms contacts, sleep, one collision "
        "box a sole on W's biped without stepping; its "
        "envelopes are within one grid step of faithful's, docs/sweep.md), unless "
        "the grid file or --set gives physics or the step/contact keys",
    )
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="any scenario key (TOML value syntax), repeatable",
    )
    p.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="local processes (default: all cores; at most twice the cores)",
    )
    p.add_argument(
        "--scheduler", metavar="ADDRESS", help="run on a Dask cluster instead, e.g. tcp://10.0.0.5:8786"
    )
    p.add_argument("--batch", type=int, default=1, metavar="N", help="trials per task (1)")
    p.add_argument(
        "--out",
        metavar="FILE.parquet",
        help="results (default runs/sweep-<controller>[-<distribution>][-stepping]-<limits>.parquet)",
    )
    p.add_argument(
        "--refine",
        type=float,
        metavar="V",
        help="after the grid, bisect each direction's speed (another paradigm: its --magnitude) between "
        "its last survivor and first failure to V m/s (the paradigm's unit) (biped envelope's search, "
        "reusing the grid's trials; docs/envelope.md)",
    )
    p.add_argument("--retry-failed", action="store_true", help="rerun trials that raised")
    p.add_argument(
        "--overwrite", action="store_true", help="replace an --out file that holds a different sweep"
    )
    p.add_argument(
        "--plot",
        nargs="?",
        const="",
        metavar="FILE.png",
        help="draw the polar envelope when done; without FILE, beside the results (--out's name "
        "with .png, in runs/ by default)",
    )
    p.add_argument(
        "--compare",
        metavar="OTHER.parquet",
        action="append",
        default=[],
        help="with --plot: draw these finished sweeps side by side (repeatable)",
    )
    add_by_option(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument(
        "--dry-run", action="store_true", help="check everything and say what would run, run nothing"
    )
    p.set_defaults(func=run)


def _say_warnings(table, mjlog: Path, before: int) -> None:
    """After the bar: MuJoCo's warnings of this sweep, counted once, and how many of its trials
    diverged (the warnings themselves are in ``mjlog``)."""
    from biped.sim.mjlog import count_warnings

    n = count_warnings(mjlog) - before
    if n <= 0:
        return
    div = sum(1 for d in table.column("diverged").to_pylist() if d) if "diverged" in table.column_names else 0
    trials = f"{div} trial{'s' if div != 1 else ''} diverged; " if div else ""
    print(f"MuJoCo warned {n} time{'s' if n != 1 else ''} ({trials}see {mjlog})", file=sys.stderr)


@keeps_mujoco_log
def run(args) -> int:
    from biped.files import check_no_link
    from biped.sim.sweep import check_run_args, check_setups, connect_scheduler, parts_dir
    from biped.sim.sweep.store import check_parts_dir, check_same_sweep, lock_path

    # every input is checked here, before any lock, manifest, trial or file exists; --dry-run
    # runs exactly these checks
    _check_plot(args.plot, args.compare)
    spec = build_spec(args)
    check_setups(spec)  # every axis value makes a valid push (--mass 1000 is refused here)
    out = (
        Path(args.out)
        if args.out
        else Path("runs")
        / (
            f"sweep-{spec.base.controller}{_variant_suffix(spec.base)}{robot_suffix(spec)}-"
            f"{spec.torque_limits}.parquet"
        )
    )
    if args.refine is not None:
        refine_spec(spec, args.refine)  # its errors before any work
    n = spec.n_trials
    where = args.scheduler or f"{args.workers or 'all'} local worker(s)"
    check_run_args(out, workers=args.workers, batch=args.batch)
    check_file_writable(out)  # a probe file, not os.access (which says yes to root everywhere)
    check_no_link(lock_path(out), "the lock file")
    check_no_link(out.with_suffix(".mujoco.log"), "the MuJoCo log")
    check_parts_dir(parts_dir(out))
    if not args.overwrite:
        check_same_sweep(spec, out)  # again under the lock: another sweep may finish meanwhile
    client = connect_scheduler(args.scheduler) if args.scheduler else None
    try:
        if args.dry_run:
            print(
                f"biped sweep (dry run): {n} trials of {spec.base.duration_s:g} s, controller "
                f"{spec.base.controller}, torque limits {spec.torque_limits}, on {where} -> {out}"
            )
            return 0
        return _sweep(args, spec, out, n, where, client)
    finally:
        if client is not None:
            client.close()


def _sweep(args, spec, out: Path, n: int, where: str, client) -> int:
    """The sweep itself, its inputs checked (:func:`run`)."""
    from biped.analysis import survived
    from biped.sim.mjlog import count_warnings, route_to
    from biped.sim.sweep import load, run_sweep

    plot = (Path(args.plot) if args.plot else out.with_suffix(".png")) if args.plot is not None else None
    mjlog = out.with_suffix(".mujoco.log")
    route_to(mjlog)  # MuJoCo's warnings (workers too) beside the results, not inside the bar
    warned_before = count_warnings(mjlog)
    print(
        f"biped sweep: {n} trials of {spec.base.duration_s:g} s, controller "
        f"{spec.base.controller}, torque limits {spec.torque_limits}, physics "
        f"{'the robot' + chr(39) + 's own' if spec.robot else spec.base.physics}, early stop "
        f"{'on' if spec.base.early_stop else 'off'}, on {where} -> {out}",
        file=sys.stderr,
    )
    if args.scheduler is None:  # compile before the local workers start: they load the cache
        warm_up_kernels(spec, tick=sys.stderr)
    if args.refine is not None:
        return _refine(args, spec, out)
    try:
        summary = run_sweep(
            spec,
            out,
            workers=args.workers,
            scheduler=client,
            progress=not args.quiet,
            retry_failed=args.retry_failed,
            overwrite=args.overwrite,
            batch=args.batch,
        )
    except KeyboardInterrupt as exc:
        return stopped_trials(exc, "biped sweep", out, "finish")
    rate = summary.ran / summary.wall_time_s if summary.wall_time_s > 0 else float("nan")
    print(
        f"ran {summary.ran} (skipped {summary.skipped} already done), failed {summary.failed}, "
        f"wall {summary.wall_time_s:.1f} s, {rate:.2f} trials/s ({summary.backend})"
    )
    if not summary.complete:
        print(
            f"biped sweep: {summary.lost} trials were lost to a dead worker; the "
            f"{summary.skipped + summary.ran} finished ones are kept in "
            f"{out.name}.parts/. Run the same command again to finish.",
            file=sys.stderr,
        )
        return 1
    data = load(out)
    ok = survived(data.table)
    print(f"{out}: {data.table.num_rows} trials, survived {int(ok.sum())}, did not {int((~ok).sum())}")
    _say_warnings(data.table, mjlog, warned_before)
    if plot is not None:
        draw_envelope([out, *args.compare], args.by, spec.base.perturbation, plot)
    return 0


def _unit(base) -> str:
    from biped.sim.perturbations import PARADIGMS

    return "m/s" if base.perturbation == "block" else PARADIGMS[base.perturbation].unit


def refine_spec(spec, resolution: float):
    """(the sweep on the fine lattice min..max of its speeds (another paradigm: its magnitudes)
    by ``resolution``, the coarse sizes): ``--refine``'s checks, before any work."""
    from biped.sim.sweep.envelope import lattice

    axes = dict(spec.axes)
    if spec.samples is not None:
        raise ScenarioError("--refine needs a grid, not --samples")
    for name in ("block_mass_kg", "height_m", "gain_scale"):
        if len(axes[name]) != 1:
            raise ScenarioError(f"--refine takes one value of {name}; got {len(axes[name])}")
    if not (math.isfinite(resolution) and resolution > 0):
        raise ScenarioError(f"--refine must be a step > 0 [{_unit(spec.base)}]; got {resolution:g}")
    axis = "speed_m_s" if spec.base.perturbation == "block" else "magnitude"
    coarse = tuple(sorted(axes[axis]))
    steps = (coarse[-1] - coarse[0]) / resolution
    if abs(steps - round(steps)) > 1e-9 * max(1.0, steps):
        raise ScenarioError(
            f"--refine {resolution:g} must divide the grid's speed range {coarse[0]:g}-{coarse[-1]:g} "
            f"into whole steps"
        )
    fine = lattice(coarse[0], coarse[-1], resolution) if len(coarse) > 1 else coarse
    for v in coarse:
        if min(abs(v - f) for f in fine) > 1e-9 * max(1.0, v):
            raise ScenarioError(
                f"--refine {resolution:g}: the grid speed {v:g} is not on the lattice {coarse[0]:g}, "
                f"{coarse[0] + resolution:g}, ... {coarse[-1]:g}; choose a resolution that divides the grid's step"
            )
    return spec.with_axes(**{axis: fine}), coarse


def _refine(args, spec, out) -> int:
    """``--refine``: the grid, then each direction's bisection, as one envelope run."""
    from biped.analysis.envelope_table import envelope_table
    from biped.sim.sweep.envelope import run_envelope

    fine, coarse = refine_spec(spec, args.refine)
    try:
        result = run_envelope(
            fine,
            out,
            axis="speed_m_s" if spec.base.perturbation == "block" else "magnitude",
            checks=0,
            workers=args.workers,
            scheduler=args.scheduler,
            overwrite=args.overwrite,
            grid=coarse,
        )
    except KeyboardInterrupt as exc:
        return stopped_trials(exc, "biped sweep", out, "finish")
    print(envelope_table(result).format())
    print(
        f"ran {result.ran} (reused {result.reused}), wall {result.wall_time_s:.1f} s ({result.backend}); "
        f"{out} holds the grid on the {args.refine:g} {_unit(spec.base)} lattice: rerun with the same --refine"
    )
    if args.plot is not None:  # --plot without a file: beside the results
        plot = Path(args.plot) if args.plot else out.with_suffix(".png")
        draw_envelope([out, *args.compare], args.by, spec.base.perturbation, plot)
    return 0 if result.complete else 1
