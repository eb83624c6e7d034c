"""Throughput of ``biped sweep``: trials per second on 1 and 2 local workers, parallel efficiency.

Runs the same random sample of 3-second push trials (W's workspace controller holding its
initial posture, block speed 2-5 m/s travelling at 150-210 deg: pushes from behind that it
survives, so every trial runs its full 3 s; the lateral pushes of docs/sweep.md end early) once in this process (``workers=1``, the reference) and once on a pool of 2
spawned worker processes (``workers=2``, process start-up and numba cache loading included),
``--repeat`` times each, and prints the medians, the speed-up, the parallel efficiency
(speed-up / 2) and the projected wall time of 1000 trials. Goal from the issue: 1000 three-second
trials in at most 60 s on 2 cores (16.7 trials/s).

    python benchmarks/sweep.py [--trials 40] [--repeat 3] [--controller workspace|joint-pd]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import tempfile
import time

from biped.sim.sweep import SweepSpec, hold_scenario, run_sweep


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=40)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--controller", choices=("workspace", "joint-pd"), default="workspace")
    args = ap.parse_args()
    base = hold_scenario().with_overrides(controller=args.controller)
    spec = SweepSpec(axes={"speed_m_s": (2.0, 5.0), "direction_deg": (150.0, 210.0)},
                     samples=args.trials, seed=1, base=base)
    warm = SweepSpec(axes={"speed_m_s": 3.0}, base=base.with_overrides(duration_s=0.05))
    with tempfile.TemporaryDirectory() as tmp:
        run_sweep(warm, os.path.join(tmp, "warm.parquet"), workers=1, progress=False)
        times = {1: [], 2: []}
        sim = None
        for r in range(args.repeat):
            for w in (1, 2):
                out = os.path.join(tmp, f"w{w}-{r}.parquet")
                t = time.perf_counter()
                s = run_sweep(spec, out, workers=w, progress=False)
                times[w].append(time.perf_counter() - t)
                assert s.complete and s.ran == args.trials and s.failed == 0
                if sim is None:
                    import pyarrow.parquet as pq

                    tab = pq.read_table(out, columns=["simulated_time_s"])
                    sim = sum(tab.column(0).to_pylist())
    t1, t2 = statistics.median(times[1]), statistics.median(times[2])
    r1, r2 = args.trials / t1, args.trials / t2
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}")
    print(f"{args.trials} trials ({args.controller}, hold task), {sim:.1f} s simulated in all "
          f"(full length: {sim / args.trials:.2f} s per trial); median of {args.repeat}")
    print(f"  1 worker (in process, reference): {t1:7.2f} s  {r1:6.2f} trials/s  "
          f"({sim / t1:5.1f}x real time)")
    print(f"  2 workers (spawned processes):     {t2:7.2f} s  {r2:6.2f} trials/s")
    print(f"  speed-up 2 vs 1: {t1 / t2:.2f}   parallel efficiency: {t1 / t2 / 2:.0%}")
    print(f"  projected 1000 trials on 2 workers: {1000 / r2:.0f} s (goal: <= 60 s)")


if __name__ == "__main__":
    main()
