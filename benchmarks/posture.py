"""Time per integration step of Bediz's body-leg forms (B V-C: "Newton-Euler 20 % slower") and of
the pendulum's 5x5 vs 3x3 Newton-Euler systems (B II-C-1: "3x3 about two times faster").

Each case runs B's closed loop (Heun, dt 0.01 s, torques held over the step, 500 steps) through
``biped.planar.runs`` and reports the median wall time per step over repeats, and the ratio to the
reference measured in the same run. Usage: python benchmarks/posture.py [--repeats N]
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time

import numpy as np

from biped.planar import body_leg as bl
from biped.planar import pendulum as pd
from biped.planar import runs


def _per_step(fn, steps, repeats):
    fn()  # warm-up
    samples = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        samples.append((time.perf_counter() - t0) / steps)
    return statistics.median(samples), samples


def _loop_per_step(method, steps, repeats):
    """Median of the integration loop's own wall time (``Trajectory.wall_time``, which excludes
    the reaction-force bookkeeping done after the loop) per step."""
    runs.simulate_body_leg(method=method, duration=steps * 0.01)  # warm-up
    return statistics.median(
        runs.simulate_body_leg(method=method, duration=steps * 0.01).wall_time / steps
        for _ in range(repeats)
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15)
    args = ap.parse_args()
    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}")

    steps = 500
    print(f"\nbody-leg, B's run (Heun, dt 0.01, {steps} steps), median time per step:")
    ref = None
    for method in ("lagrange", "lagrange-linear", "newton-euler"):
        med = _loop_per_step(method, steps, args.repeats)
        ref = ref or med
        print(f"  {method:16s} {med * 1e6:8.1f} us/step   ratio to lagrange {med / ref:5.2f}")

    print("\nsingle accelerations call (no integrator), median of 20000 calls:")
    p = bl.BodyLegParams()
    x, u = np.array([0.5, 0.1, 1.0, -0.2]), np.array([-12500.0, -40000.0])
    ref = None
    for method in ("lagrange", "lagrange-linear", "newton-euler"):
        fn = bl.BODY_LEG_METHODS[method]
        med, _ = _per_step(lambda fn=fn: [fn(p, x, u) for _ in range(20000)], 20000, args.repeats)
        ref = ref or med
        print(f"  {method:16s} {med * 1e6:8.2f} us/call   ratio to lagrange {med / ref:5.2f}")

    print("\npendulum Newton-Euler, single call, median of 20000 calls:")
    pp = pd.PendulumParams()
    ref = None
    for name, fn in (("3x3 (eq. 2.10)", pd.newton_euler_3x3), ("5x5 (eq. 2.9)", pd.newton_euler_5x5),
                     ("closed form (2.27)", pd.lagrange)):  # fmt: skip
        med, _ = _per_step(lambda fn=fn: [fn(pp, 0.3, 0.1, 100.0) for _ in range(20000)], 20000,
                           args.repeats)  # fmt: skip
        ref = ref or med
        print(f"  {name:18s} {med * 1e6:8.2f} us/call   ratio to 3x3 {med / ref:5.2f}")


if __name__ == "__main__":
    main()
