"""The stepping controller's knee-carried height drop (``SteppingConfig.knee_carried_drop``, issue
#23: >= 100 % of Hof's J_max from the front with human torque limits): the knee's lever for the
lowered hips against MuJoCo's kinematics of the lowered pose, the drop W's crouch and a 1.55 m /
50 kg subject get with human limits against the cited limits, and the 20 m/s front push with human
limits, which fell with the fixed 8 cm drops and now ends at rest."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from biped.control import leg_geometry


def _sweep_setup(speed, direction, *flags, model=None):
    """One `biped sweep --distribution qp --stepping` trial (hold task, 1.8 kg block at 1.2 m,
    fast physics, early stop, 4 s as docs/sweep.md's stepping envelopes): (scenario, setup)."""
    from biped.cli import build_parser
    from biped.cli.sweep import build_spec

    args = ["sweep", "--speed", str(speed), "--direction", str(direction), "--distribution", "qp"]
    args += ["--stepping", "--set", "duration_s=4", "--set", "qp_floor_friction=true"]
    if model is not None:
        args += ["--model", str(model)]
    spec = build_spec(build_parser().parse_args([*args, *flags]))
    trial = spec.trials()[0]
    return spec.scenario(trial), spec.setup(trial)


def _policy(setup, **over):
    """A fresh stepping controller of the trial (``over``: its SteppingConfig changed) and scene."""
    from dataclasses import replace

    from biped.sim.sweep.trial import _scene_for, make_policy

    scene = _scene_for(setup.scenario)
    pol = make_policy(setup, scene)
    if over:
        pol.stepping = replace(pol.stepping, **over)
        pol.reset()
    return pol, scene


def _first_call(setup, **over):
    """The trial's stepping controller (:func:`_policy`) after its first call at the initial
    state (where it sets its knee-carried drop), and that state's biped qpos."""
    from biped.sim.scene import initial_state

    pol, scene = _policy(setup, **over)
    qpos, qvel = initial_state(scene, setup.scenario)
    q = qpos[scene.biped_qpos_index]
    pol(0.0, q, qvel[scene.biped_qvel_index], (True, True))
    return pol, q


def _lowered_knee(pol, q0, leg: int, drop: float) -> np.ndarray:
    """MuJoCo's knee anchor with the floating base lowered by ``drop`` and the leg's hip flexion
    and knee solved (Newton, finite differences of MuJoCo's kinematics) to put the ankle anchor
    back where it stood; the ankle's dorsiflexion follows (it only turns the foot)."""
    m, d = pol.model, mujoco.MjData(pol.model)
    joints = pol.body.leg_joints[leg]
    hip_q, knee_q = (int(m.jnt_qposadr[m.joint(j).id]) for j in (joints[1], joints[3]))
    knee_j, ankle_j = m.joint(joints[3]).id, m.joint(joints[4]).id

    def ankle(q):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        return np.array(d.xanchor[ankle_j][[0, 2]])

    target = ankle(q0)
    q = np.array(q0, dtype=float)
    q[2] -= drop  # the free joint's z
    for _ in range(50):
        r = ankle(q) - target
        if np.linalg.norm(r) < 1e-12:
            break
        J = np.zeros((2, 2))
        for c, a in enumerate((hip_q, knee_q)):
            dq = np.array(q)
            dq[a] += 1e-7
            J[:, c] = (ankle(dq) - ankle(q)) / 1e-7
        step = np.linalg.solve(J, -r)
        q[hip_q] += step[0]
        q[knee_q] += step[1]
    assert np.linalg.norm(ankle(q) - target) < 1e-9
    return np.array(d.xanchor[knee_j])


def test_knee_lever_against_mujoco_kinematics_of_the_lowered_pose():
    """:func:`leg_geometry.knee_lever` for hips 0-8 cm lower equals the horizontal distance from
    MuJoCo's knee anchor of the lowered pose (base lowered, hip flexion and knee solved for the
    ankle to stay) to the end of the heel box (MuJoCo's geom, not the project's sole rectangles),
    and grows as the hips sink (W's crouch: the knee moves ahead of the foot)."""
    _, setup = _sweep_setup(8, 0, "--torque-limits", "human")
    pol, q0 = _first_call(setup)
    m = pol.model
    d = mujoco.MjData(m)
    d.qpos[:] = q0
    mujoco.mj_kinematics(m, d)
    heel = m.geom("left_heel").id
    heel_end = float(d.geom_xpos[heel][0] + m.geom_size[heel][0])  # W faces -x: the heel's +x end
    joints = pol.body.leg_joints[0]
    hip, knee = d.xpos[pol._hip[0]].copy(), d.xanchor[m.joint(joints[3]).id].copy()
    ankle = d.xanchor[m.joint(joints[4]).id].copy()
    c, yaw = pol._sole_pose(0)
    u = np.array([math.cos(yaw), math.sin(yaw)])
    ends = (float(u @ c[:2]) - pol._sole[0][1], float(u @ c[:2]) + pol._sole[0][1])
    levers = []
    for drop in (0.0, 0.02, 0.05, 0.08):
        k = _lowered_knee(pol, q0, 0, drop)
        lever = leg_geometry.knee_lever(hip, knee, ankle, u, ends, drop)
        assert lever == pytest.approx(heel_end - float(k[0]), abs=2e-4), drop
        levers.append(lever)
    assert np.all(np.diff(levers) > 0)


def test_knee_carried_drop_of_w_and_a_subject_with_human_limits(tmp_path):
    """With human torque limits (knee extension 3.2 N m/kg, limits.py's citation) W's crouch needs
    m g lever = 238 N m at the standing pose against the knee's 3.2 x 73.06 = 233.8 N m: no drop.
    A 1.55 m, 50 kg subject (``biped model``) needs 148 N m against 160 N m and may sink until
    the two are equal (between 0 and the fixed 8 cm). Without torque limits, or with the rule off:
    None, the fixed 8 cm drops (those runs unchanged)."""
    from biped.cli import main

    _, setup = _sweep_setup(8, 0, "--torque-limits", "human")
    pol, _ = _first_call(setup)
    g = pol._gravity
    assert pol.limits.upper[pol.joint_names.index("left_knee")] == pytest.approx(3.2 * 73.06, rel=1e-3)
    assert pol._knee_drop == 0.0
    assert pol._swing_drop(1) == 0.0 and pol._height_drop(0.4, 0.08) == 0.0
    _, free = _sweep_setup(8, 0)
    assert _first_call(free)[0]._knee_drop is None
    off, _ = _first_call(setup, knee_carried_drop=False)
    assert off._knee_drop is None and off._swing_drop(1) == 0.08 and off._height_drop(0.4, 0.08) == 0.08

    path = tmp_path / "f155.xml"
    assert main(["model", "--stature", "1.55", "--mass", "50", "--sex", "female", "--out", str(path)]) == 0
    _, sub = _sweep_setup(8, 0, "--torque-limits", "human", model=path)
    spol, q0 = _first_call(sub)
    drop = spol._knee_drop
    assert 0.0 < drop < 0.08
    tau = spol.limits.upper[spol.joint_names.index("left_knee")]
    assert tau == pytest.approx(3.2 * 50.0, rel=1e-3)
    # at the drop MuJoCo's lowered pose puts the knee where m g lever is the knee's limit
    d = mujoco.MjData(spol.model)
    d.qpos[:] = q0
    mujoco.mj_kinematics(spol.model, d)
    heel = spol.model.geom("left_heel").id
    heel_end = float(d.geom_xpos[heel][0] + spol.model.geom_size[heel][0])
    k = _lowered_knee(spol, q0, 0, drop)
    assert spol._mass * g * (heel_end - float(k[0])) == pytest.approx(tau, rel=2e-3)


@pytest.mark.slow
def test_front_push_of_hofs_bound_with_human_limits_ends_at_rest():
    """20 m/s from the front with human torque limits, an impulse above Hof's feet-in-place bound
    for that direction (J_max from MuJoCo's COM and sole corners, biped.analysis): with the
    knee-carried drop (none for W's crouch) the stance knee holds the body up (the central body's
    COM no lower than 2.5 cm below its start in the first swing) and the run ends at rest over
    the final feet (the strict rule, 4 s) after two backward steps (Hof et al. 2010: people are
    done within two). With the fixed 8 cm drops (the rule off) the stance knee sat at its limit,
    the body sank over 10 cm in the first swing and fell (measured: 1.55 s, after three steps)."""
    from biped.analysis import feet_in_place_bound
    from biped.sim.push import run_closed_loop
    from biped.sim.sweep.trial import measure

    sc, setup = _sweep_setup(20, 0, "--torque-limits", "human")
    j_max = float(feet_in_place_bound([0.0], sc).j_max_n_s[0])
    runs = {}
    for on in (True, False):
        pol, scene = _policy(setup, knee_carried_drop=on)
        r = run_closed_loop(sc, scene, pol)
        steps = pol.steps
        first = (r.times >= steps[0]["start_s"]) & (r.times < steps[0]["touch_down_s"])
        runs[on] = (r, float(r.com[0, 2] - r.com[first, 2].min()))
    r, sink = runs[True]
    assert measure(r, np.asarray(r.block_velocity)).impulse_horizontal_n_s > j_max  # (Hof: horizontal)
    assert r.recovered and not r.fell and r.extra["final_com_speed_m_s"] < 0.05
    assert len(r.extra["steps"]) == 2 and not any(st["sideways"] for st in r.extra["steps"])
    assert sink < 0.025, sink
    old, old_sink = runs[False]
    assert old.fell and not old.recovered and old_sink > 0.10, old_sink


@pytest.mark.slow
def test_human_limit_push_compiled_is_the_python_loop():
    """The 20 m/s front push with human limits (knee-carried drop, two steps) in the compiled
    loop (double support compiled, the swings in Python) against the Python loop: the same
    states, steps and outcome bit for bit."""
    from test_sim_fused import assert_same

    from biped.sim.push import run_closed_loop

    sc, setup = _sweep_setup(20, 0, "--torque-limits", "human")
    runs = []
    for compiled in (True, False):
        pol, scene = _policy(setup)
        runs.append((run_closed_loop(sc, scene, pol, compiled=compiled), pol._knee_drop))
    (a, da), (b, db) = runs
    assert da == db == 0.0
    assert len(a.extra["steps"]) == 2 and a.extra["steps"] == b.extra["steps"]
    assert a.recovered and a.stop_reason == b.stop_reason
    assert_same(a, b)
