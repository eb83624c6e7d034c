"""The single support's height drop (issue #23, stance slip; ``SteppingConfig.swing_drop_ramp``):
the stance set point 8 cm lower at once at a swing's start asks W's height gain for ~16 m/s^2
down, the stance foot is unloaded and slides; reached along a minimum-jerk path over the swing it
stays loaded. Measured on MuJoCo's contact forces (the floor's normal force on the stance sole's
geoms) in W's goal push, and on the controller's own set point."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from _helpers import goal_push_scenario, qp_stepping, run_qp_stepping

from biped.control import capture as cp

#: Set B of docs/sweep.md ("The swing leg in the stance model"): the stance model and the swing
#: reaction on forward and backward steps, their single-support friction 0.35 mu, sideways 0.55.
SET_B = {
    "stance_contact_model": True,
    "lateral_stance_contact_model": False,
    "swing_reaction": True,
    "lateral_swing_reaction": False,
    "swing_friction_scale": 0.35,
    "lateral_swing_friction_scale": 0.55,
}


def _sole_forces(m, d, soles: dict, c6: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's floor force on each sole's geoms (``soles``: geom id -> 0 left, 1 right) after a
    step: (normal |world z|, tangential |world xy|) [N] per sole."""
    fn, ft = np.zeros(2), np.zeros(2)
    for k in range(d.ncon):
        con = d.contact[k]
        g = con.geom1 if con.geom1 in soles else (con.geom2 if con.geom2 in soles else None)
        if g is None:
            continue
        mujoco.mj_contactForce(m, d, k, c6)
        f = con.frame.reshape(3, 3).T @ c6[:3]
        fn[soles[g]] += abs(f[2])
        ft[soles[g]] += np.hypot(f[0], f[1])
    return fn, ft


def _goal_push(**params):
    """W's goal push (4 kg at 8 m/s from behind, faithful physics, 4 s), stepping with the
    ``"qp"`` set and ``params``: (result, per step (foot, start_s), times, normal forces (n, 2)
    on the left and right soles [N] after every control period)."""
    from biped.sim.scene import build_scene

    sc = goal_push_scenario()
    scene = build_scene(sc)
    m = scene.model
    soles = {m.geom(f"{s}_{p}").id: k for k, s in enumerate(("left", "right")) for p in ("heel", "toe")}
    times, normal = [], []
    c6 = np.zeros(6)

    def on_step(m, d):
        fn = _sole_forces(m, d, soles, c6)[0]
        times.append(d.time)
        normal.append(fn)

    r = run_qp_stepping(sc, scene, on_step=on_step, **params)
    steps = [(st["foot"], st["start_s"]) for st in r.extra["steps"]]
    return r, steps, np.array(times), np.array(normal), float(np.sum(m.body_mass[1:]))


def _stance_load(steps, times, normal, weight):
    """Per step: the stance sole's mean normal force over the swing's first 0.1 s / the weight."""
    out = []
    for foot, t0 in steps:
        k = 1 - ("left", "right").index(foot)
        sel = (times > t0) & (times <= t0 + 0.1)
        out.append(float(normal[sel, k].mean()) / weight)
    return out


@pytest.mark.slow
def test_the_ramped_drop_keeps_the_stance_foot_loaded_in_the_goal_push():
    """Set B: at the third swing's start the stance set point drops by a new 8 cm at once; MuJoCo's
    normal force on the stance sole then averages under 0.3 of the weight over the swing's first
    0.1 s (measured 0.15), the foot slides and the run falls. With the drop ramped over the swing
    every swing's stance sole carries over half the weight there (measured 0.9-1.4) and the
    push is recovered by the strict rule."""
    r, steps, t, fn, m = _goal_push(**SET_B)
    weight = m * 9.81
    load = _stance_load(steps, t, fn, weight)
    assert r.fell and len(steps) == 3, (r.fell, steps)
    assert load[2] < 0.3, load
    r, steps, t, fn, m = _goal_push(**SET_B, swing_drop_ramp=True, lateral_swing_drop_ramp=False)
    load = _stance_load(steps, t, fn, weight)
    assert r.recovered and r.extra["final_com_speed_m_s"] < 0.05, r.extra
    assert min(load) > 0.5, load


def test_the_ramped_drop_is_a_minimum_jerk_path_from_the_set_point():
    """The single support's set point with ``swing_drop_ramp``: at the swing's start the double
    support's height (no step), at the planned swing time the full drop, between them the drop
    times the minimum-jerk profile, its rate and acceleration in the target's velocity and
    acceleration (checked against central differences of the height)."""
    from biped.control.policy import PolicyConfig
    from biped.control.stepping import SteppingController
    from biped.control.stepping_config import SteppingConfig

    ctl = SteppingController(
        PolicyConfig(distribution="qp"), SteppingConfig.for_trigger("qp", swing_drop_ramp=True)
    )
    m, d = ctl.model, ctl.data
    mujoco.mj_resetData(m, d)
    q, v = d.qpos.copy(), np.zeros(m.nv)
    ctl(0.0, q, v, (True, True))  # first call: the standing references
    ctl._start_step(0.0, np.array(ctl.set_point_com[:2]), (True, True))
    seen = {}
    real = ctl._ctrl_swing.torques

    def spy(qpos, qvel, target=None, gains=None, feet_in_contact=None):
        seen["target"] = target
        return real(qpos, qvel, target=target, gains=gains, feet_in_contact=feet_in_contact)

    ctl._ctrl_swing.torques = spy
    T = ctl._T
    drop = ctl._swing_drop(ctl.swing)
    assert drop > 0.01
    z0 = ctl.target.com[2]

    def height(el):
        ctl._swing_el = el
        mujoco.mj_forward(m, d)
        ctl._single_support(
            ctl.swing, q, v, 3.0, np.zeros(2), d.xpos[ctl._foot[ctl.swing]], np.zeros(3), np.zeros(3)
        )
        tg = seen["target"]
        return tg.com[2], tg.com_vel[2], tg.com_acc[2]

    assert height(0.0)[0] == pytest.approx(z0, abs=1e-12)
    assert height(T)[0] == pytest.approx(z0 - drop, abs=1e-12)
    assert height(2 * T)[0] == pytest.approx(z0 - drop, abs=1e-12)
    h = 1e-5
    for s in (0.2, 0.5, 0.8):
        z, vz, az = height(s * T)
        assert z == pytest.approx(z0 - drop * cp.min_jerk(s)[0], abs=1e-12)
        zp, zm = height(s * T + h)[0], height(s * T - h)[0]
        assert vz == pytest.approx((zp - zm) / (2 * h), rel=1e-5)
        assert az == pytest.approx((zp - 2 * z + zm) / h**2, rel=1e-3)


def test_crossover_side_takes_only_its_three_rules():
    """``crossover_side`` (the traced crossover's side, docs/sweep.md): a one-line error names the
    valid values."""
    from biped.control.stepping_config import SteppingConfig
    from biped.errors import ScenarioError

    for ok in ("retarget", "start", "near"):
        assert SteppingConfig(crossover_side=ok).crossover_side == ok
    with pytest.raises(
        ScenarioError, match="crossover_side must be 'retarget', 'start' or 'near'; got 'ahead'"
    ):
        SteppingConfig(crossover_side="ahead")


@pytest.mark.slow
def test_the_135_deg_hop_load_is_the_whipped_legs_bias_wrench_and_real():
    """The `"qp"` set at 135 deg 16 m/s (fast physics): its second step, a crossover, plans over
    two body weights of vertical force early in the swing (traced: 1.7 kN). Of the plan's
    ``F_1^bd = P_1 X^b + z_1`` it is W Alg. 3's bias ``z_1`` (over 90 % of it), not the set
    point's feedback: ``z_1`` with every velocity zero is about the weight (its gravity part), so
    the rest is the velocity products of the whipped swing leg and spinning body. MuJoCo agrees
    the load is real: its normal force on the stance sole exceeds 2.5 body weights in the same
    window, and its tangential force reaches mu times it (the sole slides)."""
    from test_stance_slip import _sweep_scenario

    from biped.sim.push import run_closed_loop
    from biped.sim.scene import build_scene

    sc = _sweep_scenario(16, 135)
    scene = build_scene(sc)
    ctl = qp_stepping(sc, scene)
    swing_qp = ctl._ctrl_swing_by_mode[True]
    names = ("tau", "P1", "z1", "X", "Fd")
    plan = []
    real = swing_qp.torques

    def spy(qpos, qvel, target=None, gains=None, feet_in_contact=None):
        tau = real(qpos, qvel, target=target, gains=gains, feet_in_contact=feet_in_contact)
        if len(ctl.steps) == 2 and ctl._cross:
            f = {n: swing_qp._out[sl].copy() for n, (sl, _) in zip(names, swing_qp._fields, strict=False)}
            R = ctl.data.ximat[ctl._root].reshape(3, 3)
            still = ctl._ctrl_before.compute(qpos, np.zeros_like(qvel), feet_in_contact=feet_in_contact)
            plan.append((len(times), (R @ f["Fd"][:3])[2], (R @ f["z1"][:3])[2], (R @ still.z1[:3])[2]))
        return tau

    swing_qp.torques = spy
    m = scene.model
    soles = {m.geom(f"{s}_{p}").id: k for k, s in enumerate(("left", "right")) for p in ("heel", "toe")}
    times, normal, tangential = [], [], []
    c6 = np.zeros(6)

    def on_step(m, d):
        fn, ft = _sole_forces(m, d, soles, c6)
        times.append(d.time)
        normal.append(fn)
        tangential.append(ft)

    run_closed_loop(sc, scene, ctl, on_step=on_step)
    st = ctl.steps[1]
    assert st["crossover"] and st["foot"] == "left", ctl.steps
    weight = float(ctl._mass) * 9.81
    early = [p for p in plan if p[0] - plan[0][0] < 60]  # the swing's first 60 ms
    k, fz, z1, z1_still = max(early, key=lambda p: p[1])
    assert fz > 2.0 * weight, (fz, weight)
    assert z1 > 0.9 * fz and abs(z1_still - weight) < 0.2 * weight, (fz, z1, z1_still, weight)
    rows = slice(early[0][0], early[-1][0] + 1)
    n, t = np.array(normal)[rows, 1], np.array(tangential)[rows, 1]  # the right (stance) sole
    assert n.max() > 2.5 * weight, n.max() / weight
    assert np.max(t / np.maximum(n, 1.0)) > 0.29, np.max(t / np.maximum(n, 1.0))
