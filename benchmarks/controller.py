"""Speed of W's controller (one call = W Alg. 1-6) next to Pinocchio and MuJoCo on the same model.

    python benchmarks/controller.py [--calls 20000] [--rounds 5]

Prints the median and 99th percentile of the wall time per call [us] of
- ``WorkspaceController.compute`` (all outputs as fresh arrays in a ControllerOutput),
- ``WorkspaceController.torques`` (the hot path: torques only, a view of the controller's buffer),
- ``pinocchio.aba`` (articulated-body forward dynamics), ``pinocchio.rnea`` (inverse dynamics) and
  ``mujoco.mj_forward`` on the same MJCF file (W's biped, no floor: no contacts),
each called from Python, with the ratio of medians to ``pin.aba`` measured in the same run. The
calls are interleaved in rounds so that a change in machine load affects all alike. Then checks
that the hot path allocates nothing (tracemalloc over 1000 calls) and reports the numba compile
time of this process (zero when the cache in ``__pycache__`` was warm).
"""

from __future__ import annotations

import argparse
import os
import platform
import time
import tracemalloc

import mujoco
import numpy as np

_t = time.perf_counter()
from biped import models  # noqa: E402 (import time is measured)
from biped.control import WorkspaceController  # noqa: E402

t_import = time.perf_counter() - _t


def per_call_us(fn, calls: int) -> np.ndarray:
    out = np.empty(calls)
    clock = time.perf_counter_ns
    for i in range(calls):
        t0 = clock()
        fn()
        out[i] = clock() - t0
    return out / 1e3


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=20000, help="timed calls per function (>= 10^4)")
    ap.add_argument("--rounds", type=int, default=5, help="interleaved rounds the calls are split into")
    args = ap.parse_args(argv)

    path = str(models.path("wendlandt"))
    m = mujoco.MjModel.from_xml_path(path)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    qpos = m.key_qpos[m.key("wendlandt_initial").id].copy()
    qvel = rng.normal(0.0, 0.3, m.nv)
    d.qpos[:], d.qvel[:] = qpos, qvel

    t0 = time.perf_counter()
    ctrl = WorkspaceController.from_mjcf(path)
    ctrl.compute(qpos, qvel)  # compiles, or loads numba's cache
    t_first = time.perf_counter() - t0

    fns = {
        "controller.compute": lambda: ctrl.compute(qpos, qvel),
        "controller.torques": lambda: ctrl.torques(qpos, qvel),
        "mujoco.mj_forward": lambda: mujoco.mj_forward(m, d),
    }
    try:
        import pinocchio as pin

        pm = pin.buildModelFromMJCF(path)
        pd = pm.createData()
        q = pin.randomConfiguration(pm, -np.ones(pm.nq), np.ones(pm.nq))
        v, tau = rng.normal(size=pm.nv), rng.normal(size=pm.nv)
        fns["pin.aba"] = lambda: pin.aba(pm, pd, q, v, tau)
        fns["pin.rnea"] = lambda: pin.rnea(pm, pd, q, v, tau)
    except ImportError:
        print("pinocchio is not installed: no reference; pip install pin")

    for fn in fns.values():  # warm up
        for _ in range(1000):
            fn()
    per_round = max(1, args.calls // args.rounds)
    samples = {name: [] for name in fns}
    for _ in range(args.rounds):
        for name, fn in fns.items():
            samples[name].append(per_call_us(fn, per_round))
    stats = {name: np.concatenate(s) for name, s in samples.items()}

    print(f"W's biped ({m.nbody - 1} bodies, {m.nv} DOF), {per_round * args.rounds} calls each, "
          f"{platform.python_implementation()} {platform.python_version()}, "
          f"{platform.machine()}, {os.cpu_count()} cores")
    ref = np.median(stats["pin.aba"]) if "pin.aba" in stats else None
    print(f"{'call':22s} {'median [us]':>12s} {'p99 [us]':>10s} {'/ pin.aba':>10s}")
    for name, s in stats.items():
        ratio = f"{np.median(s) / ref:10.2f}" if ref else f"{'-':>10s}"
        print(f"{name:22s} {np.median(s):12.2f} {np.percentile(s, 99):10.2f} {ratio}")
    print("W (1997): 7000 us per control call on a 100 MHz SGI R4000")

    # no allocation on the hot path: traced memory after 1000 and after 10000 more calls
    fn = fns["controller.torques"]
    tracemalloc.start()
    for _ in range(10):
        fn()
    base = tracemalloc.get_traced_memory()[0]
    growth = []
    for calls in (1000, 10000):
        for _ in range(calls):
            fn()
        growth.append(tracemalloc.get_traced_memory()[0] - base)
    peak = tracemalloc.get_traced_memory()[1] - base
    tracemalloc.stop()
    print(f"hot path traced memory growth: {growth[0]} bytes after 1000 calls, {growth[1]} bytes after "
          f"11000 (peak {peak} bytes above the start)")
    print(f"first call (numba compile or cache load): {t_first:.2f} s; import of biped.control: "
          f"{t_import:.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
