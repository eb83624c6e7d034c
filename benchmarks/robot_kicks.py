"""The robots' feet-in-place kick envelope in 8 directions (docs/robots.md's table).

    python benchmarks/robot_kicks.py [--robots g1 t1] [--directions 0 45 ... 315] [--steps 6]

Per robot and direction of travel (0 deg: +x, toward the robot's front, i.e. pushed from behind;
90 deg: +y, toward its left), the largest COM velocity change (every body's velocity changed by the
same vector at 0.5 s, :func:`biped.sim.robot.robot_push`) still recovered: no fall and the
central-body COM back within 1 cm of its set point 2.5 s later; bisection in ``--steps`` steps on
[0, 1.6] m/s, feet in place, QP, actuator limits. Printed beside the impulse (mass x velocity
change) and Hof's feet-in-place bound J_max = m sqrt(g / h) d in that direction
(:func:`biped.analysis.robot.robot_hof_bound`). A bisection assumes recovery is monotone in the
kick; docs/robots.md notes where it was not (T1 before the crouch). One process per robot (``--jobs``).
"""

from __future__ import annotations

import argparse
import os
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

HI_M_S = 1.6


def recovers(desc, speed: float, direction_deg: float) -> bool:
    from biped.sim.robot import robot_push
    from biped.sim.robot_rest import RECOVERED_WITHIN_M

    a = np.radians(direction_deg)
    run = robot_push(desc, 3.0, push_m_s=(speed * np.cos(a), speed * np.sin(a), 0.0), push_time_s=0.5)
    return not run.fell and run.final_offset_m < RECOVERED_WITHIN_M


def envelope(name: str, directions: list[float], steps: int) -> tuple[str, list[float], float]:
    from biped.models.robot import describe

    desc = describe(name)
    t0 = time.perf_counter()
    out = []
    for deg in directions:
        lo, hi = 0.0, HI_M_S
        for _ in range(steps):
            mid = (lo + hi) / 2
            lo, hi = (mid, hi) if recovers(desc, mid, deg) else (lo, mid)
        out.append(lo)
        print(f"{name} {deg:5.0f} deg: {lo:.3f} m/s ({time.perf_counter() - t0:.0f} s)", flush=True)
    return name, out, time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="+", default=["g1", "t1"])
    ap.add_argument("--directions", nargs="+", type=float, default=[float(a) for a in range(0, 360, 45)])
    ap.add_argument("--steps", type=int, default=6, help="bisection steps on [0, 1.6] m/s")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    from biped.analysis.robot import robot_hof_bound
    from biped.models.robot import describe

    load0 = os.getloadavg()[0]
    with ProcessPoolExecutor(args.jobs) as ex:
        results = list(
            ex.map(
                envelope, args.robots, [args.directions] * len(args.robots), [args.steps] * len(args.robots)
            )
        )
    print(f"load average {load0:.1f} -> {os.getloadavg()[0]:.1f}, {args.jobs} processes")
    dirs = " | ".join(f"{d:.0f} deg" for d in args.directions)
    print(f"| robot | h | {dirs} |")
    print("|---|---|" + "---|" * len(args.directions))
    for name, speeds, seconds in results:
        desc = describe(name)
        hof = robot_hof_bound(desc, np.asarray(args.directions))
        cells = [
            f"{v:.3f} m/s, {v * desc.mass:.2f} N s, {100 * v * desc.mass / j:.0f} % of {j:.2f}"
            for v, j in zip(speeds, hof.j_max_n_s, strict=True)
        ]
        print(f"| {name} | {hof.com_height_m:.3f} m | " + " | ".join(cells) + f" |  ({seconds:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
