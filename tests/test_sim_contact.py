"""Contact physics of the push scene measured in MuJoCo: restitution and friction of the real pairs.

The calibration (biped.sim.contact) only ever sees a 1 kg sphere; these tests measure the
coefficient of restitution e = -v_n,after / v_n,before and the friction limit on the scene's own
geoms: the 73 kg biped (made rigid in W's initial posture) landing flat on its four sole boxes, the
1.8 kg block thrown at the trunk, the block and the biped's soles on a tilted floor.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from biped.sim.scenario import JOINT_NAMES, Scenario
from biped.sim.scene import scene_spec
from biped.spatial import axis_angle_quat, quat_mul

E_TOL = 0.05


def _delete(spec, obj):
    spec.delete(obj)


def rigid_biped_spec(scenario: Scenario, slides=("z",), gravity=(0.0, 0.0, 0.0), keep_block=False):
    """The push scene with the biped frozen in W's initial posture (each hinge's angle baked into
    its body's orientation, the hinge removed) on slide joints along ``slides`` (no rotation)."""
    spec = scene_spec(scenario)
    angles = dict(zip(JOINT_NAMES, np.radians(scenario.initial_joint_angles_deg)))
    for name, angle in angles.items():
        j = spec.joint(name)
        body = j.parent
        q = quat_mul(np.array(body.quat, dtype=float), axis_angle_quat(np.array(j.axis, dtype=float), angle))
        body.quat = list(q)
        _delete(spec, j)
    for k in list(spec.keys):
        _delete(spec, k)
    for a in list(spec.actuators):
        _delete(spec, a)
    cb = spec.body("central_body")
    _delete(spec, spec.joint("root"))
    cb.pos = list(scenario.initial_com_m)
    cb.quat = list(axis_angle_quat(np.array([0.0, -1.0, 0.0]), math.radians(scenario.initial_tilt_deg)))
    for ax in slides:
        cb.add_joint(name=f"slide_{ax}", type=mujoco.mjtJoint.mjJNT_SLIDE,
                     axis=[float(ax == c) for c in "xyz"])
    if not keep_block:
        _delete(spec, spec.body("block"))
    spec.option.gravity = list(gravity)
    return spec


def _sole_bottom(model, data):
    ids = [model.geom(n).id for n in ("left_heel", "left_toe", "right_heel", "right_toe")]
    return min(data.geom_xpos[g, 2] - np.abs(data.geom_xmat[g].reshape(3, 3))[2] @ model.geom_size[g]
               for g in ids)


def _bounce(model, data, normal_velocity, max_steps=20000):
    """Step until contact is made and lost again; returns the normal velocity after."""
    touched = False
    for _ in range(max_steps):
        mujoco.mj_step(model, data)
        if data.ncon:
            touched = True
        elif touched:
            return normal_velocity(data)
    raise AssertionError("no separation after the impact")


@pytest.mark.parametrize("speed", [0.5, 2.0])
def test_restitution_foot_floor(speed):
    """The rigid 73 kg biped lands flat on its soles: e = 0.2 +- 0.05 (W's e)."""
    s = Scenario()
    model = rigid_biped_spec(s).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    gap = _sole_bottom(model, data)
    assert 0.001 < gap < 0.01  # W: "slightly above the ground"
    data.qvel[0] = -speed
    e = _bounce(model, data, lambda d: d.qvel[0]) / speed
    assert abs(e - s.restitution) < E_TOL, e


@pytest.mark.parametrize("mass", [1.8, 10.0])
def test_restitution_block_body(mass):
    """The block thrown square at the fixed trunk: e = 0.2 +- 0.05, for two block masses."""
    s = Scenario(block_mass_kg=mass)
    spec = scene_spec(s)
    spec.delete(spec.joint("root"))  # the central body is welded where the MJCF puts it
    for k in list(spec.keys):
        spec.delete(k)
    spec.option.gravity = [0.0, 0.0, 0.0]
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    cb = model.body("central_body").id
    trunk = model.geom("trunk").id
    R = data.xmat[cb].reshape(3, 3)
    n = R[:, 0]  # outward normal of the trunk's back face
    back = data.geom_xpos[trunk] + n * model.geom_size[trunk, 0]
    half = s.block_size_m[0] / 2
    bq = model.jnt_qposadr[model.joint("block_root").id]
    bv = model.jnt_dofadr[model.joint("block_root").id]
    data.qpos[bq:bq + 3] = back + n * (half + 0.002)
    data.qpos[bq + 3:bq + 7] = data.xquat[cb]  # faces parallel to the trunk's
    speed = 4.5
    data.qvel[bv:bv + 3] = -speed * n
    v_after = _bounce(model, data, lambda d: d.qvel[bv:bv + 3] @ n)
    e = v_after / speed
    assert abs(e - s.restitution) < E_TOL, e
    assert abs(data.qvel[bv + 3:bv + 6]).max() < 0.5  # a square hit: the block does not tumble


def _slope_gravity(tan_slope: float) -> list:
    th = math.atan(tan_slope)
    return [9.81 * math.sin(th), 0.0, -9.81 * math.cos(th)]


@pytest.mark.parametrize("tan_slope, slides", [(0.25, False), (0.40, True)])
def test_friction_block_on_floor(tan_slope, slides):
    """The block on a floor tilted by atan(tan_slope) (gravity tilted instead): it sticks below
    mu = 0.3 and slides above with a = g (sin - mu cos) (Coulomb)."""
    s = Scenario()
    spec = scene_spec(s)
    spec.body("block").pos = [2.0, 2.0, s.block_size_m[2] / 2 - 0.0005]
    spec.option.gravity = _slope_gravity(tan_slope)
    for k in list(spec.keys):
        spec.delete(k)
    spec.delete(spec.joint("root"))  # keep the biped out of the way: welded in the air
    model = spec.compile()
    data = mujoco.MjData(model)
    bq = model.jnt_qposadr[model.joint("block_root").id]
    mujoco.mj_forward(model, data)
    for _ in range(int(0.2 / model.opt.timestep)):  # settle
        mujoco.mj_step(model, data)
    x0, t0 = data.qpos[bq], data.time
    v0 = data.qvel[model.jnt_dofadr[model.joint("block_root").id]]
    T = 0.5
    for _ in range(int(T / model.opt.timestep)):
        mujoco.mj_step(model, data)
    dx = data.qpos[bq] - x0
    th = math.atan(tan_slope)
    if not slides:
        assert abs(dx) < 1e-3, dx
    else:
        a = 9.81 * (math.sin(th) - s.friction * math.cos(th))
        expected = v0 * T + 0.5 * a * T**2
        assert dx == pytest.approx(expected, rel=0.05), (dx, expected)
        assert data.time - t0 == pytest.approx(T, abs=2 * model.opt.timestep)


@pytest.mark.parametrize("tan_slope, slides", [(0.25, False), (0.40, True)])
def test_friction_feet_on_floor(tan_slope, slides):
    """The rigid biped standing on its soles (translation only) on a tilted floor: sticks below
    mu = 0.3, slides above with a = g (sin - mu cos)."""
    s = Scenario()
    th = math.atan(tan_slope)
    model = rigid_biped_spec(s, slides=("x", "y", "z"), gravity=_slope_gravity(tan_slope)).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for _ in range(int(0.2 / model.opt.timestep)):  # land and settle
        mujoco.mj_step(model, data)
    x0, v0 = data.qpos[0], data.qvel[0]
    T = 0.5
    for _ in range(int(T / model.opt.timestep)):
        mujoco.mj_step(model, data)
    dx = data.qpos[0] - x0
    if not slides:
        assert abs(dx) < 1e-3, dx
    else:
        a = 9.81 * (math.sin(th) - s.friction * math.cos(th))
        assert dx == pytest.approx(v0 * T + 0.5 * a * T**2, rel=0.05)


def test_calibration_matches_closed_form_without_clipping_trend():
    """Sanity of the calibration's direction: more damping, less bounce (measured), and e = 0.2
    needs more damping than the two-sided spring-damper's closed form z = 0.456 because MuJoCo
    releases the contact when its force reaches zero."""
    from biped.sim.contact import dampratio_for_restitution

    z02 = dampratio_for_restitution(0.2, 0.005, 0.0005)
    z04 = dampratio_for_restitution(0.4, 0.005, 0.0005)
    closed_form = -math.log(0.2) / math.sqrt(math.pi**2 + math.log(0.2) ** 2)
    assert z04 < z02
    assert closed_form == pytest.approx(0.456, abs=1e-3)
    assert z02 > closed_form
