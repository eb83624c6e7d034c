"""Time per integration step of Bediz's body-leg forms (B V-C: "Newton-Euler 20 % slower") and of
the pendulum's 5x5 vs 3x3 Newton-Euler systems (B II-C-1: "3x3 about two times faster").

Each case runs B's closed loop (Heun, dt 0.01 s, torques held over the step, 500 steps) through
``biped.planar.runs`` and reports the median wall time per step of the integration loop
(``Trajectory.wall_time``) over repeats, and the ratio to the reference measured in the same run.
The cases are interleaved (round robin) so that load changes on the machine hit all alike.
Usage: python benchmarks/posture.py [--repeats N]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import numpy as np

from biped.planar import body_leg as bl
from biped.planar import pendulum as pd
from biped.planar import runs


def _interleaved(cases: dict, repeats: int) -> dict:
    """cases: name -> callable returning seconds per unit; medians over round-robin repeats."""
    for fn in cases.values():
        fn()  # warm-up
    samples = {name: [] for name in cases}
    for _ in range(repeats):
        for name, fn in cases.items():
            samples[name].append(fn())
    return {name: statistics.median(v) for name, v in samples.items()}


def _report(title, medians, unit, ref_name):
    print(title)
    ref = medians[ref_name]
    for name, med in medians.items():
        print(f"  {name:20s} {med * 1e6:8.2f} us/{unit}   ratio to {ref_name} {med / ref:5.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=21)
    args = ap.parse_args()
    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}, "
          f"{os.cpu_count()} cores")  # fmt: skip

    steps = 500

    def loop(method):
        return lambda: runs.simulate_body_leg(method=method, duration=steps * 0.01).wall_time / steps

    med = _interleaved({m: loop(m) for m in ("lagrange", "lagrange-linear", "newton-euler")},
                       args.repeats)  # fmt: skip
    _report(f"\nbody-leg, B's run (Heun, dt 0.01, {steps} steps), median time per step:",
            med, "step", "lagrange")  # fmt: skip

    n = 5000
    p = bl.BodyLegParams()
    x, u = np.array([0.5, 0.1, 1.0, -0.2]), np.array([-12500.0, -40000.0])

    def calls(fn, *a):
        def run():
            t0 = time.perf_counter()
            for _ in range(n):
                fn(*a)
            return (time.perf_counter() - t0) / n

        return run

    med = _interleaved({m: calls(bl.BODY_LEG_METHODS[m], p, x, u)
                        for m in ("lagrange", "lagrange-linear", "newton-euler")}, args.repeats)  # fmt: skip
    _report(f"\nbody-leg accelerations alone, median of {n} calls:", med, "call", "lagrange")

    pp = pd.PendulumParams()
    med = _interleaved(
        {
            "3x3 (eq. 2.10)": calls(pd.newton_euler_3x3, pp, 0.3, 0.1, 100.0),
            "5x5 (eq. 2.9)": calls(pd.newton_euler_5x5, pp, 0.3, 0.1, 100.0),
            "closed form (2.27)": calls(pd.lagrange, pp, 0.3, 0.1, 100.0),
        },
        args.repeats,
    )
    _report(f"\npendulum forms, median of {n} calls:", med, "call", "3x3 (eq. 2.10)")


if __name__ == "__main__":
    main()
