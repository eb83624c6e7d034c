"""Speed of W's push experiment: closed loop vs an open-loop replay of its torques.

Runs the scenario (default W's) closed loop without video, then replays the recorded torques open
loop on the same scene from the same initial state in the same process: the same physics work
without the controller. Prints the medians of ``--repeat`` runs of each, their real-time factors
(simulated time / wall time) and the ratio closed / open. Goals from the issue: >= 30x real time,
ratio <= 1.5. W's 3 s run took 2066 s on a 100 MHz SGI R4000 (0.0015x real time).

    python benchmarks/push.py [--repeat 5] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

from biped.sim import Scenario, build_scene, replay_torques, simulate
from biped.sim.scenario import parse_assignment


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    scenario = Scenario().with_overrides(**dict(parse_assignment(a) for a in args.set))
    scene = build_scene(scenario)
    warm = simulate(scenario.with_overrides(duration_s=0.02), scene=scene)  # numba compile
    replay_torques(warm, scene=scene)

    closed, opened, result = [], [], None
    for _ in range(args.repeat):
        t = time.perf_counter()
        result = simulate(scenario, scene=scene)
        closed.append(time.perf_counter() - t)
        t = time.perf_counter()
        rep = replay_torques(result, scene=scene)
        opened.append(time.perf_counter() - t)
    sim_time = result.times[-1]
    c, o = statistics.median(closed), statistics.median(opened)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"python {platform.python_version()}")
    print(f"scenario: physics {scenario.physics_timestep_s * 1e3:g} ms, control "
          f"{scenario.control_rate_hz:g} Hz, simulated {sim_time:.3f} s of {scenario.duration_s:g} s"
          + ("" if sim_time >= scenario.duration_s else
             f" (the run ended early: fell={result.fell}, diverged={bool(result.diverged)})"))
    print(f"closed loop (controller + physics): median {c * 1e3:8.1f} ms  "
          f"{sim_time / c:7.1f}x real time")
    print(f"open-loop replay (physics only):    median {o * 1e3:8.1f} ms  "
          f"{(rep.times[-1]) / o:7.1f}x real time")
    print(f"ratio closed / open: {c / o:.3f}   (goal <= 1.5; goal >= 30x real time)")
    print(f"W (1997): 3 s in 2066 s = {3 / 2066:.4f}x real time")


if __name__ == "__main__":
    main()
