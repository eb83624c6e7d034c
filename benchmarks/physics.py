"""Is ``physics = "fast"`` faithful enough? The same sweep grid under both physics presets.

Runs one grid (default: 8 directions x block speeds 1-9 m/s, the hold task of ``biped sweep``)
for each controller under ``physics = "faithful"`` (0.5 ms step, 5 ms contact time constant) and
``physics = "fast"`` (1 ms, 7.5 ms, MuJoCo's sleep flag, one collision box a sole), then prints,
per direction, the largest speed survived before the first fall (the envelope of
``biped.sim.sweep.envelope``) under each preset and their difference in grid steps (the
criterion: at most one step in every direction), as the markdown table of docs/sweep.md. It also
prints W's default push under both presets: W's timeline (``biped.sim.contact.heel_timeline``:
block hit, heels rise, heels back) side by side (the criterion: within 10 ms) and every foot
event, and the wall time per trial of each preset (same run; a shared machine, so only a rough
figure).

Sweep files go to ``--out`` (default runs/physics-presets/); run the command again to resume.

    python benchmarks/physics.py [--speeds 1:9:9] [--directions 0:315:8] [--workers 1]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
from pathlib import Path

import numpy as np

from biped.analysis.envelope import envelope
from biped.sim import Scenario, simulate
from biped.sim.contact import heel_timeline
from biped.sim.sweep import SweepSpec, hold_scenario, load, parse_axis, run_sweep

PRESETS = ("faithful", "fast")


def compare_w_run() -> bool:
    """W's default push under both presets: W's timeline (block hit, heels rise, heels back)
    side by side, and every foot event of each run."""
    runs = {p: simulate(Scenario(physics=p)) for p in PRESETS}
    lines = {p: heel_timeline(runs[p].events, runs[p].block_contact_time_s) for p in PRESETS}
    print("W's default push (workspace controller, 3 s):")
    for p in PRESETS:
        r = runs[p]
        print(
            f"  {p:8s}: recovered={r.recovered} fell={r.fell}, final COM error "
            f"{r.final_com_error_m * 1e3:.3f} mm, orientation error "
            f"{r.final_orientation_error_deg:.3f} deg; foot events: "
            + ", ".join(f"{e.foot} {e.part} {e.kind.replace('_', ' ')} {e.time_s:.3f}" for e in r.events)
        )
    print("\n| W's event | faithful [s] | fast [s] | difference [ms] |")
    print("|---|---|---|---|")
    worst = 0.0
    for name, a in lines["faithful"].items():
        b = lines["fast"][name]
        diff = math.inf if (a is None) != (b is None) else 0.0 if a is None else abs(a - b)
        worst = max(worst, diff)
        print(f"| {name} | {a} | {b} | {diff * 1e3:.0f} |")
    ok = worst <= 0.010 and runs["fast"].recovered == runs["faithful"].recovered
    print(f"largest difference {worst * 1e3:.0f} ms (criterion <= 10 ms): {'holds' if ok else 'FAILS'}")
    return ok


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speeds", default="1:9:9", help="block speeds [m/s] (sweep axis syntax)")
    ap.add_argument("--directions", default="0:315:8", help="directions [deg]")
    ap.add_argument("--controllers", default="joint-pd,workspace")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--out", default="runs/physics-presets")
    ap.add_argument("--skip-w", action="store_true", help="do not compare W's default push")
    args = ap.parse_args()
    speeds = parse_axis("speed_m_s", args.speeds)
    dirs = parse_axis("direction_deg", args.directions)
    out = Path(args.out)
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores "
        f"(shared with other work), Python {platform.python_version()}"
    )
    w_ok = True if args.skip_w else compare_w_run()
    all_ok = True
    for controller in args.controllers.split(","):
        envs, walls = {}, {}
        for p in PRESETS:
            base = hold_scenario(Scenario(physics=p, controller=controller))
            spec = SweepSpec(axes={"speed_m_s": speeds, "direction_deg": dirs}, base=base)
            path = out / f"{controller}-{p}.parquet"
            s = run_sweep(spec, path, workers=args.workers, progress=False)
            data = load(path)
            envs[p] = envelope(data)
            if s.ran:
                walls[p] = s.wall_time_s / s.ran
        step = np.diff(speeds).min() if len(speeds) > 1 else math.inf
        a, b = envs["faithful"], envs["fast"]
        print(
            f"\n{controller} controller, hold task: largest speed survived before the first "
            f"fall [m/s] (grid step {step:g} m/s)"
        )
        print("| direction [deg] | faithful | fast | difference [steps] |")
        print("|---|---|---|---|")
        worst = 0
        for d, x, y in zip(a.directions_deg, a.survived_max, b.survived_max, strict=True):
            xs = 0.0 if math.isnan(x) else x  # nothing survived: below the grid
            ys = 0.0 if math.isnan(y) else y
            diff = round(abs(xs - ys) / step)
            worst = max(worst, diff)
            print(f"| {d:g} | {x:g} | {y:g} | {diff} |")
        ok = worst <= 1 and np.array_equal(a.directions_deg, b.directions_deg)
        all_ok &= ok
        print(f"largest difference: {worst} grid step(s) (criterion <= 1): {'holds' if ok else 'FAILS'}")
        if walls:
            print(
                "wall time per trial (this run): "
                + ", ".join(f"{p} {w * 1e3:.0f} ms" for p, w in walls.items())
            )
    print(f"\nfast is faithful enough on this grid: {'yes' if all_ok and w_ok else 'NO'}")


if __name__ == "__main__":
    main()
