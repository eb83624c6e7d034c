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
from pathlib import Path

import numpy as np

from biped.errors import ScenarioError, unknown_name


def register(subparsers) -> None:
    from biped.planar import body_leg as bl
    from biped.planar import integrators, runs
    from biped.planar import pendulum as pd

    parser = subparsers.add_parser(
        "posture",
        help="Bediz's planar postural models: pendulum, body + massless leg, gain design",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="model", metavar="MODEL", required=True)

    def common(p, methods, method, integrator, dt, duration, n_gains, gains, x0, n_alpha, out):
        p.add_argument("--method", default=method, choices=sorted(methods),
                       help=f"equations to integrate (default {method})")  # fmt: skip
        p.add_argument("--integrator", default=integrator, choices=sorted(integrators.INTEGRATORS),
                       help=f"integration method (default {integrator})")  # fmt: skip
        p.add_argument("--dt", type=float, default=dt, help=f"time step [s] (default {dt})")
        p.add_argument("--duration", type=float, default=duration,
                       help=f"simulated time [s] (default {duration})")  # fmt: skip
        names = ["K", "KD"] if n_gains == 2 else ["K1", "K1D", "K2", "K2D"]
        p.add_argument("--gains", type=float, nargs=n_gains, default=list(gains), metavar=tuple(names),
                       help=f"local feedback gains (default {' '.join(f'{g:g}' for g in gains)})")  # fmt: skip
        p.add_argument("--x0", type=float, nargs=len(x0), default=list(x0),
                       help=f"initial state [rad, rad/s] (default {' '.join(f'{v:g}' for v in x0)})")  # fmt: skip
        p.add_argument("--alpha", type=float, nargs=n_alpha, default=[0.0] * n_alpha,
                       help="set point(s) [rad] (default 0)")  # fmt: skip
        p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                       help="model parameter override, repeatable (e.g. --param m=80)")  # fmt: skip
        p.add_argument("--continuous", action="store_true",
                       help="re-evaluate the torques in every integrator stage "
                            "(default: held over each step, as B's code)")  # fmt: skip
        p.add_argument("--no-animation", action="store_true", help="skip the GIF")
        p.add_argument(
            "--out", type=Path, default=Path(out), help=f"output directory (default {out})"
        )

    pp = sub.add_parser("pendulum", help="single-link inverted pendulum (B Fig. 25)")
    common(pp, pd.PENDULUM_METHODS, "newton-euler", "euler", 0.02, 20.0, 2, runs.PENDULUM_GAINS,
           (1.0, 0.0), 1, "posture-pendulum")  # fmt: skip
    pp.set_defaults(func=run)

    pb = sub.add_parser("body-leg", help="body on a massless leg (B Figs. 30, 31, 36, 37)")
    common(pb, bl.BODY_LEG_METHODS, "lagrange-linear", "heun", 0.01, 5.0, 4, runs.BODY_LEG_GAINS,
           (0.5, 0.0, 1.0, 0.0), 2, "posture-body-leg")  # fmt: skip
    pb.add_argument("--compare", action="store_true",
                    help="also run lagrange-linear, lagrange and newton-euler and report their "
                         "differences (comparison.json, comparison.png)")  # fmt: skip
    pb.set_defaults(func=run)

    pg = sub.add_parser("gains", help="linear analysis, pole placement, LQR, best local gains, map")
    pg.add_argument(
        "--grid", type=int, default=81, help="stability map points per axis (default 81)"
    )
    pg.add_argument("--k1-max", type=float, default=60000.0, help="map K_theta1 range end")
    pg.add_argument("--k2-max", type=float, default=60000.0, help="map K_theta2 range end")
    pg.add_argument("--rate-gains", type=float, nargs=2, default=[2500.0, 400.0],
                    metavar=("K1D", "K2D"), help="rate gains fixed on the map (default B's)")  # fmt: skip
    pg.add_argument("--poles", type=float, nargs=4, default=None, metavar="P",
                    help="real closed-loop poles for pole placement [1/s] "
                         "(default: those of the best local gains)")  # fmt: skip
    pg.add_argument("--param", action="append", default=[], metavar="NAME=VALUE")
    pg.add_argument("--out", type=Path, default=Path("posture-gains"))
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

    cls = pd.PendulumParams if args.model == "pendulum" else bl.BodyLegParams
    params = _params(cls, args.param)
    out: Path = args.out
    traj, lin = run_model(args.model, params, args.method, args.gains, args.x0, args.alpha,
                          out=out, dt=args.dt, duration=args.duration, integrator=args.integrator,
                          hold=not args.continuous, compare=getattr(args, "compare", False),
                          animation=not args.no_animation)
    print(f"{traj.model} {traj.method} ({traj.integrator}, dt {traj.dt:g} s): "
          f"final state {np.array2string(traj.states[-1], precision=5)}; linearized closed loop "
          f"{'stable' if lin.stable else 'UNSTABLE'} (margin {lin.margin:.4g} 1/s); "
          f"wrote {out}/")  # fmt: skip
    return 0


def _run_gains(args) -> int:
    from biped.outputs.posture import run_gains
    from biped.planar import body_leg as bl

    if args.grid < 2:
        raise ScenarioError(f"--grid must be >= 2, got {args.grid}")
    params = _params(bl.BodyLegParams, args.param)
    out: Path = args.out
    result, best = run_gains(params, out=out, grid=args.grid, k1_max=args.k1_max,
                             k2_max=args.k2_max, rate_gains=args.rate_gains, poles=args.poles)
    print(f"best local gains {np.array2string(best.gains, precision=1)} margin {best.margin:.3f} 1/s "
          f"(B's: {result['bediz_gains']['B eq. 5.5-5.8 (K2 = 40000)']['stability_margin']:.3f}); "
          f"wrote {out}/")  # fmt: skip
    return 0


def run(args) -> int:
    if args.model == "gains":
        return _run_gains(args)
    return _run_model(args)
