"""``biped posture``: Bediz's planar postural models (pendulum, body + massless leg, gain design).

    biped posture pendulum  [--method M] [--integrator I] [--dt S] [--duration S] [--gains K KD]
                            [--x0 TH THD] [--alpha A] [--param NAME=VALUE ...] [--out DIR]
    biped posture body-leg  [... --gains K1 K1D K2 K2D --x0 T1 T1D T2 T2D --alpha A1 A2 --compare]
    biped posture gains     [--grid N] [--k1-max K] [--k2-max K] [--poles P P P P] [--out DIR]

Defaults are B's runs (Fig. 25; Figs. 30, 31). Units are B's own: lb used as a mass, ft, s.
"""

from __future__ import annotations

import argparse
import dataclasses
import math

import numpy as np

from biped.cli._common import add_folder_options, check_range, run_dir
from biped.errors import ScenarioError, unknown_name

#: Bounds on the work one command may ask for (a run must end in minutes and fit in memory).
MAX_STEPS = 1_000_000  # integration steps, duration / dt (~30 s of pure-Python stepping)
MAX_GRID = 401  # stability map points per axis (401^2 = 160801 eigenvalue problems, ~5 s)


def register(subparsers) -> None:
    from biped.planar import body_leg as bl
    from biped.planar import integrators, runs
    from biped.planar import pendulum as pd

    parser = subparsers.add_parser(
        "posture",
        help="Bediz's planar postural models: pendulum, body + massless leg, gain design",
        description=__doc__.replace("``", ""),  # the docstring's RST quotes read badly in a terminal
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="model", metavar="MODEL", required=True)

    def common(p, methods, method, integrator, dt, duration, n_gains, gains, x0, n_alpha, out):
        p.add_argument("--method", default=method, choices=sorted(methods),
                       help=f"equations to integrate (default {method})")  # fmt: skip
        p.add_argument("--integrator", default=integrator, choices=sorted(integrators.INTEGRATORS),
                       help=f"integration method (default {integrator})")  # fmt: skip
        p.add_argument("--dt", type=float, default=dt, metavar="S", help=f"time step [s] (default {dt})")
        p.add_argument("--duration", type=float, default=duration, metavar="S",
                       help=f"simulated time [s] (default {duration})")  # fmt: skip
        names = ["K", "KD"] if n_gains == 2 else ["K1", "K1D", "K2", "K2D"]
        p.add_argument("--gains", type=float, nargs=n_gains, default=list(gains), metavar=tuple(names),
                       help=f"local feedback gains (default {' '.join(f'{g:g}' for g in gains)})")  # fmt: skip
        states = ("TH", "THD") if len(x0) == 2 else ("T1", "T1D", "T2", "T2D")
        p.add_argument("--x0", type=float, nargs=len(x0), default=list(x0), metavar=states,
                       help=f"initial state [rad, rad/s] (default {' '.join(f'{v:g}' for v in x0)})")  # fmt: skip
        p.add_argument("--alpha", type=float, nargs=n_alpha, default=[0.0] * n_alpha,
                       metavar=("A",) if n_alpha == 1 else ("A1", "A2"),
                       help="set point(s) [rad] (default 0)")  # fmt: skip
        p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                       help="model parameter override, repeatable (e.g. --param m=80)")  # fmt: skip
        p.add_argument("--continuous", action="store_true",
                       help="re-evaluate the torques in every integrator stage "
                            "(default: held over each step, as B's code)")  # fmt: skip
        p.add_argument("--no-animation", action="store_true", help="skip the GIF")
        add_folder_options(p, f"a new runs/{out}-<date>-<time>")

    what = "single-link inverted pendulum (B Fig. 25)"
    pp = sub.add_parser("pendulum", help=what, description=f"{what}; B's units: lb used as a mass, ft, s")
    common(pp, pd.PENDULUM_METHODS, "newton-euler", "euler", 0.02, 20.0, 2, runs.PENDULUM_GAINS,
           (1.0, 0.0), 1, "posture-pendulum")  # fmt: skip
    pp.set_defaults(func=run)

    what = "body on a massless leg (B Figs. 30, 31, 36, 37)"
    pb = sub.add_parser("body-leg", help=what, description=f"{what}; B's units: lb used as a mass, ft, s")
    common(pb, bl.BODY_LEG_METHODS, "lagrange-linear", "heun", 0.01, 5.0, 4, runs.BODY_LEG_GAINS,
           (0.5, 0.0, 1.0, 0.0), 2, "posture-body-leg")  # fmt: skip
    pb.add_argument("--compare", action="store_true",
                    help="also run lagrange-linear, lagrange and newton-euler and report their "
                         "differences (comparison.json, comparison.png)")  # fmt: skip
    pb.set_defaults(func=run)

    what = "linear analysis, pole placement, LQR, best local gains, map"
    pg = sub.add_parser("gains", help=what, description=f"the body-leg model's {what}")
    pg.add_argument("--grid", type=int, default=81, metavar="N",
                    help=f"stability map points per axis, 2..{MAX_GRID} (default 81)")  # fmt: skip
    pg.add_argument("--k1-max", type=float, default=60000.0, metavar="K",
                    help="map K_theta1 range end (default 60000)")  # fmt: skip
    pg.add_argument("--k2-max", type=float, default=60000.0, metavar="K",
                    help="map K_theta2 range end (default 60000)")  # fmt: skip
    pg.add_argument("--rate-gains", type=float, nargs=2, default=[2500.0, 400.0],
                    metavar=("K1D", "K2D"), help="rate gains fixed on the map (default B's)")  # fmt: skip
    pg.add_argument("--poles", type=float, nargs=4, default=None, metavar="P",
                    help="real closed-loop poles for pole placement [1/s], each value at most "
                         "twice (rank of B) (default: those of the best local gains)")  # fmt: skip
    pg.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                    help="body-leg parameter override, repeatable (e.g. --param m=80)")  # fmt: skip
    add_folder_options(pg, "a new runs/posture-gains-<date>-<time>")
    pg.set_defaults(func=run)


def _params(cls, overrides):
    valid = [f.name for f in dataclasses.fields(cls)]
    values = {}
    for item in overrides:
        name, sep, value = item.partition("=")
        if not sep:
            raise ScenarioError(f"--param expects NAME=VALUE, got {item!r}")
        if name not in valid:
            raise ScenarioError(unknown_name("parameter", name, valid))
        try:
            values[name] = float(value)
        except ValueError:
            raise ScenarioError(f"--param {name}: {value!r} is not a number") from None
    return cls(**values)


def _run_model(args) -> int:
    from biped.outputs.posture import run_model
    from biped.planar import body_leg as bl
    from biped.planar import pendulum as pd

    _check_steps(args)
    cls = pd.PendulumParams if args.model == "pendulum" else bl.BodyLegParams
    params = _params(cls, args.param)
    out = run_dir(args.out, f"posture-{args.model}", overwrite=args.overwrite)
    traj, lin = run_model(
        args.model,
        params,
        args.method,
        args.gains,
        args.x0,
        args.alpha,
        out=out,
        dt=args.dt,
        duration=args.duration,
        integrator=args.integrator,
        hold=not args.continuous,
        compare=getattr(args, "compare", False),
        animation=not args.no_animation,
    )
    print(f"{traj.model} {traj.method} ({traj.integrator}, dt {traj.dt:g} s): "
          f"final state {np.array2string(traj.states[-1], precision=5)}; linearized closed loop "
          f"{'stable' if lin.stable else 'UNSTABLE'} (margin {lin.margin:.4g} 1/s); "
          f"wrote {out}/")  # fmt: skip
    return 0


def _run_gains(args) -> int:
    from biped.outputs.posture import run_gains
    from biped.planar import body_leg as bl

    if not 2 <= args.grid <= MAX_GRID:
        raise ScenarioError(
            f"--grid must be in [2, {MAX_GRID}] points per axis (bounds the "
            f"work: {MAX_GRID}^2 eigenvalue problems); got {args.grid}"
        )
    for flag, v in (("--k1-max", args.k1_max), ("--k2-max", args.k2_max)):
        check_range(flag, v, 0.0, 1e12, "map range end, lb ft^2/s^2 per rad", lo_open=True)
    for i, v in enumerate(args.rate_gains):
        check_range(f"--rate-gains[{i}]", v, -1e12, 1e12, "lb ft^2/s^2 per rad/s")
    params = _params(bl.BodyLegParams, args.param)
    if args.poles is not None:
        from biped.planar import analysis

        _check_poles(args.poles, np.linalg.matrix_rank(analysis.ab_matrices(params)[1]))
    out = run_dir(args.out, "posture-gains", overwrite=args.overwrite)
    result, best = run_gains(
        params,
        out=out,
        grid=args.grid,
        k1_max=args.k1_max,
        k2_max=args.k2_max,
        rate_gains=args.rate_gains,
        poles=args.poles,
    )
    print(f"best local gains {np.array2string(best.gains, precision=1)} margin {best.margin:.3f} 1/s "
          f"(B's: {result['bediz_gains']['B eq. 5.5-5.8 (K2 = 40000)']['stability_margin']:.3f}); "
          f"wrote {out}/")  # fmt: skip
    return 0


#: The largest initial angular rate ``--x0`` accepts [rad/s] (a fall is ~10 rad/s).
MAX_RATE = 1000.0


def _check_steps(args) -> None:
    """Bound the integration before any work: finite positive dt, duration >= 0, and at most
    MAX_STEPS steps."""
    check_range("--dt", args.dt, 0.0, 1.0, "time step in s", lo_open=True)
    check_range("--duration", args.duration, 0.0, 1e6, "simulated time in s")
    for i, v in enumerate(getattr(args, "x0", None) or ()):
        if not math.isfinite(v):
            raise ScenarioError(f"--x0 values must be finite (the initial state); got {v!r}")
        if i % 2 == 0:
            check_range(f"--x0 (value {i + 1}, an angle)", v, -math.pi, math.pi, "rad: at most half a turn")
        else:
            check_range(f"--x0 (value {i + 1}, a rate)", v, -MAX_RATE, MAX_RATE, "rad/s")
    steps = args.duration / args.dt
    if steps > MAX_STEPS:
        raise ScenarioError(
            f"--duration / --dt = {steps:.4g} steps, more than the limit of {MAX_STEPS:,} (bounds "
            f"the run's time and memory); use a larger --dt or a shorter --duration"
        )


def _check_poles(poles, rank: int) -> None:
    """Pole placement needs finite real poles, none repeated more often than rank(B)."""
    for i, p in enumerate(poles):
        check_range(f"--poles[{i}]", p, -1e6, 1e6, "real closed-loop pole in 1/s")
    values, counts = np.unique(np.asarray(poles), return_counts=True)
    if counts.max() > rank:
        raise ScenarioError(
            f"--poles: {values[counts.argmax()]:g} is given {counts.max()} times; with {rank} "
            f"inputs (rank of B) a pole may be repeated at most {rank} times"
        )


def run(args) -> int:
    if args.model == "gains":
        return _run_gains(args)
    return _run_model(args)
