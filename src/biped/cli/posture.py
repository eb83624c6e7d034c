"""``biped posture``: Bediz's planar postural models (pendulum, body + massless leg, gain design).

    biped posture pendulum  [--method M] [--integrator I] [--dt S] [--duration S] [--gains K KD]
                            [--x0 TH THD] [--alpha A] [--param NAME=VALUE ...] [--out DIR]
    biped posture body-leg  [... --gains K1 K1D K2 K2D --x0 T1 T1D T2 T2D --alpha A1 A2 --compare]
    biped posture gains     [--grid N] [--k1-max K] [--k2-max K] [--poles P P P P] [--out DIR]

Defaults are B's runs (Fig. 25; Figs. 30, 31). Units are B's own: lb used as a mass, ft, s.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
from pathlib import Path

import numpy as np

from biped.cli._common import check_range, run_dir
from biped.errors import ScenarioError, unknown_name

#: Bounds on the work one command may ask for (a run must end in minutes and fit in memory).
MAX_STEPS = 1_000_000  # integration steps, duration / dt (~30 s of pure-Python stepping)
MAX_GRID = 401  # stability map points per axis (401^2 = 160801 eigenvalue problems, ~5 s)

UNITS = (
    "B's own units: mass in lb (used as a mass unit), length in ft, time in s; forces in poundal "
    "(lb ft/s^2), torques and gains in lb ft^2/s^2 (per rad, per rad/s); angles in rad"
)


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
        p.add_argument("--out", metavar="DIR",
                       help=f"output folder (default: a new runs/{out}-<date>-<time>)")
        p.add_argument("--overwrite", action="store_true",
                       help="allow writing into a folder that already holds a run (its files "
                            "are removed first)")

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
        "--grid", type=int, default=81,
        help=f"stability map points per axis, 2..{MAX_GRID} (default 81)"
    )
    pg.add_argument("--k1-max", type=float, default=60000.0, help="map K_theta1 range end")
    pg.add_argument("--k2-max", type=float, default=60000.0, help="map K_theta2 range end")
    pg.add_argument("--rate-gains", type=float, nargs=2, default=[2500.0, 400.0],
                    metavar=("K1D", "K2D"), help="rate gains fixed on the map (default B's)")  # fmt: skip
    pg.add_argument("--poles", type=float, nargs=4, default=None, metavar="P",
                    help="real closed-loop poles for pole placement [1/s], each value at most "
                         "twice (rank of B) (default: those of the best local gains)")  # fmt: skip
    pg.add_argument("--param", action="append", default=[], metavar="NAME=VALUE")
    pg.add_argument("--out", metavar="DIR",
                    help="output folder (default: a new runs/posture-gains-<date>-<time>)")
    pg.add_argument("--overwrite", action="store_true",
                    help="allow writing into a folder that already holds a run (its files are "
                         "removed first)")
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


def _write_csv(path: Path, header: list[str], columns: list[np.ndarray]) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for row in zip(*columns):
            w.writerow([f"{v:.10g}" for v in row])


def _write_json(path: Path, obj) -> None:
    path.write_text(json.dumps(obj, indent=2, default=_jsonable) + "\n")


def _jsonable(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if dataclasses.is_dataclass(o):
        return dataclasses.asdict(o)
    raise TypeError(type(o))


def _trajectory_csv(traj, path: Path) -> None:
    names = list(traj.state_names)
    cols = [traj.time, *traj.states.T]
    torque_names = ["M"] if traj.model == "pendulum" else ["M1", "M2"]
    cols += list(traj.torques.T)
    names = ["time", *names, *torque_names, *traj.forces]
    cols += [traj.forces[k] for k in traj.forces]
    _write_csv(path, names, cols)


def _summary(traj, lin) -> dict:
    return {
        "model": traj.model,
        "method": traj.method,
        "integrator": traj.integrator,
        "dt": traj.dt,
        "duration": float(traj.time[-1]),
        "torques_held_over_step": traj.hold,
        "parameters": dataclasses.asdict(traj.params),
        "gains": list(traj.feedback.gains[: 2 if traj.model == "pendulum" else 4]),
        "set_points": [traj.feedback.alpha1] if traj.model == "pendulum"
        else [traj.feedback.alpha1, traj.feedback.alpha2],
        "x0": traj.states[0].tolist(),
        "final_state": traj.states[-1].tolist(),
        "max_abs_state": np.abs(traj.states).max(axis=0).tolist(),
        "eigenvalues": lin.eigenvalue_pairs(),
        "stable": lin.stable,
        "stability_margin": lin.margin,
        "characteristic_polynomial": lin.char_poly.tolist(),
        "wall_time_s": traj.wall_time,
        "units": UNITS,
    }  # fmt: skip


def _run_model(args) -> int:
    from biped.planar import analysis, runs
    from biped.planar import body_leg as bl
    from biped.planar import pendulum as pd
    from biped.viz import posture as viz

    _check_steps(args)
    params = _params(pd.PendulumParams if args.model == "pendulum" else bl.BodyLegParams, args.param)
    out = run_dir(args.out, f"posture-{args.model}", overwrite=args.overwrite)
    common = {"dt": args.dt, "duration": args.duration, "integrator": args.integrator,
                  "hold": not args.continuous, "progress": True}  # fmt: skip
    if args.model == "pendulum":
        traj = runs.simulate_pendulum(params, args.method, args.gains, args.x0,
                                      alpha=args.alpha[0], **common)  # fmt: skip
        lin = analysis.analyze_pendulum(params, args.gains)
        figs = {"attitude.png": viz.pendulum_attitude_figure(traj)}
    else:
        traj = runs.simulate_body_leg(params, args.method, args.gains, args.x0,
                                      alpha=args.alpha, **common)  # fmt: skip
        lin = analysis.analyze_body_leg(params, args.gains)
        figs = {
            "body_attitude.png": viz.body_leg_figure(traj, "body"),
            "leg_angle.png": viz.body_leg_figure(traj, "leg"),
        }
    summary = _summary(traj, lin)
    if args.model == "body-leg" and args.compare:
        summary["comparison"] = _compare(args, params, common, out)
    _write_json(out / "summary.json", summary)
    _trajectory_csv(traj, out / "trajectory.csv")
    for name, fig in figs.items():
        fig.savefig(out / name)
    if not args.no_animation:
        viz.animate(traj, out / "animation.gif")
    print(f"{traj.model} {traj.method} ({traj.integrator}, dt {traj.dt:g} s): "
          f"final state {np.array2string(traj.states[-1], precision=5)}; linearized closed loop "
          f"{'stable' if lin.stable else 'UNSTABLE'} (margin {lin.margin:.4g} 1/s); "
          f"wrote {out}/")  # fmt: skip
    return 0


def _compare(args, params, common, out: Path) -> dict:
    """Run B's three forms from the same x0 and report their largest differences."""
    from biped.errors import StateError
    from biped.planar import runs
    from biped.viz import posture as viz

    trajs, errors = {}, {}
    for method in ("lagrange-linear", "lagrange", "newton-euler", "newton-euler-printed"):
        try:
            trajs[method] = runs.simulate_body_leg(params, method, args.gains, args.x0,
                                                   alpha=args.alpha, **common)  # fmt: skip
        except StateError as exc:
            errors[method] = str(exc)
    ref = trajs.get("lagrange")
    result = {"diverged": errors, "max_abs_difference_vs_lagrange": {}}
    for name, tr in trajs.items():
        if ref is not None and name != "lagrange":
            d = np.abs(tr.states - ref.states).max(axis=0)
            result["max_abs_difference_vs_lagrange"][name] = dict(zip(tr.state_names, d.tolist()))
        result.setdefault("wall_time_s", {})[name] = tr.wall_time
    viz.comparison_figure(trajs).savefig(out / "comparison.png")
    _write_json(out / "comparison.json", result)
    return result


def _run_gains(args) -> int:
    from biped.planar import analysis, runs
    from biped.planar import body_leg as bl
    from biped.viz import posture as viz

    if not 2 <= args.grid <= MAX_GRID:
        raise ScenarioError(f"--grid must be in [2, {MAX_GRID}] points per axis (bounds the "
                            f"work: {MAX_GRID}^2 eigenvalue problems); got {args.grid}")
    for flag, v in (("--k1-max", args.k1_max), ("--k2-max", args.k2_max)):
        check_range(flag, v, 0.0, 1e12, "map range end, lb ft^2/s^2 per rad", lo_open=True)
    for i, v in enumerate(args.rate_gains):
        check_range(f"--rate-gains[{i}]", v, -1e12, 1e12, "lb ft^2/s^2 per rad/s")
    params = _params(bl.BodyLegParams, args.param)
    A, B = analysis.ab_matrices(params)
    if args.poles is not None:
        _check_poles(args.poles, np.linalg.matrix_rank(B))
    out = run_dir(args.out, "posture-gains", overwrite=args.overwrite)
    result = {"parameters": dataclasses.asdict(params), "units": UNITS, "A": A, "B": B}
    b_sets = {"B eq. 3.81-3.84 (K2 = 4000)": runs.BODY_LEG_GAINS_EQ_3_83,
              "B eq. 5.5-5.8 (K2 = 40000)": runs.BODY_LEG_GAINS}  # fmt: skip
    result["bediz_gains"] = {}
    for label, g in b_sets.items():
        lin = analysis.analyze_body_leg(params, g)
        result["bediz_gains"][label] = {
            "gains": list(g), "eigenvalues": lin.eigenvalue_pairs(), "stable": lin.stable,
            "stability_margin": lin.margin, "characteristic_polynomial": lin.char_poly,
            "hurwitz_minors": analysis.hurwitz_minors(lin.char_poly),
        }  # fmt: skip
    best = analysis.best_local_gains(params)
    best_lin = analysis.analyze_body_leg(params, best.gains)
    result["best_local_gains"] = {
        "gains": best.gains, "bounds": best.bounds, "stability_margin": best.margin,
        "eigenvalues": best_lin.eigenvalue_pairs(),
    }  # fmt: skip
    poles = (
        np.array(args.poles)
        if args.poles
        else np.array([-best.margin * f for f in (1.0, 1.1, 1.2, 1.3)])
    )
    K_pp = analysis.place_poles_gains(A, B, poles)
    result["pole_placement"] = {
        "poles": poles, "K": K_pp,
        "eigenvalues": [[z.real, z.imag] for z in np.linalg.eigvals(A + B @ K_pp)],
    }  # fmt: skip
    Q, R = analysis.bryson_weights()
    lq = analysis.lqr(A, B, Q, R)
    result["lqr"] = {"Q": Q, "R": R, "K": lq.K,
                     "eigenvalues": [[z.real, z.imag] for z in lq.eigenvalues]}  # fmt: skip
    k1 = np.linspace(0.0, args.k1_max, args.grid)
    k2 = np.linspace(0.0, args.k2_max, args.grid)
    smap = analysis.stability_map(params, k1, k2, *args.rate_gains)
    np.savez(out / "stability_map.npz", k_theta1=k1, k_theta2=k2, margin=smap.margin,
             rate_gains=np.array(args.rate_gains))  # fmt: skip
    result["stability_map"] = {"file": "stability_map.npz", "rate_gains": list(args.rate_gains),
                               "stable_fraction": float(np.mean(smap.margin > 0))}  # fmt: skip
    marks = {"K2 = 4000 (eq. 3.83)": (25000.0, 4000.0), "K2 = 40000 (eq. 5.7)": (25000.0, 40000.0)}
    viz.stability_map_figure(smap, marks).savefig(out / "stability_map.png")
    _write_json(out / "gains.json", result)
    print(f"best local gains {np.array2string(best.gains, precision=1)} margin {best.margin:.3f} 1/s "
          f"(B's: {result['bediz_gains']['B eq. 5.5-5.8 (K2 = 40000)']['stability_margin']:.3f}); "
          f"wrote {out}/")  # fmt: skip
    return 0


def _check_steps(args) -> None:
    """Bound the integration before any work: finite positive dt, duration >= 0, and at most
    MAX_STEPS steps."""
    check_range("--dt", args.dt, 0.0, 1.0, "time step in s", lo_open=True)
    check_range("--duration", args.duration, 0.0, 1e6, "simulated time in s")
    steps = args.duration / args.dt
    if steps > MAX_STEPS:
        raise ScenarioError(
            f"--duration / --dt = {steps:.4g} steps, more than the limit of {MAX_STEPS:,} (bounds "
            f"the run's time and memory); use a larger --dt or a shorter --duration")


def _check_poles(poles, rank: int) -> None:
    """Pole placement needs finite real poles, none repeated more often than rank(B)."""
    for i, p in enumerate(poles):
        check_range(f"--poles[{i}]", p, -1e6, 1e6, "real closed-loop pole in 1/s")
    values, counts = np.unique(np.asarray(poles), return_counts=True)
    if counts.max() > rank:
        raise ScenarioError(
            f"--poles: {values[counts.argmax()]:g} is given {counts.max()} times; with {rank} "
            f"inputs (rank of B) a pole may be repeated at most {rank} times")


def run(args) -> int:
    if args.model == "gains":
        return _run_gains(args)
    return _run_model(args)
