"""How far does the stance foot slide while the other foot swings? Measured from MuJoCo's records.

Runs sweep-grid pushes with stepping (``biped sweep --distribution qp --stepping``: hold task,
1.8 kg block aimed at 1.2 m, W's friction 0.3) in the given directions and speeds, and for every
step prints the stance foot's slip: the largest horizontal displacement of its sole centre
(MuJoCo kinematics of the recorded states: the foot body's pose and the sole geoms' centre in
it) over the control periods from lift-off to touchdown in which MuJoCo has the stance foot in
contact with the floor, measured from the first such period. Not the controller's own
``stance_slip_m`` (also printed, for comparison).

    python benchmarks/stance_slip.py [--direction 0:315:8] [--speed 16,18] [--trigger qp]
        [--physics fast] [--duration 4] [--torque-limits human] [--model FILE.xml]
        [--set key=value ...] [--param field=literal ...]
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np

from biped.sim.push import simulate
from biped.sim.scene import build_scene

#: Default speeds [m/s] per direction [deg]: from the QP's feet-in-place envelope edge up to the
#: stepping envelope of docs/sweep.md ("Results: stepping that ends standing").
SPEEDS = {0: (16, 18, 20), 45: (19, 21, 22), 90: (14, 15, 16), 135: (12, 13, 14), 180: (10, 14, 17)}


def sole_centres(model, qpos_rows) -> np.ndarray:
    """(n, 2, 3) the sole centres (left, right) [m]: the centre of the bottom face of each foot's
    sole geoms' bounding box, MuJoCo kinematics of each row."""
    d = mujoco.MjData(model)
    out = np.empty((len(qpos_rows), 2, 3))
    geoms = [[model.geom(f"{side}_{p}").id for p in ("heel", "toe")] for side in ("left", "right")]
    signs = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)])
    for k, q in enumerate(qpos_rows):
        d.qpos[:] = q
        mujoco.mj_kinematics(model, d)
        for i, gs in enumerate(geoms):
            body = model.geom_bodyid[gs[0]]
            R, p = d.xmat[body].reshape(3, 3), d.xpos[body]
            # the corners in the foot body's frame, then the bottom face's centre
            local = []
            for g in gs:
                Rg = d.geom_xmat[g].reshape(3, 3)
                c = d.geom_xpos[g] + (signs * model.geom_size[g]) @ Rg.T
                local.append((c - p) @ R)
            local = np.vstack(local)
            lo, hi = local.min(axis=0), local.max(axis=0)
            centre = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
            out[k, i] = p + R @ centre
    return out


def step_slips(sc, r) -> list[dict]:
    """Per step of run ``r`` (scenario ``sc``): foot, sideways, the measured stance slip [m] and
    the controller's own figure."""
    steps = r.extra.get("steps") or []
    if not steps:
        return []
    model = build_scene(sc).model
    contact = np.stack([r.contacts[:, 0] | r.contacts[:, 1], r.contacts[:, 2] | r.contacts[:, 3]], axis=1)
    out = []
    for st in steps:
        if st["lift_off_s"] is None or st["touch_down_s"] is None:
            continue
        stance = 1 - ("left", "right").index(st["foot"])
        k0 = int(np.searchsorted(r.times, st["lift_off_s"] - 1e-9))
        k1 = int(np.searchsorted(r.times, st["touch_down_s"] - 1e-9))
        rows = [k for k in range(k0, k1 + 1) if contact[k, stance]]
        slip = np.nan
        if rows:
            c = sole_centres(model, r.qpos[rows])[:, stance, :2]
            slip = float(np.linalg.norm(c - c[0], axis=1).max())
        out.append(
            {
                "foot": st["foot"],
                "sideways": st["sideways"],
                "lift_off_s": st["lift_off_s"],
                "touch_down_s": st["touch_down_s"],
                "slip_m": slip,
                "controller_slip_m": st["stance_slip_m"],
                "contact_share": len(rows) / (k1 - k0 + 1),
            }
        )
    return out


def _scenario(speed, direction, trigger, physics, duration, sets, more=()):
    from biped.cli import build_parser
    from biped.cli.sweep import build_spec

    args = ["sweep", "--speed", str(speed), "--direction", str(direction), "--distribution", "qp"]
    args += ["--stepping", "--physics", physics, "--set", f"duration_s={duration}"]
    args += ["--set", f'step_trigger="{trigger}"']
    for s in sets:
        args += ["--set", s]
    args += list(more)
    spec = build_spec(build_parser().parse_args(args))
    return spec.scenario(spec.trials()[0])


def _patch_stepping(params) -> None:
    """Make every stepping run of this process use ``SteppingConfig`` fields ``params``
    (["field=literal", ...]) on top of its trigger's set."""
    import ast

    from biped.control.stepping_config import SteppingConfig

    kw = {}
    for p in params:
        key, _, value = p.partition("=")
        kw[key.strip()] = ast.literal_eval(value.strip())
    if not kw:
        return
    plain = SteppingConfig.for_trigger.__func__

    def for_trigger(cls, trigger, **more):
        return plain(cls, trigger, **{**more, **kw})

    SteppingConfig.for_trigger = classmethod(for_trigger)  # type: ignore[method-assign]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--direction", default="0:315:8", help="start:stop:count [deg]")
    ap.add_argument("--speed", default=None, help="comma list [m/s] (default: per direction)")
    ap.add_argument("--trigger", default="qp", choices=("qp", "capture"))
    ap.add_argument("--physics", default="fast", choices=("fast", "faithful"))
    ap.add_argument("--duration", type=float, default=4.0)
    ap.add_argument("--torque-limits", default=None, choices=("none", "human"))
    ap.add_argument("--model", default=None, help="MJCF file (e.g. from `biped model`)")
    ap.add_argument("--set", action="append", default=[], help="scenario key=value (TOML value)")
    ap.add_argument(
        "--param", action="append", default=[], help="SteppingConfig field=literal, e.g. swing_reaction=True"
    )
    args = ap.parse_args()
    _patch_stepping(args.param)
    a, b, n = args.direction.split(":")
    directions = [int(round(x)) for x in np.linspace(float(a), float(b), int(n))]
    worst: dict[int, float] = {}
    print("dir  speed  outcome    steps  per step: foot side slip_cm (controller's) [contact share]")
    for direction in directions:
        base = min(direction, 360 - direction)
        speeds = [float(s) for s in args.speed.split(",")] if args.speed else SPEEDS[base]
        for speed in speeds:
            # the scenario's own key (simulate applies it; the sweep spec's is the runner's)
            more = ["--set", f'torque_limits="{args.torque_limits}"'] if args.torque_limits else []
            more += ["--model", args.model] if args.model else []
            sc = _scenario(speed, direction, args.trigger, args.physics, args.duration, args.set, more)
            t0 = time.perf_counter()
            r = simulate(sc)
            wall = time.perf_counter() - t0
            outcome = "recovered" if r.recovered else ("fell" if r.fell else "survived")
            if r.diverged:
                outcome = "diverged"
            parts = []
            for s in step_slips(sc, r):
                ctl = s["controller_slip_m"]
                parts.append(
                    f"{s['foot'][0]} {'side' if s['sideways'] else 'fwd '} {100 * s['slip_m']:5.1f} "
                    f"({100 * ctl if ctl is not None else np.nan:4.1f}) [{s['contact_share']:.2f}]"
                )
                if np.isfinite(s["slip_m"]):
                    worst[direction] = max(worst.get(direction, 0.0), s["slip_m"])
            steps = r.extra.get("steps") or []
            head = f"{direction:3d}  {speed:5.1f}  {outcome:9s}  {len(steps):5d}  "
            print(head + "; ".join(parts) + f"  ({wall:.1f} s)")
    print("largest measured slip per direction [cm]:")
    print("  " + ", ".join(f"{d}: {100 * w:.1f}" for d, w in sorted(worst.items())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
