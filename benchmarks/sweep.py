"""Throughput of ``biped sweep`` against a physics-only reference measured in the same run.

1. Physics-only reference: for each of the first ``--reference`` trials of the sample, the closed
   loop runs once to record its torques, then the same scene is stepped from the same initial
   state with those torques in a bare ``mj_step(m, d, nsub)`` loop (no controller, no contact
   bookkeeping, no recording). Closed-loop trial (``run_trial``: controller, bookkeeping and the
   measurements) and bare physics are timed alternately in this thread (CPU time of the thread,
   so that other processes on a shared machine weigh less), median per trial; the ratio is
   trial / physics-only.
2. Sweeps: the same random sample of 3-second push trials (W's workspace controller holding its
   initial posture, block speed 2-5 m/s travelling at 150-210 deg: pushes from behind that it
   survives, so every trial runs its full 3 s) with ``run_sweep`` on 1 worker (this process) and
   on 2 worker processes (start-up included), ``--repeat`` times each, wall time; trials/s, the
   speed-up, the parallel efficiency (speed-up / 2), and each rate against the physics-only rate
   of the same number of cores. Goal of the speed issue: 1000 three-second trials in at most 60 s
   on 2 cores (16.7 trials/s) at a parallel efficiency of at least 85 %.
3. CPU time of each sweep (this process plus its worker processes, ``getrusage``): on a machine
   shared with other work the wall times measure the other work too, the CPU times much less.
   The CPU-based efficiency is CPU(1 worker) / CPU(2 workers): what running in parallel costs
   (worker start-up, pickling, the parent's bookkeeping, two workers sharing caches); the
   projected 1000 trials assume two otherwise idle cores (2-worker CPU time / 2).

    python benchmarks/sweep.py [--trials 40] [--repeat 3] [--reference 5] [--physics fast]
                               [--controller workspace|joint-pd]
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import statistics
import tempfile
import time

import mujoco
import numpy as np

from biped.sim import Scenario
from biped.sim.push import run_closed_loop
from biped.sim.scene import initial_state
from biped.sim.sweep import SweepSpec, hold_scenario, run_sweep
from biped.sim.sweep.trial import _scene_for, make_policy, run_trial


def _cpu() -> float:
    """CPU seconds of this process and of its finished child processes (user + system)."""
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def physics_only(setup) -> tuple[float, float]:
    """(CPU s of the closed-loop trial, CPU s of the bare physics with its recorded torques)."""
    sc = setup.scenario
    scene = _scene_for(sc)
    t0 = time.thread_time()
    run_trial(setup)
    t_trial = time.thread_time() - t0
    result = run_closed_loop(sc, scene, make_policy(setup, scene))
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = initial_state(scene, sc)
    mujoco.mj_forward(m, d)
    act, sub, tau = scene.actuator_index, sc.control_substeps, np.asarray(result.torques)
    t0 = time.thread_time()
    for k in range(len(result.times) - 1):
        d.ctrl[act] = tau[k]
        mujoco.mj_step(m, d, sub)
    return t_trial, time.thread_time() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=40)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--reference", type=int, default=5, help="trials timed against bare physics")
    ap.add_argument("--controller", choices=("workspace", "joint-pd"), default="workspace")
    ap.add_argument(
        "--physics",
        choices=("faithful", "fast"),
        default="fast",
        help="physics preset (biped sweep's default: fast)",
    )
    args = ap.parse_args()
    base = hold_scenario(Scenario(physics=args.physics)).with_overrides(controller=args.controller)
    spec = SweepSpec(
        axes={"speed_m_s": (2.0, 5.0), "direction_deg": (150.0, 210.0)},
        samples=args.trials,
        seed=1,
        base=base,
    )
    warm = SweepSpec(axes={"speed_m_s": 3.0}, base=base.with_overrides(duration_s=0.05))
    with tempfile.TemporaryDirectory() as tmp:
        run_sweep(warm, os.path.join(tmp, "warm.parquet"), workers=1, progress=False)
        pairs = [physics_only(spec.setup(t)) for t in spec.trials()[: args.reference]]
        trial_cpu = statistics.median(p[0] for p in pairs)
        phys_cpu = statistics.median(p[1] for p in pairs)
        times: dict[int, list[float]] = {1: [], 2: []}
        cpus: dict[int, list[float]] = {1: [], 2: []}
        sim = None
        for r in range(args.repeat):
            for w in (1, 2):
                out = os.path.join(tmp, f"w{w}-{r}.parquet")
                c = _cpu()
                t = time.perf_counter()
                s = run_sweep(spec, out, workers=w, progress=False)
                times[w].append(time.perf_counter() - t)
                cpus[w].append(_cpu() - c)
                assert s.complete and s.ran == args.trials and s.failed == 0
                if sim is None:
                    import pyarrow.parquet as pq

                    tab = pq.read_table(out, columns=["simulated_time_s"])
                    sim = sum(tab.column(0).to_pylist())
    t1, t2 = statistics.median(times[1]), statistics.median(times[2])
    c1, c2 = statistics.median(cpus[1]), statistics.median(cpus[2])
    r1, r2 = args.trials / t1, args.trials / t2
    phys_rate = 1.0 / phys_cpu
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, "
        f"load average {os.getloadavg()[0]:.1f} at the end, Python {platform.python_version()}, "
        f"MuJoCo {mujoco.__version__}"
    )
    print(
        f"{args.trials} trials ({args.controller}, hold task), {sim:.1f} s simulated in all "
        f"({sim / args.trials:.2f} s per trial); medians"
    )
    print(f"reference, {args.reference} trials, thread CPU time per trial:")
    print(
        f"  physics only (bare mj_step, recorded torques): {1e3 * phys_cpu:7.1f} ms "
        f"({phys_rate:5.2f} trials/s per core)"
    )
    print(
        f"  closed-loop trial (run_trial):                 {1e3 * trial_cpu:7.1f} ms "
        f"= {trial_cpu / phys_cpu:.2f}x physics only"
    )
    print(f"sweeps, wall time (median of {args.repeat}):")
    print(
        f"  1 worker (this process): {t1:7.2f} s  {r1:6.2f} trials/s  "
        f"= {r1 / phys_rate:.2f} of physics-only on 1 core"
    )
    print(
        f"  2 worker processes:      {t2:7.2f} s  {r2:6.2f} trials/s  "
        f"= {r2 / (2 * phys_rate):.2f} of physics-only on 2 cores"
    )
    print(f"  speed-up 2 vs 1: {t1 / t2:.2f}   parallel efficiency: {t1 / t2 / 2:.0%}")
    print(f"  projected 1000 trials on 2 workers: {1000 / r2:.0f} s (goal: <= 60 s)")
    print("sweeps, CPU time (this process + its workers; median):")
    print(
        f"  1 worker: {c1:7.2f} s = {1e3 * c1 / args.trials:6.1f} ms per trial   "
        f"2 workers: {c2:7.2f} s = {1e3 * c2 / args.trials:6.1f} ms per trial"
    )
    print(
        f"  CPU-based parallel efficiency CPU(1) / CPU(2): {c1 / c2:.0%}   projected 1000 "
        f"trials on 2 idle cores: {1000 * c2 / args.trials / 2:.0f} s (goal: <= 60 s)"
    )


if __name__ == "__main__":
    main()
