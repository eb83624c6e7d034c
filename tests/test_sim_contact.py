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

from biped.sim import simulate
from biped.sim.contact import SOLE_GEOMS, ContactEvent, ContactMonitor, heel_timeline
from biped.sim.scenario import JOINT_NAMES, Scenario
from biped.sim.scene import build_scene, initial_state, scene_spec
from biped.sim.sweep import SweepSpec, hold_scenario
from biped.spatial import axis_angle_quat, quat_mul

E_TOL = 0.05
PRESETS = ("faithful", "fast")  # every contact test runs on both physics presets


def _delete(spec, obj):
    spec.delete(obj)


def rigid_biped_spec(scenario: Scenario, slides=("z",), gravity=(0.0, 0.0, 0.0), keep_block=False):
    """The push scene with the biped frozen in W's initial posture (each hinge's angle baked into
    its body's orientation, the hinge removed) on slide joints along ``slides`` (no rotation)."""
    spec = scene_spec(scenario)
    angles = dict(zip(JOINT_NAMES, np.radians(scenario.initial_joint_angles_deg), strict=True))
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
        cb.add_joint(
            name=f"slide_{ax}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[float(ax == c) for c in "xyz"]
        )
    if not keep_block:
        _delete(spec, spec.body("block"))
    spec.option.gravity = list(gravity)
    return spec


def _sole_bottom(model, data):
    ids = [model.geom(n).id for n in ("left_heel", "left_toe", "right_heel", "right_toe")]
    return min(
        data.geom_xpos[g, 2] - np.abs(data.geom_xmat[g].reshape(3, 3))[2] @ model.geom_size[g] for g in ids
    )


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


@pytest.mark.parametrize("physics", PRESETS)
@pytest.mark.parametrize("speed", [0.5, 2.0])
def test_restitution_foot_floor(speed, physics):
    """The rigid 73 kg biped lands flat on its soles: e = 0.2 +- 0.05 (W's e)."""
    s = Scenario(physics=physics)
    model = rigid_biped_spec(s).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    gap = _sole_bottom(model, data)
    assert 0.001 < gap < 0.01  # W: "slightly above the ground"
    data.qvel[0] = -speed
    e = _bounce(model, data, lambda d: d.qvel[0]) / speed
    assert abs(e - s.restitution) < E_TOL, e


@pytest.mark.parametrize("physics", PRESETS)
@pytest.mark.parametrize("mass", [1.8, 10.0])
def test_restitution_block_body(mass, physics):
    """The block thrown square at the fixed trunk: e = 0.2 +- 0.05, for two block masses."""
    s = Scenario(block_mass_kg=mass, physics=physics)
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
    data.qpos[bq : bq + 3] = back + n * (half + 0.002)
    data.qpos[bq + 3 : bq + 7] = data.xquat[cb]  # faces parallel to the trunk's
    speed = 4.5
    data.qvel[bv : bv + 3] = -speed * n
    v_after = _bounce(model, data, lambda d: d.qvel[bv : bv + 3] @ n)
    e = v_after / speed
    assert abs(e - s.restitution) < E_TOL, e
    assert abs(data.qvel[bv + 3 : bv + 6]).max() < 0.5  # a square hit: the block does not tumble


def _slope_gravity(tan_slope: float) -> list:
    th = math.atan(tan_slope)
    return [9.81 * math.sin(th), 0.0, -9.81 * math.cos(th)]


@pytest.mark.parametrize("physics", PRESETS)
@pytest.mark.parametrize("tan_slope, slides", [(0.25, False), (0.40, True)])
def test_friction_block_on_floor(tan_slope, slides, physics):
    """The block on a floor tilted by atan(tan_slope) (gravity tilted instead): it sticks below
    mu = 0.3 and slides above with a = g (sin - mu cos) (Coulomb)."""
    s = Scenario(physics=physics)
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


@pytest.mark.parametrize("physics", PRESETS)
@pytest.mark.parametrize("tan_slope, slides", [(0.25, False), (0.40, True)])
def test_friction_feet_on_floor(tan_slope, slides, physics):
    """The rigid biped standing on its soles (translation only) on a tilted floor: sticks below
    mu = 0.3, slides above with a = g (sin - mu cos)."""
    s = Scenario(physics=physics)
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


# ---------------------------------------------------------------------------------------------
# events: the compiled ContactMonitor against a plain reference


class ReferenceMonitor:
    """The contact classification as first written (a role per geom, every contact looked at in
    Python), from MuJoCo's ``geom1`` / ``geom2`` arrays one contact at a time, independently of
    :class:`biped.sim.contact.ContactMonitor`'s pair table and compiled OR. A foot's one
    collision box (physics "fast") stands for the heel or the toe box nearer the contact point
    along the foot (MuJoCo's ``geom_xpos`` / ``geom_xmat`` of the two boxes)."""

    def __init__(self, model, scene, fall_height_m):
        self.model, self.floor, self.block = model, scene.floor_geom, scene.block_geom
        self.sole = {g: i for i, g in enumerate(scene.sole_geoms)}
        self.boxes = {}  # one collision box -> (heel geom, toe geom)
        names = [model.geom(g).name for g in range(model.ngeom)]
        for foot in ("left", "right"):
            if f"{foot}_sole_box" in names:
                heel = model.geom(f"{foot}_heel").id
                toe = model.geom(f"{foot}_toe").id
                self.boxes[model.geom(f"{foot}_sole_box").id] = (heel, toe)
        self.biped = set(scene.biped_geoms) - {self.floor, self.block}
        self.central, self.fall_height = scene.central_body, fall_height_m
        self.flags = [False] * 4
        self.rows, self.events = [], []
        self.block_time = self.fall_time = self.fall_reason = None

    def update(self, t, d):
        flags, block, lying = [False] * 4, False, None
        for j in range(d.ncon):
            a, b = int(d.contact.geom1[j]), int(d.contact.geom2[j])
            for x, y in ((a, b), (b, a)):
                if x == self.floor and y in self.sole:
                    flags[self.sole[y]] = True
                elif x == self.floor and y in self.boxes:
                    gap = {}  # how far the contact lies beyond each box's ends along the foot
                    for g in self.boxes[y]:
                        along = (d.geom_xmat[g].reshape(3, 3).T @ (d.contact.pos[j] - d.geom_xpos[g]))[0]
                        gap[g] = max(0.0, abs(along) - self.model.geom_size[g][0])
                    flags[self.sole[min(gap, key=gap.get)]] = True
                elif x == self.floor and y in self.biped and lying is None:
                    lying = self.model.geom(y).name
                if x == self.block and y in self.biped:
                    block = True
        if self.rows:
            for i, (old, new) in enumerate(zip(self.flags, flags, strict=True)):
                if old != new:
                    foot, part = SOLE_GEOMS[i]
                    self.events.append(
                        ContactEvent(round(float(t), 9), foot, part, "touch_down" if new else "lift_off")
                    )
        self.flags = flags
        self.rows.append(flags)
        if block and self.block_time is None:
            self.block_time = float(t)
        if self.fall_time is None:
            z = d.xipos[self.central, 2]
            if lying is not None:
                self.fall_time, self.fall_reason = float(t), f"{lying} touched the floor"
            elif z < self.fall_height:
                self.fall_time = float(t)
                self.fall_reason = f"central-body COM at {z:.3f} m, below {self.fall_height} m"


def _sweep_scenario(controller, speed, direction, duration):
    base = hold_scenario(Scenario(controller=controller, duration_s=duration))
    spec = SweepSpec(axes={"speed_m_s": speed, "direction_deg": direction}, base=base)
    return spec.scenario(spec.trials()[0])


@pytest.mark.slow
@pytest.mark.parametrize(
    "scenario, ends",
    [
        (Scenario(), "recovered"),  # W's run
        (Scenario(physics="fast", duration_s=2.0), "recovered"),  # the block falls asleep ~1.5 s
        (_sweep_scenario("workspace", 9.0, 0.0, 0.5), "left_shank touched"),  # a shank on the floor
        (_sweep_scenario("joint-pd", 9.0, 180.0, 1.6), "central-body COM"),  # sinks below 0.6 m
        (_sweep_scenario("workspace", 3.0, 90.0, 0.5), "diverged"),  # MuJoCo gives up
    ],
    ids=["w", "w-fast", "sweep-shank", "sweep-com", "sweep-diverged"],
)
def test_monitor_events_are_the_reference_classification(scenario, ends):
    """Every period of a closed-loop run, the compiled monitor (inside the loop) and the plain
    reference (fed the same MjData after every control period) agree exactly: per-period sole
    flags, every foot event (time, foot, part, kind), the first block hit, the fall and its
    reason."""
    scene = build_scene(scenario)
    m = scene.model
    ref = ReferenceMonitor(m, scene, scenario.fall_height_m)
    d0 = mujoco.MjData(m)  # the loop's own start: initial state + mj_forward
    d0.qpos[:], d0.qvel[:] = initial_state(scene, scenario)
    mujoco.mj_forward(m, d0)
    ref.update(0.0, d0)
    period = 1.0 / scenario.control_rate_hz

    def on_step(model, data):
        ref.update(len(ref.rows) * period, data)

    r = simulate(scenario, scene=scene, on_step=on_step)
    outcome = (
        "recovered" if r.recovered else r.fall_reason if r.fell else "diverged" if r.diverged else "completed"
    )
    assert outcome.startswith(ends), outcome
    assert len(ref.rows) == len(r.times)
    np.testing.assert_array_equal(r.contacts, np.array(ref.rows, dtype=bool))
    assert r.events == tuple(ref.events)
    assert r.block_contact_time_s == ref.block_time and r.block_contact_time_s is not None
    assert (r.fall_time_s, r.fall_reason) == (ref.fall_time, ref.fall_reason)
    if ends == "recovered":
        assert len(r.events) >= 8  # the landing, the heels' rise and return


def test_monitor_classifies_a_lying_biped_and_a_resting_block():
    """A static check of the same equivalence without a controller: the biped dropped on its
    side with the block dropped on it; both monitors read the same MjData after each of 300
    steps."""
    s = Scenario(block_position_m=(0.0, 0.0, 0.6), block_velocity_m_s=(0.0, 0.0, 0.0), fall_height_m=0.01)
    scene = build_scene(s)
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = initial_state(scene, s)
    d.qpos[scene.biped_qpos_index[3:7]] = axis_angle_quat(np.array([1.0, 0.0, 0.0]), math.pi / 2)
    d.qpos[scene.biped_qpos_index[2]] = 0.25
    mujoco.mj_forward(m, d)
    assert scene.sole_boxes == ()  # W's soles, two geoms a foot
    mon = ContactMonitor.of_scene(scene, s.fall_height_m)
    ref = ReferenceMonitor(m, scene, s.fall_height_m)
    for k in range(300):
        mon.update(k * 0.001, d)
        ref.update(k * 0.001, d)
        np.testing.assert_array_equal(mon.flags, ref.flags)
        assert mon.feet == (ref.flags[0] or ref.flags[1], ref.flags[2] or ref.flags[3])
        mujoco.mj_step(m, d, 2)
    assert mon.fall_reason == ref.fall_reason and "touched the floor" in mon.fall_reason
    assert mon.fall_time_s == ref.fall_time
    assert mon.block_contact_time_s == ref.block_time and ref.block_time is not None
    assert mon.events == ref.events


def test_heel_timeline_reads_w_events_through_chatter():
    """Hand-made events: a 2 ms bounce before the long rise and one after the return are not
    W's events; a heel that never comes back has no return time."""
    ev = [
        ContactEvent(t, foot, "heel", kind)
        for t, foot, kind in [
            (0.010, "left", "touch_down"),
            (0.086, "left", "lift_off"),
            (0.088, "left", "touch_down"),
            (0.090, "left", "lift_off"),
            (0.274, "left", "touch_down"),
            (0.300, "left", "lift_off"),
            (0.302, "left", "touch_down"),
            (0.094, "right", "lift_off"),
        ]
    ]
    line = heel_timeline(ev, 0.082)
    assert line == {
        "block hits the body": 0.082,
        "left heel rises": 0.086,
        "left heel back": 0.274,
        "right heel rises": 0.094,
        "right heel back": None,
    }
    assert heel_timeline(ev, None)["left heel rises"] is None


@pytest.mark.slow
def test_fast_preset_keeps_w_timeline():
    """``physics = "fast"`` (1 ms, 7.5 ms, sleep) against "faithful" on W's push: the block hit,
    both heels' rise and return within 10 ms (the criterion of docs/sweep.md)."""
    runs = {p: simulate(Scenario(physics=p, duration_s=1.0)) for p in PRESETS}
    a, b = (heel_timeline(r.events, r.block_contact_time_s) for r in runs.values())
    assert all(v is not None for v in a.values()), a
    for name in a:
        assert b[name] == pytest.approx(a[name], abs=0.010), (name, a[name], b[name])
