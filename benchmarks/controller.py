"""Speed of W's controller (one call = W Alg. 1-6) next to Pinocchio and MuJoCo on the same model.

    python benchmarks/controller.py [--calls 20000] [--rounds 5] [--push 7]
    python benchmarks/controller.py --model g1   # a robot (docs/robots.md) instead of W's biped

Prints the median and 99th percentile of the wall time per call [us] of
- ``WorkspaceController.compute`` (all outputs as fresh arrays in a ControllerOutput),
- ``WorkspaceController.torques`` (the hot path: torques only, a view of the controller's buffer),
- ``pinocchio.aba`` (articulated-body forward dynamics), ``pinocchio.rnea`` (inverse dynamics) and
  ``mujoco.mj_forward`` on the same MJCF file (W's biped, no floor: no contacts),
each called from Python, with the ratio of medians to ``pin.aba`` measured in the same run, and
the contact-feasible QP distribution (``distribution="qp"``): ``compute``/``torques`` with daqp
(the default) and ``torques`` with quadprog, the QP solve alone with each solver on the same built
problem, and the ratio of the
qp ``torques`` call to the min-norm (``statics``) one. The calls are interleaved in rounds so that a
change in machine load affects all alike. With ``--push N``: W's default push (faithful physics,
3 s) closed loop with statics and with qp, in the compiled loop and in the Python loop, interleaved
N times, median wall and CPU times and their ratio (goal <= 1.3x). Then checks
that the hot path allocates nothing (tracemalloc over 1000 calls) and reports the numba compile
time of this process (zero when the cache in ``__pycache__`` was warm).
"""

from __future__ import annotations

import argparse
import functools
import os
import platform
import time
import tracemalloc
from collections.abc import Callable

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


def sampled(fns: dict, calls: int, rounds: int) -> tuple[int, dict[str, np.ndarray]]:
    """Each of ``fns`` warmed up (1000 calls), then ``rounds`` rounds of ``calls // rounds`` timed
    calls of each in turn (interleaved: a slow spell of the machine hits every one alike):
    (calls per round, the per-call times [us] by name)."""
    for fn in fns.values():  # warm up
        for _ in range(1000):
            fn()
    per_round = max(1, calls // rounds)
    samples: dict[str, list] = {name: [] for name in fns}
    for _ in range(rounds):
        for name, fn in fns.items():
            samples[name].append(per_call_us(fn, per_round))
    return per_round, {name: np.concatenate(s) for name, s in samples.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=20000, help="timed calls per function (>= 10^4)")
    ap.add_argument("--rounds", type=int, default=5, help="interleaved rounds the calls are split into")
    ap.add_argument(
        "--push",
        type=int,
        default=0,
        metavar="N",
        help="also time W's default push closed loop, statics vs qp, N times each",
    )
    ap.add_argument("--model", help="a robot's name or MJCF path (docs/robots.md) instead of W's biped")
    ap.add_argument(
        "--state",
        choices=("standing", "random", "still"),
        default="standing",
        help="--model's state: standing (feet still: leg velocities from a random root twist; "
        "default), random (random leg velocities too: the feet move), still (zero velocity)",
    )
    args = ap.parse_args(argv)
    if args.model:
        return robot_bench(args)

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

    qp = {
        name: WorkspaceController.from_mjcf(path, distribution="qp", qp_solver=name)
        for name in ("quadprog", "daqp")
    }
    for c in qp.values():
        c.compute(qpos, qvel)
    qpq, qpd = qp["quadprog"].qp, qp["daqp"].qp
    fns = {
        "controller.compute": lambda: ctrl.compute(qpos, qvel),
        "controller.torques": lambda: ctrl.torques(qpos, qvel),
        "qp.compute": lambda: qp["daqp"].compute(qpos, qvel),
        "qp.torques": lambda: qp["daqp"].torques(qpos, qvel),
        "qp.torques (quadprog)": lambda: qp["quadprog"].torques(qpos, qvel),
        "qp solve (quadprog)": qpq._solve_once,
        "qp solve (daqp)": qpd._solve_once,
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

    per_round, stats = sampled(fns, args.calls, args.rounds)

    print(
        f"W's biped ({m.nbody - 1} bodies, {m.nv} DOF), {per_round * args.rounds} calls each, "
        f"{platform.python_implementation()} {platform.python_version()}, "
        f"{platform.machine()}, {os.cpu_count()} cores"
    )
    ref = np.median(stats["pin.aba"]) if "pin.aba" in stats else None
    print(f"{'call':22s} {'median [us]':>12s} {'p99 [us]':>10s} {'/ pin.aba':>10s}")
    for name, s in stats.items():
        ratio = f"{np.median(s) / ref:10.2f}" if ref else f"{'-':>10s}"
        print(f"{name:22s} {np.median(s):12.2f} {np.percentile(s, 99):10.2f} {ratio}")
    print("W (1997): 7000 us per control call on a 100 MHz SGI R4000")
    med = {name: float(np.median(s)) for name, s in stats.items()}
    print(
        f"qp / statics (torques): {med['qp.torques'] / med['controller.torques']:.2f}x; the QP adds "
        f"{med['qp.torques'] - med['controller.torques']:.1f} us (goal: qp call <= 50 us median)"
    )
    print(
        f"QP solve alone: quadprog {med['qp solve (quadprog)']:.1f} us, daqp "
        f"{med['qp solve (daqp)']:.1f} us (daqp / quadprog "
        f"{med['qp solve (daqp)'] / med['qp solve (quadprog)']:.2f}); same solution: max |dx| = "
        f"{np.max(np.abs(qpq._solve_once() - qpd._solve_once())):.1e} N or N m"
    )

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
    print(
        f"hot path traced memory growth: {growth[0]} bytes after 1000 calls, {growth[1]} bytes after "
        f"11000 (peak {peak} bytes above the start)"
    )
    print(
        f"first call (numba compile or cache load): {t_first:.2f} s; import of biped.control: "
        f"{t_import:.2f} s"
    )
    if args.push:
        push_ratio(args.push)
    return 0


def standing_velocity(m, d, desc, tree, qpos, rng) -> np.ndarray:
    """A velocity of the robot standing: a random floating-body twist (0.1 m/s, rad/s) and the leg
    joint velocities that keep both feet still (each leg's 6 x 6 Jacobian solved, MuJoCo's
    ``mj_jacBody``); the held joints still."""
    qvel = np.zeros(m.nv)
    r = tree.dof_adr[0]
    qvel[r : r + 6] = rng.normal(0.0, 0.1, 6)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    legs = np.asarray(tree.dof_adr[1:])
    for foot in desc.feet:
        jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        mujoco.mj_jacBody(m, d, jp, jr, m.body(foot).id)
        J = np.vstack([jp, jr])
        mine = [a for a in legs if abs(J[:, a]).sum() > 0]
        qvel[mine] = np.linalg.solve(J[:, mine], -J[:, r : r + 6] @ qvel[r : r + 6])
    return qvel


def robot_bench(args) -> int:
    """The controller on a robot's folded tree against Pinocchio on the same tree and on the file."""
    import tempfile

    import pinocchio as pin

    from biped.control.setpoint import Target
    from biped.models.robot import ROBOTS, controller_spec, describe, robot_path
    from biped.sim.robot import robot_controller, standing_qpos
    from biped.spatial import rot_to_quat

    path = robot_path(args.model) if args.model in ROBOTS else args.model
    desc = describe(path)
    t0 = time.perf_counter()
    ctrls = {dist: robot_controller(desc, dist) for dist in ("qp", "statics")}
    ctrls["qp, no limits"] = robot_controller(desc, "qp", "none")
    tree = ctrls["qp"].tree
    rng = np.random.default_rng(0)
    qpos = standing_qpos(desc, ctrls["qp"])
    g0 = ctrls["qp"].link_poses(qpos)[0]
    for c in ctrls.values():  # the standing set point, as robot_push (without it: W's, 1.035 m high)
        c.target = Target(com=tuple(g0[:3, 3]), quat=tuple(rot_to_quat(np.ascontiguousarray(g0[:3, :3]))))
    m = mujoco.MjModel.from_xml_path(str(desc.path))
    d = mujoco.MjData(m)
    qvel = standing_velocity(m, d, desc, tree, qpos, rng) if args.state == "standing" else np.zeros(tree.nv)
    if args.state == "random":  # random leg velocities: the feet move, which standing excludes
        qvel[tree.dof_adr[0] : tree.dof_adr[0] + 6] = rng.normal(0.0, 0.1, 6)
        qvel[tree.dof_adr[1:]] = rng.normal(0.0, 0.3, len(tree.dof_adr) - 1)
    for c in ctrls.values():
        c.compute(qpos, qvel)  # compiles, or loads numba's cache
    t_first = time.perf_counter() - t0
    qp = ctrls["qp"].qp
    x, _, flag, info = qp._daqp(qp.Gq, -qp.av, qp.Ct, qp._upper, qp.b, qp._sense)
    act = int(np.sum(np.abs(qp.Ct[: qp.rows] @ x - qp.b[: qp.rows]) < 1e-7))
    print(
        f"state {args.state}: the QP with limits: {qp.rows} rows, daqp {info['iterations']} iterations, "
        f"{act} active rows, normal forces {x[2]:.1f} and {x[8]:.1f} N (weight {desc.mass * 9.81:.1f} N)"
    )
    d.qpos[:], d.qvel[:] = qpos, rng.normal(0.0, 0.3, m.nv)
    spec = controller_spec(desc)
    spec.compile()  # fuses the jointless bodies; to_xml then writes the fused tree
    with tempfile.TemporaryDirectory() as tmp:  # the folded tree as MuJoCo wrote it after fusing
        folded_xml = os.path.join(tmp, "folded.xml")
        with open(folded_xml, "w") as f:
            f.write(spec.to_xml())
        pf = pin.buildModelFromMJCF(folded_xml)
    pw = pin.buildModelFromMJCF(str(desc.path))
    mass = {
        "controller tree": float(tree.mass.sum()),
        "pin folded": float(sum(i.mass for i in pf.inertias)),
        "pin file": float(sum(i.mass for i in pw.inertias)),
    }
    fns: dict[str, Callable[[], object]] = {
        "qp.torques": lambda: ctrls["qp"].torques(qpos, qvel),
        "qp.compute": lambda: ctrls["qp"].compute(qpos, qvel),
        "qp.torques, no limits": lambda: ctrls["qp, no limits"].torques(qpos, qvel),
        "statics.torques": lambda: ctrls["statics"].torques(qpos, qvel),
        "mujoco.mj_forward (file)": lambda: mujoco.mj_forward(m, d),
    }
    for name, pm in (("folded", pf), ("file", pw)):
        pd = pm.createData()
        q = pin.neutral(pm)
        v, tau = rng.normal(0.0, 0.3, pm.nv), rng.normal(size=pm.nv)
        fns[f"pin.aba ({name})"] = functools.partial(pin.aba, pm, pd, q, v, tau)
        fns[f"pin.rnea ({name})"] = functools.partial(pin.rnea, pm, pd, q, v, tau)
    load0 = os.getloadavg()[0]  # before the warm-up (~1 s) and the rounds
    per_round, stats = sampled(fns, args.calls, args.rounds)
    print(
        f"{desc.path.name} ({desc.mass:.2f} kg): folded tree {pf.nv} DOF ({tree.nv} in the file's "
        f"layout), whole file {pw.nv} DOF; masses [kg] {', '.join(f'{k} {v:.2f}' for k, v in mass.items())}; "
        f"{per_round * args.rounds} calls each, load average {load0:.1f} -> {os.getloadavg()[0]:.1f}, "
        f"{platform.python_implementation()} {platform.python_version()}, {os.cpu_count()} cores"
    )
    ref = np.median(stats["pin.aba (folded)"])
    ref10 = np.percentile(stats["pin.aba (folded)"], 10)  # the quiet calls: the 10th percentiles
    print(
        f"{'call':26s} {'median [us]':>12s} {'p10 [us]':>9s} {'p99 [us]':>10s} {'/ pin.aba (folded)':>19s} "
        f"{'p10 / p10':>10s}"
    )
    for name, s in stats.items():
        p10 = np.percentile(s, 10)
        print(
            f"{name:26s} {np.median(s):12.2f} {p10:9.2f} {np.percentile(s, 99):10.2f} "
            f"{np.median(s) / ref:19.2f} {p10 / ref10:10.2f}"
        )
    print(
        f"goal: the controller call <= 2x pin.aba on the same model: qp.torques "
        f"{np.median(stats['qp.torques']) / ref:.2f}x (10th percentiles "
        f"{np.percentile(stats['qp.torques'], 10) / ref10:.2f}x), statics.torques "
        f"{np.median(stats['statics.torques']) / ref:.2f}x (against pin.aba on the whole file: "
        f"{np.median(stats['qp.torques']) / np.median(stats['pin.aba (file)']):.2f}x)"
    )
    print(f"first calls (numba compile or cache load, model folding): {t_first:.2f} s")
    return 0


def push_ratio(repeat: int) -> None:
    """W's default push (scenario defaults, faithful physics) closed loop with the min-norm split,
    with the QP (daqp, the default) and with the QP solved by quadprog, all in the compiled loop
    (``biped.sim.fused``; the QP's solve in Python through objmode), and the statics and qp runs
    in the Python loop (``compiled=False``, what they cost before), interleaved ``repeat`` times:
    median wall and thread-CPU times, their ratios to the compiled statics run, and the thread CPU
    per controller call inside the Python loop (the QP's active set there is not the one at the
    initial state)."""
    from biped.control.distribution import ContactQP
    from biped.sim import Scenario, build_scene, fused
    from biped.sim.push import controller_policy, run_closed_loop

    runs, per_call = {}, {}
    for name, dist, compiled in (
        ("statics", "statics", True),
        ("qp", "qp", True),
        ("qp (quadprog)", "qp", True),
        ("statics, Python", "statics", False),
        ("qp, Python", "qp", False),
    ):
        sc = Scenario(distribution=dist)
        scene = build_scene(sc)
        policy = controller_policy(sc, scene)
        if name == "qp (quadprog)":
            ctrl = policy.policy.controller
            q = ctrl.qp
            ctrl.qp = ContactQP(
                ctrl.tree,
                q.soles,
                q.weights,
                q._lo if q.limited else None,
                q._hi if q.limited else None,
                solver="quadprog",
            )
        assert not compiled or fused.fused_controller(policy) is not None, name
        acc = per_call[name] = [0.0, 0]

        def timed(t, qpos, qvel, feet, policy=policy, acc=acc):
            c = time.thread_time()
            out = policy(t, qpos, qvel, feet)
            acc[0] += time.thread_time() - c
            acc[1] += 1
            return out

        # compile, warm caches; 0.1 s: the feet are down from 0.034 s on, so the QP's first solve
        # (loading numba's objmode glue, ~0.1 s once per process) is not timed
        run_closed_loop(sc.with_overrides(duration_s=0.1), scene, policy, compiled=compiled)
        runs[name] = (sc, scene, policy, timed, compiled)
    wall = {k: [] for k in runs}
    cpu = {k: [] for k in runs}
    for i in range(repeat + 1):
        for k, (sc, scene, policy, timed, compiled) in runs.items():
            if i == repeat:  # one more run, timing the controller calls inside the (Python) loop
                res = run_closed_loop(sc, scene, timed)
                continue
            t0, c0 = time.perf_counter(), time.thread_time()
            res = run_closed_loop(sc, scene, policy, compiled=compiled)
            wall[k].append(time.perf_counter() - t0)
            cpu[k].append(time.thread_time() - c0)
            assert res.recovered, f"W's push with {k!r} did not recover"
    med = {k: float(np.median(v)) for k, v in wall.items()}
    medc = {k: float(np.median(v)) for k, v in cpu.items()}
    print(
        f"W's push closed loop (3 s, faithful physics), median of {repeat}, interleaved "
        f"(load average {os.getloadavg()[0]:.1f}: the machine is shared, wall times move with "
        f"other work; thread CPU is the steadier figure); without ', Python': the compiled loop:"
    )
    print(
        f"{'':16s} {'wall [ms]':>10s} {'/ statics':>10s} {'CPU [ms]':>10s} {'/ statics':>10s} "
        f"{'CPU per controller call, Python loop [us]':>42s}"
    )
    for k in runs:
        print(
            f"{k:16s} {med[k] * 1e3:10.0f} {med[k] / med['statics']:10.2f} {medc[k] * 1e3:10.0f} "
            f"{medc[k] / medc['statics']:10.2f} {per_call[k][0] / per_call[k][1] * 1e6:42.1f}"
        )
    print(
        f"goal: qp / statics <= 1.3 (both compiled): wall {med['qp'] / med['statics']:.2f}, "
        f"CPU {medc['qp'] / medc['statics']:.2f}; Python loop qp / statics: wall "
        f"{med['qp, Python'] / med['statics, Python']:.2f}, CPU {medc['qp, Python'] / medc['statics, Python']:.2f}"
    )


if __name__ == "__main__":
    raise SystemExit(main())
