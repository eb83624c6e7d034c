"""Files of Bediz's planar postural runs (``biped posture``): summary.json, trajectory.csv, the
figures and the animation of one run; comparison.json/.png of B's equation forms; gains.json,
stability_map.npz/.png of the gain design.

>>> import tempfile
>>> from pathlib import Path
>>> from biped.planar import PendulumParams
>>> from biped.planar.runs import PENDULUM_GAINS
>>> from biped.outputs.posture import run_model
>>> traj, lin = run_model("pendulum", PendulumParams(), "newton-euler", PENDULUM_GAINS, (1.0, 0.0),
...                       (0.0,), out=Path(tempfile.mkdtemp()), dt=0.02, duration=20.0,
...                       integrator="euler", animation=False)
>>> lin.stable
True
"""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from biped import files
from biped.errors import StateError
from biped.outputs._json import write_json
from biped.planar import analysis, runs
from biped.viz import posture as viz

UNITS = (
    "B's own units: mass in lb (used as a mass unit), length in ft, time in s; forces in poundal "
    "(lb ft/s^2), torques and gains in lb ft^2/s^2 (per rad, per rad/s); angles in rad"
)

__all__ = ["UNITS", "compare_forms", "run_gains", "run_model"]


def _write_csv(path: Path, header: list[str], columns: list[np.ndarray]) -> None:
    with files.atomic_open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for row in zip(*columns, strict=True):
            w.writerow([f"{v:.10g}" for v in row])


def _write_json(path: Path, obj) -> None:
    write_json(path, obj)  # strict JSON: NaN / Infinity become null


def write_trajectory_csv(traj, path: Path) -> None:
    """trajectory.csv: time, the states, the torques (M or M1, M2) and the forces of ``traj``."""
    names = list(traj.state_names)
    cols = [traj.time, *traj.states.T]
    torque_names = ["M"] if traj.model == "pendulum" else ["M1", "M2"]
    cols += list(traj.torques.T)
    names = ["time", *names, *torque_names, *traj.forces]
    cols += [traj.forces[k] for k in traj.forces]
    _write_csv(path, names, cols)


def summary_dict(traj, lin) -> dict:
    """The content of summary.json for a run ``traj`` and its linearized analysis ``lin``."""
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


def run_model(
    model: str,
    params,
    method: str,
    gains,
    x0,
    alpha,
    *,
    out: Path,
    dt: float,
    duration: float,
    integrator: str,
    hold: bool = True,
    compare: bool = False,
    animation: bool = True,
):
    """Simulate B's ``model`` ("pendulum" or "body-leg") and write summary.json, trajectory.csv,
    its figures, animation.gif (unless ``animation`` is False) and, with ``compare``, the
    comparison of B's forms (:func:`compare_forms`) into ``out``. Returns ``(traj, lin)``."""
    out.mkdir(parents=True, exist_ok=True)
    common: dict[str, Any] = {"dt": dt, "duration": duration, "integrator": integrator,
              "hold": hold, "progress": True}  # fmt: skip
    if model == "pendulum":
        traj = runs.simulate_pendulum(params, method, gains, x0, alpha=alpha[0], **common)
        lin = analysis.analyze_pendulum(params, gains)
        figs = {"attitude.png": viz.pendulum_attitude_figure(traj)}
    else:
        traj = runs.simulate_body_leg(params, method, gains, x0, alpha=alpha, **common)
        lin = analysis.analyze_body_leg(params, gains)
        figs = {
            "body_attitude.png": viz.body_leg_figure(traj, "body"),
            "leg_angle.png": viz.body_leg_figure(traj, "leg"),
        }
    summary = summary_dict(traj, lin)
    if model == "body-leg" and compare:
        summary["comparison"] = compare_forms(params, gains, x0, alpha, common, out)
    _write_json(out / "summary.json", summary)
    write_trajectory_csv(traj, out / "trajectory.csv")
    for name, fig in figs.items():
        files.write_via(out / name, fig.savefig)
    if animation:
        viz.animate(traj, out / "animation.gif")
    return traj, lin


def compare_forms(params, gains, x0, alpha, common: dict, out: Path) -> dict:
    """Run B's body-leg forms from the same x0, report their largest differences from the
    nonlinear Lagrangian and write comparison.json and comparison.png."""
    trajs, errors = {}, {}
    for method in ("lagrange-linear", "lagrange", "newton-euler", "newton-euler-printed"):
        try:
            trajs[method] = runs.simulate_body_leg(params, method, gains, x0, alpha=alpha, **common)
        except StateError as exc:
            errors[method] = str(exc)
    ref = trajs.get("lagrange")
    result: dict[str, Any] = {"diverged": errors, "max_abs_difference_vs_lagrange": {}}
    for name, tr in trajs.items():
        if ref is not None and name != "lagrange":
            d = np.abs(tr.states - ref.states).max(axis=0)
            result["max_abs_difference_vs_lagrange"][name] = dict(
                zip(tr.state_names, d.tolist(), strict=True)
            )
        result.setdefault("wall_time_s", {})[name] = tr.wall_time
    files.write_via(out / "comparison.png", viz.comparison_figure(trajs).savefig)
    _write_json(out / "comparison.json", result)
    return result


def run_gains(params, *, out: Path, grid: int, k1_max: float, k2_max: float, rate_gains, poles=None):
    """B's gain design for the body-leg model ``params``: the linearized A, B; B's two gain sets;
    the best local gains; pole placement (``poles`` [1/s], default from the best gains' margin);
    LQR; the stability map over (K_theta1, K_theta2) on a ``grid`` x ``grid`` mesh with
    ``rate_gains`` fixed. Writes gains.json, stability_map.npz and stability_map.png into ``out``.
    Returns ``(gains.json content, best local gains)``."""
    out.mkdir(parents=True, exist_ok=True)
    A, B = analysis.ab_matrices(params)
    result: dict[str, Any] = {"parameters": dataclasses.asdict(params), "units": UNITS, "A": A, "B": B}
    b_sets = {"B eq. 3.81-3.84 (K2 = 4000)": runs.BODY_LEG_GAINS_EQ_3_83,
              "B eq. 5.5-5.8 (K2 = 40000)": runs.BODY_LEG_GAINS}  # fmt: skip
    result["bediz_gains"] = {}
    for label, g in b_sets.items():
        lin = analysis.analyze_body_leg(params, g)
        assert lin.char_poly is not None  # the body-leg analysis has one
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
    poles = np.array(poles) if poles else np.array([-best.margin * f for f in (1.0, 1.1, 1.2, 1.3)])
    K_pp = analysis.place_poles_gains(A, B, poles)
    result["pole_placement"] = {
        "poles": poles, "K": K_pp,
        "eigenvalues": [[z.real, z.imag] for z in np.linalg.eigvals(A + B @ K_pp)],
    }  # fmt: skip
    Q, R = analysis.bryson_weights()
    lq = analysis.lqr(A, B, Q, R)
    result["lqr"] = {"Q": Q, "R": R, "K": lq.K,
                     "eigenvalues": [[z.real, z.imag] for z in lq.eigenvalues]}  # fmt: skip
    k1 = np.linspace(0.0, k1_max, grid)
    k2 = np.linspace(0.0, k2_max, grid)
    smap = analysis.stability_map(params, k1, k2, *rate_gains)
    files.write_via(out / "stability_map.npz", lambda tmp: np.savez(
        tmp, k_theta1=k1, k_theta2=k2, margin=smap.margin, rate_gains=np.array(rate_gains)))  # fmt: skip
    result["stability_map"] = {"file": "stability_map.npz", "rate_gains": list(rate_gains),
                               "stable_fraction": float(np.mean(smap.margin > 0))}  # fmt: skip
    marks = {"K2 = 4000 (eq. 3.83)": (25000.0, 4000.0), "K2 = 40000 (eq. 5.7)": (25000.0, 40000.0)}
    files.write_via(out / "stability_map.png", viz.stability_map_figure(smap, marks, best=best).savefig)
    _write_json(out / "gains.json", result)
    return result, best
