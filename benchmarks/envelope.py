"""`biped envelope` against the full grid it replaces, in the same run.

Times the whole ``biped envelope`` command (a subprocess: imports, worker start-up, every trial,
the table) for N directions at a resolution, then the ``biped sweep`` grid of the same
directions at the same resolution (1-24 m/s by default), and compares per direction the
envelope's limit with the grid's (the largest speed below the first failure,
:func:`biped.analysis.envelope`): equal within one resolution step is the criterion.

    python benchmarks/envelope.py [--directions 16] [--resolution 0.25] [--grid-min 1] [--max 24]
        [--workers 2] [--out runs/envelope-bench] [--skip-grid] [-- extra options of both commands]

Example: ``python benchmarks/envelope.py -- --distribution qp`` (QP feet in place, fast physics).
The files go to ``--out``; the grid file is reused when present (delete it to time the grid again).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from biped.analysis import envelope
from biped.sim.sweep import load


def _run(cmd: list[str]) -> tuple[float, float]:
    """(wall [s], CPU time of the command and its workers [s])."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--directions", type=int, default=16)
    ap.add_argument("--resolution", type=float, default=0.25)
    ap.add_argument("--grid-min", type=float, default=1.0)
    ap.add_argument("--max", type=float, default=24.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default="runs/envelope-bench")
    ap.add_argument("--tag", default="qp")
    ap.add_argument("--skip-grid", action="store_true")
    ap.add_argument("extra", nargs="*", help="options for both commands (after --)")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    biped = [sys.executable, "-m", "biped"]
    env_file, env_json = out / f"envelope-{args.tag}.parquet", out / f"envelope-{args.tag}.json"
    for f in (env_file, env_json):
        f.unlink(missing_ok=True)
    stop = 360.0 - 360.0 / args.directions
    load0 = os.getloadavg()
    wall_env, cpu_env = _run(
        [*biped, "envelope", "--directions", str(args.directions), "--resolution", str(args.resolution),
         "--max", str(args.max), "--workers", str(args.workers), "--out", str(env_file),
         "--json", str(env_json), "--quiet", *args.extra]
    )  # fmt: skip
    table = json.loads(env_json.read_text())
    n_env = load(env_file).table.num_rows
    print(
        f"biped envelope, {args.directions} directions, resolution {args.resolution:g}, "
        f"{' '.join(args.extra) or 'defaults'}: {wall_env:.1f} s wall (whole command), "
        f"{cpu_env:.1f} s CPU, {n_env} trials; load average {load0[0]:.1f} before"
    )
    if args.skip_grid:
        return 0
    num = round((args.max - args.grid_min) / args.resolution) + 1
    grid_file = out / f"grid-{args.tag}-{args.directions}x{num}.parquet"
    load1 = os.getloadavg()
    wall_grid = cpu_grid = float("nan")
    if not grid_file.exists():
        wall_grid, cpu_grid = _run(
            [*biped, "sweep", "--speed", f"{args.grid_min:g}:{args.max:g}:{num}", "--direction",
             f"0:{stop:g}:{args.directions}", "--workers", str(args.workers), "--out", str(grid_file),
             "--quiet", *args.extra]
        )  # fmt: skip
    grid = load(grid_file)
    ge = envelope(grid)
    print(
        f"biped sweep grid, {args.directions} x {num} = {grid.table.num_rows} trials: "
        f"{wall_grid:.1f} s wall (whole command; NaN: reused), {cpu_grid:.1f} s CPU; load average "
        f"{load1[0]:.1f} before, "
        f"{os.getloadavg()[0]:.1f} after"
    )
    print(f"speed-up: x{wall_grid / wall_env:.1f} wall, x{cpu_grid / cpu_env:.1f} CPU")
    within = 0
    print("direction  envelope limit  grid limit  difference [steps]  note")
    for row in table["directions"]:
        d = row["direction_deg"]
        i = int(np.argmin(np.abs(ge.directions_deg - d)))
        g = ge.survived_max[i]
        e = row["limit"] if row["limit"] is not None else float("nan")
        steps = (e - g) / args.resolution
        ok = bool(np.isfinite(steps) and abs(steps) <= 1.0 + 1e-9)
        within += ok
        note = "non-monotone" if row["non_monotone"] else ""
        print(f"{d:9.1f}  {e:14.2f}  {g:10.2f}  {steps:18.1f}  {note}")
    print(f"limits within one step of the grid's: {within} of {len(table['directions'])}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
