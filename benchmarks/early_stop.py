"""Does early stop change any outcome, and what does it save? One grid with and without it.

Runs the same ``biped sweep`` grid twice, with the scenario key ``early_stop`` off and on
(:mod:`biped.sim.early_stop`), and compares the two files trial by trial: ``survived`` (completed,
no fall, error, controller error or divergence), ``recovered``, ``fell`` and ``diverged``. Any
difference is listed (the rule is wrong if there is one). Prints the wall time of each sweep (the
same run; a shared machine, so the ratio is the figure to read), the simulated time saved and how
the early-stopped trials ended.

    python benchmarks/early_stop.py --speed 1:15:15 --direction 0:315:8 --distribution qp \\
        [--controller joint-pd] [--torque-limits human] [--stepping] [--physics faithful] \\
        [--workers 2] [--out runs/early-stop]
    python benchmarks/early_stop.py --perturbation force --magnitude 100:400:4 --direction 0:270:4

Another paradigm (``--perturbation force|platform|release``, docs/perturbations.md) is swept by
``--magnitude`` (its own unit) and ``--direction`` instead of ``--speed``.

The sweep files go to ``--out`` (named by the options); run again to resume or to reuse them.
"""

from __future__ import annotations

import argparse
import os
import resource
import time
from pathlib import Path

import numpy as np

from biped.analysis import survived
from biped.sim.sweep import SweepSpec, hold_scenario, load, parse_axis, run_sweep


def _cpu() -> float:
    """CPU time [s] of this process and its finished children (the sweep's workers)."""
    total = 0.0
    for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN):
        r = resource.getrusage(who)
        total += r.ru_utime + r.ru_stime
    return total


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--speed", default="1:15:15")
    ap.add_argument("--perturbation", default="block", choices=("block", "force", "platform", "release"))
    ap.add_argument("--magnitude", default=None, help="another paradigm's sizes (its unit), as --speed")
    ap.add_argument("--duration", type=float, default=None, help="trial duration [s] (default the sweep's)")
    ap.add_argument("--direction", default="0:315:8")
    ap.add_argument("--controller", default="workspace", choices=("workspace", "joint-pd"))
    ap.add_argument("--distribution", default="statics", choices=("statics", "printed", "qp"))
    ap.add_argument("--torque-limits", default="none", choices=("none", "human"))
    ap.add_argument("--stepping", action="store_true")
    ap.add_argument("--physics", default="fast", choices=("fast", "faithful"))
    ap.add_argument("--samples", type=int, default=None, help="a random sample instead of the grid")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default="runs/early-stop")
    ap.add_argument("--fresh", action="store_true", help="rerun both sweeps (overwrite the files)")
    args = ap.parse_args()
    block = args.perturbation == "block"
    size_axis = "speed_m_s" if block else "magnitude"
    if not block and args.magnitude is None:
        ap.error(f"--perturbation {args.perturbation} needs --magnitude")
    axes = {
        size_axis: parse_axis(size_axis, args.speed if block else args.magnitude),
        "direction_deg": parse_axis("direction_deg", args.direction),
    }
    name = (
        ("" if block else f"{args.perturbation}-")
        + f"{args.controller}-{args.distribution}{'-stepping' if args.stepping else ''}-"
        f"{args.torque_limits}-{args.physics}-{len(axes[size_axis])}x{len(axes['direction_deg'])}"
        + (f"-s{args.samples}" if args.samples else "")
        + (f"-{args.duration:g}s" if args.duration else "")
    )
    out = Path(args.out)
    files, walls = {}, {}
    load1 = os.getloadavg()
    for es in (False, True):
        base = hold_scenario().with_overrides(
            controller=args.controller,
            distribution=args.distribution,
            stepping=args.stepping,
            physics=args.physics,
            early_stop=es,
            **({} if block else {"perturbation": args.perturbation}),
            **({"duration_s": args.duration} if args.duration else {}),
        )
        spec = SweepSpec(axes=axes, base=base, torque_limits=args.torque_limits, samples=args.samples)
        files[es] = out / f"{name}-{'early' if es else 'full'}.parquet"
        c0 = _cpu()
        t0 = time.perf_counter()
        s = run_sweep(spec, files[es], workers=args.workers, progress=False, overwrite=args.fresh)
        walls[es] = (time.perf_counter() - t0, s.ran, _cpu() - c0)
    load2 = os.getloadavg()
    full, early = (load(files[es]).table.to_pylist() for es in (False, True))
    key = (size_axis, "direction_deg")
    by = {tuple(r[k] for k in key): r for r in full}
    diffs = []
    ok_f = survived(load(files[False]))
    ok_e = survived(load(files[True]))
    ok_f = {tuple(r[k] for k in key): bool(o) for r, o in zip(full, ok_f, strict=True)}
    ok_e = {tuple(r[k] for k in key): bool(o) for r, o in zip(early, ok_e, strict=True)}
    for r in early:
        p = tuple(r[k] for k in key)
        f = by[p]
        got = (ok_e[p], bool(r["recovered"]), bool(r["fell"]), r["diverged"] is not None)
        want = (ok_f[p], bool(f["recovered"]), bool(f["fell"]), f["diverged"] is not None)
        if got != want:
            diffs.append((p, want, got, r["stop_reason"], r["stopped_at_s"]))
    n = len(early)
    sim_f = sum(r["simulated_time_s"] for r in full)
    sim_e = sum(r["simulated_time_s"] for r in early)
    reasons: dict = {}
    for r in early:
        reasons[r["stop_reason"]] = reasons.get(r["stop_reason"], 0) + 1
    print(f"grid {name}: {n} trials; load average {load1[0]:.1f} before, {load2[0]:.1f} after")
    print(
        f"  survived {sum(ok_f.values())} (full) / {sum(ok_e.values())} (early); recovered "
        f"{sum(bool(r['recovered']) for r in full)} / {sum(bool(r['recovered']) for r in early)}"
    )
    print(f"  outcome differences (survived, recovered, fell, diverged): {len(diffs)}")
    for d in diffs:
        print(f"    {d}")
    wf, we = walls[False][0], walls[True][0]
    print(
        f"  wall: full {wf:.1f} s ({walls[False][1]} run now), early stop {we:.1f} s "
        f"({walls[True][1]} run now): x{wf / we:.2f}"
        if we > 0
        else ""
    )
    cf, ce = walls[False][2], walls[True][2]
    print(
        f"  CPU (this process + workers): full {cf:.1f} s, early stop {ce:.1f} s: x{cf / max(ce, 1e-9):.2f}"
    )
    print(f"  simulated time: full {sim_f:.0f} s, early {sim_e:.0f} s (x{sim_f / max(sim_e, 1e-9):.2f})")
    print(f"  how the early-stop trials ended: {reasons}")
    at_rest = [r["stopped_at_s"] for r in early if r["stop_reason"] == "at_rest"]
    if at_rest:
        print(f"  at-rest stop times: median {np.median(at_rest):.2f} s, max {max(at_rest):.2f} s")
    return 1 if diffs else 0


if __name__ == "__main__":
    raise SystemExit(main())
