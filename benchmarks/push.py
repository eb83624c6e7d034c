"""Speed of W's push experiment: the closed loop against MuJoCo's own stepping of the same run.

In one process and one run: the scenario (default W's) closed loop (``biped.sim.push``'s loop:
contact monitor, controller, records, MuJoCo; the controller built outside the timer; for W's
controller the compiled loop of ``biped.sim.fused``), the same closed loop in the Python loop
(``compiled=False``, what it cost before the compiled loop), then a
**physics-only** rollout of the same scene from the same initial state driven by the torques the
closed loop recorded, two ways: ``mj_step(m, d, substeps)`` in a bare Python loop that sets
``ctrl`` once per control period, and ``mujoco.rollout`` (no Python at all per step). Both
reproduce the closed loop's final state bit for bit (checked and printed), so they do exactly the
same physics work. Also the Python loop driven by the recorded torques (:class:`RecordedTorques`:
contact monitor, records and foot poses, no controller), which splits the Python loop's overhead
into its bookkeeping and the controller. The five are interleaved ``--repeat`` times; the medians of wall time and of
thread CPU time (less sensitive to other work on a shared machine) are printed with real-time
factors and the ratios closed loop / physics-only. Goals: closed loop <= 1.25x the bare
``mj_step`` loop (``physics = "faithful"``); >= 30x real time with ``--physics fast``.
W's 3 s run took 2066 s on a 100 MHz SGI R4000 (0.0015x real time).

    python benchmarks/push.py [--repeat 7] [--physics faithful|fast] [--distribution statics|printed|qp]
                              [--set KEY=VALUE ...] [--paradigms]

``--paradigms``: instead, the compiled closed loop of each perturbation paradigm
(docs/perturbations.md; block = W's run, force 60 N x 0.15 s, platform 5 cm in 0.3 s, release
4 deg, pull 5 cm at 0.4 m/s) on the same preset, interleaved, medians, and each one's cost over the block's
(goal <= 1.2x); also the ratio of the fastest runs (less moved by other work on a shared machine);
a run that ends early (falls or diverges) is flagged: its cost is not comparable.

``--stepping``: instead, sweep trials with capture-point stepping (``biped sweep --distribution qp
--stepping``, 1.8 kg block at 1.2 m, early stop off, ``--duration`` s, ``--trigger``): a push that
steps (``--step-push``, default 14 m/s from the side) and one that does not (``--hold-push``,
8 m/s from the side), each with stepping in the compiled loop (the default) and in the Python
loop, against the feet-in-place trial of the hold push (the same length: it holds): interleaved,
medians of thread CPU time, each one's ratio to the feet-in-place trial (issue #23: a stepping
trial <= 1.3x); also the ratio of the fastest runs (less moved by other work on a shared machine),
and the controller's share: each round's trial less its own physics replay, and the step trial's
ratio with its physics at the feet-in-place trial's cost (MuJoCo's own extra work on a step taken
out). ``--phases``: and where the step trial's rows go (thread CPU a row of the compiled loop's
double support and swing stretches and of the Python periods, and the same rows' physics in a bare
replay).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import mujoco
import numpy as np
from mujoco import rollout

from biped.sim import Scenario, build_scene
from biped.sim.push import RecordedTorques, controller_policy, run_closed_loop
from biped.sim.scenario import parse_assignment
from biped.sim.scene import initial_state


def _timed(fn):
    w, c = time.perf_counter(), time.thread_time()
    out = fn()
    return out, time.perf_counter() - w, time.thread_time() - c


def _warm(sc, scene, compiled=None) -> None:
    """A short run of ``sc`` outside the timers (compiles, warms: the QP's first solve)."""
    run_closed_loop(sc.with_overrides(duration_s=0.1), scene, controller_policy(sc, scene), compiled=compiled)


def _interleaved(cases, repeat, after=None):
    """``repeat`` rounds of one timed closed loop of each case (name: (scenario, scene, compiled)),
    its controller built outside the timer; ``after(name, scenario, scene, result)`` runs after
    each, outside the timer. Returns the last results, and the wall and thread-CPU times [s] of
    every round, by name."""
    results: dict = {}
    wall: dict = {k: [] for k in cases}
    cpu: dict = {k: [] for k in cases}
    for _ in range(repeat):
        for name, (sc, scene, compiled) in cases.items():
            policy = controller_policy(sc, scene)  # built outside the timer
            results[name], w, c = _timed(lambda: run_closed_loop(sc, scene, policy, compiled=compiled))  # noqa: B023
            wall[name].append(w)
            cpu[name].append(c)
            if after is not None:
                after(name, sc, scene, results[name])
    return results, wall, cpu


def physics_loop(scenario, scene, torques, steps):
    """The bare reference: same scene and initial state, ``ctrl`` set per control period,
    ``mj_step`` for the period's substeps; returns the final data."""
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = initial_state(scene, scenario)
    mujoco.mj_forward(m, d)
    act, sub = scene.actuator_index, scenario.control_substeps
    for k in range(steps):
        d.ctrl[act] = torques[k]
        mujoco.mj_step(m, d, sub)
    return d


def physics_rollout(scenario, scene, torques, steps, data):
    """The same with ``mujoco.rollout`` (the whole run in C); returns the final qpos."""
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = initial_state(scene, scenario)
    mujoco.mj_forward(m, d)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    x0 = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, x0, spec)
    ctrl = np.zeros((steps, m.nu))
    ctrl[:, scene.actuator_index] = torques[:steps]
    ctrl = np.repeat(ctrl, scenario.control_substeps, axis=0)
    state, _ = rollout.rollout(m, data, x0, ctrl)
    return state[0, -1, 1 : 1 + m.nq]  # FULLPHYSICS = (time, qpos, qvel, ...)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--physics", choices=("faithful", "fast"), default="faithful")
    ap.add_argument(
        "--distribution",
        choices=("statics", "printed", "qp"),
        default="statics",
        help="W's controller's wrench distribution (qp: its solve runs in Python inside the compiled loop)",
    )
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--paradigms", action="store_true", help="time every perturbation paradigm instead")
    ap.add_argument(
        "--stepping", action="store_true", help="time stepping trials against feet in place instead"
    )
    ap.add_argument("--trigger", choices=("qp", "capture"), default="qp", help="--stepping: step_trigger")
    ap.add_argument("--step-push", default="14,90", help="--stepping: speed [m/s],direction [deg] that steps")
    ap.add_argument("--hold-push", default="8,90", help="--stepping: speed,direction held feet in place")
    ap.add_argument("--duration", type=float, default=4.0, help="--stepping: trial length [s]")
    ap.add_argument("--phases", action="store_true", help="--stepping: and where the step trial's rows go")
    args = ap.parse_args()
    if args.paradigms:
        paradigms(args)
        return
    if args.stepping:
        stepping(args)
        return
    scenario = Scenario(physics=args.physics, distribution=args.distribution)
    scenario = scenario.with_overrides(**dict(parse_assignment(a) for a in args.set))
    scene = build_scene(scenario)
    policy = controller_policy(scenario, scene)
    result = run_closed_loop(
        scenario.with_overrides(duration_s=0.1), scene, policy
    )  # compile, warm (QP: a solve)
    rdata = mujoco.MjData(scene.model)

    run_closed_loop(scenario.with_overrides(duration_s=0.02), scene, policy, compiled=False)
    runs = {"closed": [], "python": [], "replay": [], "loop": [], "rollout": []}
    cpu = {k: [] for k in runs}
    for _ in range(args.repeat):
        result, w, c = _timed(lambda: run_closed_loop(scenario, scene, policy))
        runs["closed"].append(w)
        cpu["closed"].append(c)
        py, w, c = _timed(lambda: run_closed_loop(scenario, scene, policy, compiled=False))
        runs["python"].append(w)
        cpu["python"].append(c)
        assert np.array_equal(py.qpos, result.qpos) and py.events == result.events
        steps = len(result.times) - 1  # the closed loop steps after every row but the last
        tq = result.torques
        replay = RecordedTorques(tq, scenario.control_rate_hz)
        _, w, c = _timed(lambda: run_closed_loop(scenario, scene, replay))  # noqa: B023
        runs["replay"].append(w)
        cpu["replay"].append(c)
        d, w, c = _timed(lambda: physics_loop(scenario, scene, tq, steps))  # noqa: B023
        runs["loop"].append(w)
        cpu["loop"].append(c)
        q_loop = d.qpos.copy()
        q_roll, w, c = _timed(lambda: physics_rollout(scenario, scene, tq, steps, rdata))  # noqa: B023
        runs["rollout"].append(w)
        cpu["rollout"].append(c)
    sim_time = result.times[-1]
    same_loop = np.array_equal(q_loop, result.qpos[-1])
    same_roll = np.array_equal(q_roll, result.qpos[-1])
    med = {k: statistics.median(v) for k, v in runs.items()}
    medc = {k: statistics.median(v) for k, v in cpu.items()}
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"python {platform.python_version()}, mujoco {mujoco.__version__}; load average "
        f"{load:.1f} at the end (the machine is shared: wall times move with other work)"
    )
    print(
        f"scenario: physics {scenario.physics!r} ({scenario.physics_timestep_s * 1e3:g} ms step, "
        f"contact time constant {scenario.contact_timeconst_s * 1e3:g} ms"
        f"{', sleep' if scenario.sleep else ''}{', one box a sole' if scenario.sole_box else ''})"
        f", control {scenario.control_rate_hz:g} Hz, "
        f"controller {scenario.controller} ({scenario.distribution}), simulated {sim_time:.3f} s of "
        f"{scenario.duration_s:g} s"
        + (
            ""
            if sim_time >= scenario.duration_s - 1e-9
            else f" (the run ended early: fell={result.fell}, diverged={bool(result.diverged)})"
        )
    )
    print(
        f"physics-only reproduces the closed loop's final state exactly: bare loop {same_loop}, "
        f"rollout {same_roll}"
    )
    print(f"median of {args.repeat}        wall [ms]  x real time   thread CPU [ms]  x real time")
    names = {
        "closed": "closed loop",
        "python": "closed loop, Python loop",
        "replay": "Python loop, recorded torques",
        "loop": "physics only, mj_step loop",
        "rollout": "physics only, mujoco.rollout",
    }
    for k, name in names.items():
        print(
            f"  {name:30s} {med[k] * 1e3:8.1f}  {sim_time / med[k]:8.1f}    "
            f"{medc[k] * 1e3:10.1f}    {sim_time / medc[k]:8.1f}"
        )
    print(
        f"ratio closed loop / physics-only (mj_step loop): wall {med['closed'] / med['loop']:.3f}, "
        f"CPU {medc['closed'] / medc['loop']:.3f}   (goal <= 1.25 on faithful)"
    )
    print(
        f"ratio closed loop / physics-only (rollout):      wall "
        f"{med['closed'] / med['rollout']:.3f}, CPU {medc['closed'] / medc['rollout']:.3f}"
    )
    print(
        f"closed loop: {sim_time / med['closed']:.1f}x real time wall, "
        f"{sim_time / medc['closed']:.1f}x on CPU time (goal >= 30x with --physics fast)"
    )
    print(
        f"per control period: closed loop {medc['closed'] / steps * 1e6:.1f} us CPU, physics "
        f"{medc['loop'] / steps * 1e6:.1f} us, the difference (controller, contact monitor, "
        f"records) {(medc['closed'] - medc['loop']) / steps * 1e6:.1f} us"
    )
    print(
        f"  the Python loop (compiled=False, the same result bit for bit): "
        f"{(medc['python'] - medc['loop']) / steps * 1e6:.1f} us, of which bookkeeping (contact "
        f"monitor, records, foot poses; the loop replaying the torques) "
        f"{(medc['replay'] - medc['loop']) / steps * 1e6:.1f} us and the controller "
        f"{(medc['python'] - medc['replay']) / steps * 1e6:.1f} us; closed loop / Python loop "
        f"{medc['closed'] / medc['python']:.3f}"
    )
    print(f"W (1997): 3 s in 2066 s = {3 / 2066:.4f}x real time")


#: the paradigms' runs of --paradigms (small moves; with --distribution qp every one recovers and
#: simulates its 3 s; with W's min-norm split the release and the pull diverge and are flagged)
PARADIGM_RUNS = {
    "block": {},
    "force": {"perturbation": "force"},
    "platform": {"perturbation": "platform", "platform_displacement_m": (0.05, 0.0)},
    "release": {"perturbation": "release", "release_lean_deg": 4.0},
    "pull": {"perturbation": "pull", "pull_displacement_m": (-0.05, 0.0)},
}


def paradigms(args) -> None:
    """Wall and thread-CPU medians of the compiled closed loop of each paradigm, and each one's
    ratio to the block's (W's run) on the same preset."""
    base = Scenario(physics=args.physics, distribution=args.distribution)
    base = base.with_overrides(**dict(parse_assignment(a) for a in args.set))
    setups = {}
    for name, keys in PARADIGM_RUNS.items():
        sc = base.with_overrides(**keys)
        scene = build_scene(sc)
        _warm(sc, scene)
        setups[name] = (sc, scene, None)
    results, wall, cpu = _interleaved(setups, args.repeat)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; load average "
        f"{load:.1f} at the end (shared machine); physics {base.physics!r}, distribution "
        f"{base.distribution!r}, {base.duration_s:g} s runs, median of {args.repeat}"
    )
    print("  paradigm    wall [ms]  CPU [ms]  CPU / block's  min CPU / block's  simulated [s]  recovered")
    ref, ref_min = statistics.median(cpu["block"]), min(cpu["block"])
    for name in setups:
        r = results[name]
        mc = statistics.median(cpu[name])
        print(
            f"  {name:10s} {statistics.median(wall[name]) * 1e3:9.1f} {mc * 1e3:9.1f} {mc / ref:12.3f}"
            f"   {min(cpu[name]) / ref_min:16.3f}   {r.times[-1]:12.3f}  {r.recovered}"
        )
    short = [n for n in setups if results[n].times[-1] < base.duration_s - 1e-9]
    for name in short:  # e.g. release and pull with W's min-norm split (docs/perturbations.md)
        r = results[name]
        print(
            f"  {name}: the run ended at {r.times[-1]:.3f} s (fell={r.fell}, diverged="
            f"{bool(r.diverged)}): its cost is not that of a {base.duration_s:g} s run, not comparable"
        )
    print("goal: every paradigm <= 1.2x the block's run (issue #20)")


def _sweep_trial(push: str, args, stepping: bool):
    """One ``biped sweep --distribution qp`` trial of ``push`` ("speed,direction"), early stop off."""
    from biped.cli import build_parser
    from biped.cli.sweep import build_spec

    speed, direction = push.split(",")
    argv = [
        "sweep",
        "--speed",
        speed,
        "--direction",
        direction,
        "--distribution",
        "qp",
        "--physics",
        args.physics,
    ]
    argv += ["--set", f"duration_s={args.duration}", "--set", "early_stop=false"]
    argv += ["--set", f'step_trigger="{args.trigger}"'] + (["--stepping"] if stepping else [])
    argv += [x for a in args.set for x in ("--set", a)]
    spec = build_spec(build_parser().parse_args(argv))
    return spec.scenario(spec.trials()[0])


def stepping(args) -> None:
    """Thread-CPU medians of stepping trials (compiled loop and Python loop) and their ratio to the
    feet-in-place trial of the same length (see the module docstring); then the controller's share
    (each trial less its own physics replay) and where the step trial's rows go (``phases``)."""
    cases = {
        "feet in place, hold push": (_sweep_trial(args.hold_push, args, False), None),
        "stepping, hold push": (_sweep_trial(args.hold_push, args, True), None),
        "stepping, step push": (_sweep_trial(args.step_push, args, True), None),
        "stepping, hold push, Python loop": (_sweep_trial(args.hold_push, args, True), False),
        "stepping, step push, Python loop": (_sweep_trial(args.step_push, args, True), False),
    }
    setups = {}
    for name, (sc, compiled) in cases.items():
        scene = build_scene(sc)
        _warm(sc, scene, compiled)
        setups[name] = (sc, scene, compiled)
    phys: dict = {k: [] for k in cases}  # the bare mj_step loop driven by the trial's torques

    def physics(name, sc, scene, r) -> None:
        phys[name].append(_timed(lambda: physics_loop(sc, scene, r.torques, len(r.times) - 1))[2])

    results, _, cpu = _interleaved(setups, args.repeat, physics)
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    sc0 = cases["feet in place, hold push"][0]
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; load average "
        f"{load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} at the end (shared machine); physics {sc0.physics!r} "
        f"(sole boxes: feet in place {sc0.sole_box}, stepping {cases['stepping, step push'][0].sole_box}), "
        f"step_trigger {args.trigger!r}, {args.duration:g} s trials, median of {args.repeat}"
    )
    ref = statistics.median(cpu["feet in place, hold push"])
    ref_p = statistics.median(phys["feet in place, hold push"])
    print(
        "  trial                                CPU [ms]  / feet in place   physics only [ms]  / feet in place's"
        "  trial / its physics  min / feet in place's min  simulated [s]  steps  recovered"
    )
    ref_min = min(cpu["feet in place, hold push"])
    for name in cases:
        r = results[name]
        mc, mp = statistics.median(cpu[name]), statistics.median(phys[name])
        fastest = min(cpu[name]) / ref_min
        print(
            f"  {name:36s} {mc * 1e3:8.1f} {mc / ref:12.3f}   {mp * 1e3:14.1f} {mp / ref_p:14.3f}   {mc / mp:18.3f}"
            f"   {fastest:24.3f}   {r.times[-1]:12.3f}  {len(r.extra.get('steps', ())):5d}  {r.recovered}"
        )
    a, b = results["stepping, step push"], results["stepping, step push, Python loop"]
    same = np.array_equal(a.qpos, b.qpos) and a.extra["steps"] == b.extra["steps"]
    print(f"the step push's compiled run is the Python loop's bit for bit: {same}")
    # the controller's share: each round's trial less its own physics replay (same round), medians
    print("the controller's share (each round's trial CPU less its physics replay's; medians):")
    own = {k: statistics.median(c - p for c, p in zip(cpu[k], phys[k], strict=True)) for k in cases}
    for name in ("feet in place, hold push", "stepping, hold push", "stepping, step push"):
        print(f"  {name:36s} {own[name] * 1e3:7.1f} ms")
    step, fip = "stepping, step push", "feet in place, hold push"
    dphys = statistics.median(phys[step]) - ref_p
    print(
        f"  the step trial costs {statistics.median(cpu[step]) / ref:.3f}x the feet-in-place trial; its physics "
        f"{dphys * 1e3:+.1f} ms of that ({statistics.median(phys[step]) / ref_p:.3f}x), the controller "
        f"{(own[step] - own[fip]) * 1e3:+.1f} ms; the trial with the step's physics at the feet-in-place "
        f"trial's cost: {(statistics.median(cpu[step]) - dphys) / ref:.3f}x"
    )
    print("goal: a stepping trial <= 1.3x a feet-in-place trial of the same length (issue #23)")
    if args.phases:
        for name in (fip, step):
            phases(name, setups[name][0], setups[name][1], args.repeat)


def phases(name, sc, scene, repeat) -> None:
    """Where trial ``name``'s rows go: the compiled loop's calls (rows of double support and of
    the plain swing, :mod:`biped.control.swing_period`), the Python periods (the policy's call),
    and the same rows' physics in a bare ``mj_step`` replay; thread CPU per row, medians of
    ``repeat``, and per kind of row the loop's cost beyond its physics."""
    from biped.sim import fused as fused_mod
    from biped.sim import push as push_mod

    acc: dict = {}
    real_run = fused_mod.FusedRows.run

    def timed_run(self, k0, k1):
        t = time.thread_time_ns()
        k, why = real_run(self, k0, k1)
        st = self._stepping
        swing = st is not None and getattr(st, "plan", None) is not None and st.plan.ints[-1]  # its I_ON
        kind = "swing" if swing else "double support"
        if kind != "swing" and st is not None:
            kind += ", after a step" if st.policy.steps else ", before"
        rows = k - k0 + (1 if why not in (fused_mod.DONE, fused_mod.PYTHON) else 0)
        if rows > 0:
            acc.setdefault(kind, []).append((time.thread_time_ns() - t, rows))
        for j in range(k0, k):
            kinds[j] = kind
        return k, why

    fused_mod.FusedRows.run = timed_run  # type: ignore[method-assign]
    per: dict = {}
    phys: dict = {}
    try:
        for _ in range(repeat):
            acc.clear()
            policy = controller_policy(sc, scene)
            real_call = type(policy).__call__
            n = sc.control_steps + 1
            kinds = ["python"] * n

            def call(self, t, q, v, feet, real_call=real_call):
                w = time.thread_time_ns()
                out = real_call(self, t, q, v, feet)
                acc.setdefault("python", []).append((time.thread_time_ns() - w, 1))
                return out

            type(policy).__call__ = call  # type: ignore[method-assign]
            try:
                r = push_mod.run_closed_loop(sc, scene, policy)
            finally:
                type(policy).__call__ = real_call  # type: ignore[method-assign]
            for key, v in acc.items():
                per.setdefault(key, []).append((sum(x for x, _ in v), sum(y for _, y in v)))
            # the physics of the same rows, replayed
            m = scene.model
            d = mujoco.MjData(m)
            d.qpos[:], d.qvel[:] = initial_state(scene, sc)
            mujoco.mj_forward(m, d)
            act, sub = scene.actuator_index, sc.control_substeps
            tot: dict = {}
            for k in range(len(r.times) - 1):
                d.ctrl[act] = r.torques[k]
                w = time.thread_time_ns()
                mujoco.mj_step(m, d, sub)
                x = tot.setdefault(kinds[k], [0, 0])
                x[0] += time.thread_time_ns() - w
                x[1] += 1
            for key, (ns, rows) in tot.items():
                phys.setdefault(key, []).append((ns, rows))
    finally:
        fused_mod.FusedRows.run = real_run  # type: ignore[method-assign]
    print(f"where the {name} trial's rows go (thread CPU a row, median of {repeat}):")
    print(
        "  rows                                   rows   loop [us]   physics alone [us]   loop less physics [us]"
    )
    for key, v in per.items():
        us = statistics.median(ns / rows / 1e3 for ns, rows in v)
        ph = statistics.median(ns / rows / 1e3 for ns, rows in phys.get(key, [(0, 1)]))
        if key == "python":  # (its loop time is the policy's call alone)
            print(f"  {'python: the policy':38s} {v[0][1]:5d}   {us:9.1f}   {ph:18.1f}   {'-':>22s}")
        else:
            print(f"  {'compiled ' + key:38s} {v[0][1]:5d}   {us:9.1f}   {ph:18.1f}   {us - ph:22.1f}")


if __name__ == "__main__":
    main()
