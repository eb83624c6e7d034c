"""Where the time of ``biped push`` goes after the simulation: each output timed on its own.

    python benchmarks/outputs.py [--repeat 3] [--video-settings]

Simulates W's push once (warm caches assumed: run ``biped push`` once before), then times, in
rounds so that a change in machine load affects all alike: the row measurements with
trajectory.csv and summary.json, the figures as PNG and as SVG, replay.html, and video.mp4 as
``biped push`` renders it. With ``--video-settings`` it also renders the video at other sizes,
shadow modes and frame rates (the choices weighed in docs/viz.md). Prints the median of each [s].
The machine's load average is printed too: on a shared machine, quote it with the numbers.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--video-settings", action="store_true", help="also other video sizes and modes")
    args = ap.parse_args()

    from biped.outputs.push import write_summary, write_trajectory_csv
    from biped.sim import Scenario, build_scene, simulate
    from biped.sim.measure import measure_rows
    from biped.viz.push_figures import plot_push
    from biped.viz.push_video import render_push_video
    from biped.viz.replay import replay_from_mujoco, write_replay

    scenario = Scenario()
    scene = build_scene(scenario)
    result = simulate(scenario, scene=scene)
    tmp = Path(tempfile.mkdtemp(prefix="biped-outputs-"))

    def csv_summary():
        rows = measure_rows(scene, result)
        write_trajectory_csv(result, tmp / "trajectory.csv", rows=rows)
        write_summary(result, tmp / "summary.json", rows=rows)

    def replay():
        rp = replay_from_mujoco(scene.model, result.times, result.qpos, follow="trunk")
        write_replay(rp, tmp / "replay.html")

    def video(**kw):
        def run():
            res = render_push_video(scene.model, result, tmp / "video.mp4", **kw)
            if res.path is None:
                raise SystemExit(res.reason)

        return run

    tasks = {
        "trajectory.csv + summary.json": csv_summary,
        "figures (PNG, the default)": lambda: plot_push(result, tmp / "png"),
        "figures (PNG + SVG, --svg)": lambda: plot_push(result, tmp / "svg", formats=("png", "svg")),
        "replay.html": replay,
        "video.mp4 (biped push's default)": video(),
    }
    if args.video_settings:
        tasks |= {
            "video 1280x720, shadows, MSAA, reflection, 30 fps (before)": video(
                width=1280, height=720, fps=30, shadows="follow", msaa=4, reflection=True
            ),
            "video 854x480, shadows, MSAA, reflection": video(shadows="follow", msaa=4, reflection=True),
            "video 854x480, shadows": video(shadows="follow"),
            "video 854x480, MSAA": video(msaa=4),
            "video 854x480, reflection": video(reflection=True),
            "video 640x360": video(width=640, height=360),
        }
    times: dict[str, list[float]] = {k: [] for k in tasks}
    cpu: dict[str, list[float]] = {k: [] for k in tasks}
    for _ in range(args.repeat):
        for name, fn in tasks.items():
            c = _cpu()
            t = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t)
            cpu[name].append(_cpu() - c)
    print(f"{platform.machine()}, {os.cpu_count()} cores, load average {os.getloadavg()}")
    print(f"W's push, {len(result.times)} rows; medians of {args.repeat} [s]: wall, and CPU time")
    print("(this process + its children: under load the wall time grows, the CPU time much less)")
    for name, ts in times.items():
        print(
            f"  {name:45s} {statistics.median(ts):7.2f} wall (min {min(ts):.2f}, max {max(ts):.2f})"
            f"  {statistics.median(cpu[name]):6.2f} CPU"
        )


def _cpu() -> float:
    """CPU time [s] of this process and its finished children (the video renderer)."""
    import resource

    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


if __name__ == "__main__":
    main()
