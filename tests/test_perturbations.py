"""The perturbation paradigms (biped.sim.perturbations, docs/perturbations.md), each against a
reference the project does not compute: MuJoCo's own momentum for the force pulse, the held
state's stillness for the tether, the feet's displacement against the platform's."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from _helpers import paradigm_push

from biped.errors import ScenarioError
from biped.sim import Scenario, build_scene
from biped.sim.perturbations import of
from biped.sim.perturbations.platform import profile
from biped.sim.push import controller_policy, run_closed_loop
from biped.sim.scene import initial_state


def _run(compiled=None, **keys):
    sc = Scenario(physics="fast", distribution="qp", **keys)
    scene = build_scene(sc)
    return run_closed_loop(sc, scene, controller_policy(sc, scene), compiled=compiled), scene


@pytest.mark.parametrize("shape", ["rectangular", "half-sine"])
def test_force_pulse_delivers_its_impulse_to_the_free_body(shape):
    """MuJoCo's own momentum of the biped, floating without gravity, changes by the pulse's
    impulse: F T for the rectangle, 2 F T / pi for the half sine (to 1 %)."""
    F, T = np.array([-80.0, 30.0, 10.0]), 0.15
    sc = Scenario(
        physics="fast", perturbation="force", force_n=tuple(F), force_start_s=0.02, force_duration_s=T,
        force_shape=shape,
    )  # fmt: skip
    scene = build_scene(sc)
    m = scene.model
    m.opt.gravity[:] = 0.0
    d = mujoco.MjData(m)
    q, v = initial_state(scene, sc)
    q[scene.biped_qpos_index[2]] += 1.0  # in the air: no contacts
    d.qpos[:], d.qvel[:] = q, v
    mujoco.mj_forward(m, d)
    mujoco.mj_subtreeVel(m, d)
    driver = of(sc).driver(scene, m, d, None)
    root = m.body_rootid[scene.central_body]
    mass = m.body_subtreemass[root]
    p0 = mass * d.subtree_linvel[root].copy()
    rows = set(driver.rows.tolist())
    for k in range(round(0.3 * sc.control_rate_hz)):
        if k in rows:
            driver.apply(k, k / sc.control_rate_hz, d)
        mujoco.mj_step(m, d, sc.control_substeps)
    mujoco.mj_forward(m, d)
    mujoco.mj_subtreeVel(m, d)
    dp = mass * d.subtree_linvel[root] - p0
    want = F * T * (1.0 if shape == "rectangular" else 2.0 / np.pi)
    assert np.linalg.norm(dp - want) < 0.01 * np.linalg.norm(want), (dp, want)


@pytest.mark.parametrize("direction", [0.0, 90.0])
def test_release_held_by_the_tether_stays_put(direction):
    """With the tether kept (release after the run), the leaned biped is a static equilibrium:
    over 1 s its central body moves less than 0.2 mm and turns less than 0.1 deg (exact with the
    feet fixed), its feet less than 3 mm: the creep of MuJoCo's soft friction, which the same
    biped standing unleaned, with no tether, shows too (1.4 mm in 1 s at friction 1)."""
    r, _ = _run(perturbation="release", release_lean_deg=8.0, release_direction_deg=direction,
                release_time_s=10.0, duration_s=1.0)  # fmt: skip
    assert not r.fell and len(r.times) == 501
    drift = np.linalg.norm(r.com - r.com[0], axis=1).max()
    turn = max(np.degrees(2 * np.arccos(min(1.0, abs(float(q @ r.quat[0]))))) for q in r.quat)
    feet = np.abs(r.feet_pos - r.feet_pos[0]).max()
    assert drift < 2e-4 and turn < 0.1 and feet < 3e-3, (drift, turn, feet)
    # it leans: the central body's COM is 8 deg ahead of the ankles, forward (-x) or left (-y)
    axis = 0 if direction == 0.0 else 1
    assert r.com[0, axis] < -0.1


def test_release_lean_is_straight_and_the_feet_flat():
    """The held pose leans the body about the ankles (COM ahead of the ankles by tan(lean) of its
    height) with both feet where they stood, flat."""
    sc = Scenario(perturbation="release", release_lean_deg=10.0)
    scene = build_scene(sc)
    up = Scenario()
    m = scene.model
    d0, d1 = mujoco.MjData(m), mujoco.MjData(m)
    d0.qpos[:] = initial_state(scene, up.with_overrides(perturbation="force"))[0]
    d1.qpos[:] = initial_state(scene, sc)[0]
    mujoco.mj_kinematics(m, d0)
    mujoco.mj_kinematics(m, d1)
    for f in ("left_foot", "right_foot"):
        b = m.body(f).id
        assert np.allclose(d1.xpos[b][:2], d0.xpos[b][:2], atol=1e-9)
        assert abs(abs(float(d1.xquat[b] @ d0.xquat[b])) - 1) < 1e-12
    a = m.body("left_ankle_1").id
    c0, c1 = d0.xipos[scene.central_body] - d0.xpos[a], d1.xipos[scene.central_body] - d1.xpos[a]
    tilt = np.degrees(np.arctan2(-c1[0], c1[2]) - np.arctan2(-c0[0], c0[2]))
    assert abs(tilt - 10.0) < 1e-6


def test_platform_carries_the_feet():
    """A 10 cm platform move at friction 1 carries both feet with it (within 1 cm)."""
    r, scene = _run(perturbation="platform", platform_displacement_m=(0.1, 0.0), friction=1.0, duration_s=1.0)
    assert not r.fell
    moved = r.feet_pos[-1, :, :2] - r.feet_pos[0, :, :2]
    assert np.abs(moved - [0.1, 0.0]).max() < 0.01, moved
    m = scene.model
    slide = m.jnt_qposadr[m.joint("platform_slide").id]
    assert abs(r.qpos[-1, slide] - 0.1) < 1e-3  # the servo holds the platform at the end


def test_platform_profile_is_a_ramp_and_hold():
    t = np.linspace(-0.1, 0.5, 6001)
    x, v, a = profile(t, 0.1, 0.3)
    assert x[0] == 0 and x[-1] == 0.1 and np.all(np.diff(x) >= 0)
    # its velocity and acceleration are its position's derivatives (finite differences)
    dt = t[1] - t[0]
    assert np.abs(np.gradient(x, dt) - v).max() < 1e-2 * v.max()
    assert abs(v.max() - 0.1 / (0.75 * 0.3)) < 1e-12


@pytest.mark.parametrize(
    "keys",
    [
        {"perturbation": "force", "duration_s": 0.3},
        {
            "perturbation": "force",
            "force_shape": "half-sine",
            "force_point_m": (0.0, 0.05, 0.1),
            "duration_s": 0.3,
        },
        {"perturbation": "platform", "duration_s": 0.5},
        {"perturbation": "platform", "duration_s": 0.25, "platform_start_s": 0.0},  # ends in the ramp
        {"perturbation": "release", "duration_s": 0.3},
    ],
)
def test_compiled_loop_is_the_python_loop(keys):
    """Every paradigm runs in the compiled loop, bit for bit the Python loop's run, with the same
    record of the perturbation's inputs (the platform's: applied by the compiled loop itself, its
    driver's schedule, and rebuilt)."""
    a, _ = _run(compiled=True, **keys)
    b, _ = _run(compiled=False, **keys)
    assert np.array_equal(a.qpos, b.qpos) and np.array_equal(a.torques, b.torques)
    ia, ib = a.extra.get("inputs"), b.extra.get("inputs")
    assert (ia is None) == (ib is None)
    for key in ("rows", "ctrl", "xfrc") if ia is not None else ():
        assert ia[key].shape == ib[key].shape and np.array_equal(ia[key], ib[key]), key


def test_platform_ramp_runs_inside_the_compiled_loop(monkeypatch):
    """The platform's references and set point are its driver's schedule, applied by the compiled
    loop itself: a 0.5 s run (a 150-period ramp) returns to Python a few times, not once a period
    of the ramp (each return cost ~80 us: the platform's 1.14-1.2x of the block's run)."""
    from biped.sim import fused

    calls = []
    run = fused.FusedRows.run

    def counted(self, k0, k1):
        calls.append((k0, k1))
        return run(self, k0, k1)

    monkeypatch.setattr(fused.FusedRows, "run", counted)
    r, _ = _run(compiled=True, perturbation="platform", duration_s=0.5)
    assert r.times[-1] == pytest.approx(0.5) and len(r.extra["inputs"]["rows"]) == 152
    assert 0 < len(calls) <= 12, len(calls)


@pytest.mark.parametrize(
    ("keys", "words"),
    [
        ({"force_duration_s": -0.1}, "force_duration_s must be > 0"),
        ({"release_lean_deg": 50.0}, "release_lean_deg must be in [0, 45]"),
        ({"platform_displacement_m": (1.5, 0.0)}, "platform_displacement_m must be at most"),
        ({"perturbation": "force", "force_body": "tail"}, "force_body 'tail' is not a body"),
        ({"perturbation": "wave"}, "perturbation must be one of"),
        ({"force_shape": "square"}, "force_shape must be one of"),
        ({"force_point_m": "hip"}, "force_point_m must be 'pelvis'"),
        ({"perturbation": "release", "controller": "joint-pd"}, "needs controller = 'workspace'"),
    ],
)
def test_bad_keys_are_one_line_errors(keys, words):
    with pytest.raises(ScenarioError) as exc:
        Scenario.from_dict(keys)
    assert words in str(exc.value) and "\n" not in str(exc.value)


def test_release_refuses_a_lean_friction_cannot_hold():
    """A 30 deg lean at W's friction 0.3: the tether's pull would slide the feet; a one-line error
    before the run."""
    with pytest.raises(ScenarioError, match="more than friction = 0.3 lets the feet hold"):
        _run(perturbation="release", release_lean_deg=30.0, duration_s=0.1)


def _swaying(hip_factor: float):
    """Hand-made sway, 1 s at 100 Hz: the legs turn theta(t) = 3 deg sin(2 pi t) about the
    ankles, forward (-x); the trunk then turns about the hips by hip_factor * theta (0: the body
    as one inverted pendulum, the ankle strategy; -3: the trunk against the legs, the hip
    strategy). Each foot stays where it stood (the legs' joints solved)."""
    from biped.sim.perturbations.release import turn_body

    sc = Scenario(perturbation="force")
    scene = build_scene(sc)
    m = scene.model
    q0 = initial_state(scene, sc)[0]
    d = mujoco.MjData(m)
    qs = []
    for t in np.arange(0, 1.0, 0.01):
        th = np.radians(3.0) * np.sin(2 * np.pi * t)
        q = q0.copy()
        assert turn_body(scene, q, _ankles(m, d, q), (0.0, 1.0, 0.0), -th)  # top toward -x
        if hip_factor:
            assert turn_body(scene, q, _hips(m, d, q), (0.0, 1.0, 0.0), -hip_factor * th)
        qs.append(q)
    return scene, np.array(qs)


def _mid(m, d, q, name):
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    return np.mean([d.xpos[m.body(f"{s}_{name}").id] for s in ("left", "right")], axis=0)


def _ankles(m, d, q):
    return _mid(m, d, q, "ankle_1")


def _hips(m, d, q):
    return _mid(m, d, q, "hip_1")


@pytest.mark.parametrize(
    ("keys", "falls"),
    [
        ({"perturbation": "force", "force_n": (-60.0, 0.0, 0.0)}, False),
        ({"perturbation": "force", "force_n": (-400.0, 0.0, 0.0)}, True),
        ({"perturbation": "platform", "platform_displacement_m": (0.05, 0.0)}, False),
        ({"perturbation": "platform", "platform_displacement_m": (0.15, 0.0)}, True),
        ({"perturbation": "release", "release_lean_deg": 4.0}, False),
        ({"perturbation": "release", "release_lean_deg": 10.0}, True),
    ],
)
def test_small_moves_are_recovered_large_ones_fall(keys, falls):
    """W's controller with the QP distribution, no torque limits: a small move of each paradigm is
    recovered (back at its set point within the tolerances), a large one falls."""
    r, _ = _run(duration_s=2.0, **keys)
    assert r.fell is falls
    assert r.recovered is (not falls)


@pytest.mark.parametrize(("hip_factor", "label"), [(0.0, "ankle"), (-3.0, "hip")])
def test_strategy_rule_labels_hand_made_motions(hip_factor, label):
    """The rule of biped.sim.response on MuJoCo's kinematics of hand-made motions: the body
    swaying as one piece about the ankles is 'ankle'; the trunk counter-rotating is 'hip'."""
    from biped.sim.response import body_angles, strategy_from_angles

    scene, qs = _swaying(hip_factor)
    leg, trunk = body_angles(scene, qs, (-1.0, 0.0))
    got, corr, pt, pl = strategy_from_angles(leg, trunk)
    assert got == label
    assert abs(pl - 3.0) < 0.05  # the legs' sway, read back
    assert abs(pt - abs(1 + hip_factor) * 3.0) < 0.1  # the trunk's: 3 deg, or 2 deg against the legs
    assert (corr > 0.99) if hip_factor == 0 else (corr < -0.99)


def test_margin_of_stability_against_a_square():
    from biped.sim.response import margin

    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    got = margin(np.array([[0.5, 0.5], [0.9, 0.5], [1.5, 0.5], [2.0, 2.0]]), sq)
    assert np.allclose(got, [0.5, 0.1, -0.5, -np.sqrt(2)])


def test_block_sweep_keys_are_those_of_before_the_paradigms():
    """A block sweep's identity and trial keys are unchanged (a rerun resumes an older file):
    the values main's code gave before the paradigms existed."""
    from biped.sim.sweep import SweepSpec

    s = SweepSpec(axes={"speed_m_s": (2.0, 4.0), "direction_deg": (0.0, 90.0)})
    assert s.identity == "6c9f08c3bb9e9a7b"
    assert [t.key for t in s.trials()][:2] == ["67abf38466ab22b14368", "5e3e011cc73543e70e10"]


@pytest.mark.parametrize(
    ("paradigm", "magnitude", "key", "want"),
    [
        ("force", 100.0, "force_n", (0.0, -100.0, 0.0)),  # pushes toward -y: the force points there
        ("platform", 0.1, "platform_displacement_m", (0.0, 0.1)),  # the floor moves the other way
        ("release", 10.0, "release_direction_deg", 90.0),  # world -y is the biped's left
        ("pull", 0.1, "pull_displacement_m", (0.0, -0.1)),  # the motor pulls toward -y
    ],
)
def test_sweep_magnitude_and_direction_set_the_paradigm(paradigm, magnitude, key, want):
    """--magnitude M --direction 270 (toward world -y) in each paradigm's own keys."""
    from biped.sim.sweep import SweepSpec

    base = Scenario(perturbation=paradigm)
    spec = SweepSpec(axes={"magnitude": magnitude, "direction_deg": 270.0}, base=base)
    (trial,) = spec.trials()
    sc = spec.scenario(trial)
    assert np.allclose(getattr(sc, key), want, atol=1e-9)
    size = of(sc).size(70.0)
    assert size.magnitude == pytest.approx(magnitude) and size.direction_deg == pytest.approx(270.0)


def test_push_command_runs_a_paradigm_and_names_its_strategy(tmp_path):
    summary = paradigm_push(tmp_path / "run", "force")
    assert summary["perturbation"]["paradigm"] == "force"
    assert summary["perturbation"]["impulse_applied_n_s"] == pytest.approx([-9.0, 0.0, 0.0])
    assert summary["response"]["strategy"] in ("ankle", "hip")


@pytest.mark.parametrize(
    ("perturbation", "axes", "words"),
    [
        ("force", {"speed_m_s": 3.0}, "sweep axis speed_m_s is the block's"),
        ("block", {"magnitude": 3.0}, "sweep axis magnitude is for perturbation"),
    ],
)
def test_sweep_refuses_the_other_paradigms_axes(perturbation, axes, words):
    from biped.sim.sweep import SweepSpec

    with pytest.raises(ScenarioError, match=words):
        SweepSpec(axes=axes, base=Scenario(perturbation=perturbation))


def test_held_lean_loads_the_feet_as_the_tether_says():
    """MuJoCo's contact forces in the held lean (measure_rows, which applies the run's tether force
    again): the floor pushes the feet forward by exactly the tether's pull, carries the weight, and
    the centre of pressure stays where upright stance had it (the tether holds the lean's moment)."""
    from biped.sim.measure import measure_rows

    r, scene = _run(perturbation="release", release_lean_deg=6.0, release_time_s=10.0, duration_s=0.2)
    rows = measure_rows(scene, r)
    k = len(r.times) - 1
    T = r.extra["perturbation"]["tether_force_n"]
    total = rows.grf[k].sum(axis=0)
    assert total[0] == pytest.approx(-T, rel=0.02) and abs(total[1]) < 1.0
    assert total[2] == pytest.approx(rows.biped_mass_kg * 9.81, rel=0.01)
    up, _ = _run(perturbation="force", force_n=(0.0, 0.0, 0.0), duration_s=0.2)
    up_rows = measure_rows(scene, up)
    cop = (rows.cop[k] * rows.grf[k, :, 2:]).sum(axis=0) / rows.grf[k, :, 2].sum()
    assert abs(cop[0] - up_rows.whole_body_com[0, 0]) < 0.005


def test_a_step_is_measured_as_the_stepping_controller_took_it():
    """A 300 N push with capture-point stepping: the response reads a step whose touchdown (from
    the contacts) is the stepping controller's own record of it, within one control period."""
    from biped.sim.response import measure_response

    r, scene = _run(perturbation="force", force_n=(-300.0, 0.0, 0.0), stepping=True, duration_s=1.0)
    resp = measure_response(scene, r)
    (step,) = r.extra["steps"]
    assert resp.strategy == "step" and resp.step_needed
    assert abs(resp.time_to_foot_contact_s - (step["touch_down_s"] - 0.1)) <= 0.0021
    assert 0.1 < resp.step_length_m < 0.6
