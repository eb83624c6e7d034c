"""What a sweep measures and compares against: the block's impulse, Hof's feet-in-place bound,
the joint-space PD baseline and the torque limits. Oracles: closed forms, MuJoCo."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from biped import models
from biped.analysis import envelope, hof_bound, ray_to_polygon_edge, support_polygon
from biped.control.joint_pd import JointPDController
from biped.control.limits import HUMAN_N_M_PER_KG, JOINT_NAMES, clip_torques, torque_limits
from biped.errors import ScenarioError
from biped.sim.contact import contact_solref
from biped.sim.scenario import PHYSICS, Scenario
from biped.sim.sweep import SweepSpec, ballistic_impulse, run_trial

G = np.array([0.0, 0.0, -9.81])


# ---------------------------------------------------------------------------------------------
# impulse


def test_impulse_is_m_delta_v_of_a_piecewise_ballistic_block():
    """Closed form: a 1.8 kg block flies, gets dv = (-6.1, 0.4, 0.9) m/s over a 3 ms contact
    that starts between two samples, flies again; J on the body = -m dv."""
    m, dv = 1.8, np.array([-6.1, 0.4, 0.9])
    t = np.arange(0, 0.3, 0.002)
    v0 = np.array([4.5, 0.0, 0.3])
    t_hit, t_end = 0.0813, 0.0843
    v = np.where(t[:, None] < t_hit, v0 + np.outer(t, G), v0 + dv + np.outer(t, G))
    during = (t >= t_hit) & (t < t_end)  # mid-contact samples: partway
    v[during] = v0 + 0.5 * dv + np.outer(t[during], G)
    J, t1 = ballistic_impulse(t, v, m, contact_time_s=0.082)
    np.testing.assert_allclose(J, -m * dv, rtol=1e-12, atol=1e-12)
    assert t1 == pytest.approx(0.082)
    # never hits: zero; never flies free again: NaN; first hit elsewhere than the body: NaN
    J0, _ = ballistic_impulse(t, v0 + np.outer(t, G), m)
    assert np.all(J0 == 0)
    stuck = v.copy()
    stuck[t >= t_hit] = 0.0
    assert np.all(np.isnan(ballistic_impulse(t, stuck, m)[0]))
    assert np.all(np.isnan(ballistic_impulse(t, v, m, contact_time_s=0.2)[0]))


@pytest.mark.parametrize("physics", PHYSICS)
def test_impulse_equals_the_momentum_the_target_gains_in_mujoco(physics):
    """Conservation of momentum: in zero gravity a 1.8 kg box hits a free 40 kg sphere; the
    impulse measured from the box's velocity at 500 Hz equals the sphere's momentum change
    (with each physics preset's step and calibrated contact)."""
    s = Scenario(physics=physics)
    dt, (tc, z) = s.physics_timestep_s, contact_solref(0.2, s.contact_timeconst_s, s.physics_timestep_s)
    model = mujoco.MjModel.from_xml_string(f"""
    <mujoco><option timestep="{dt}" gravity="0 0 0"/>
      <default><geom solref="{tc} {z}" solimp="0.95 0.95 0.001 0.5 2" friction="0.3"/></default>
      <worldbody>
        <body name="box" pos="0.5 0.03 0.05"><freejoint/><geom type="box" size=".05 .05 .05" mass="1.8"/></body>
        <body name="ball"><freejoint/><geom type="sphere" size="0.2" mass="40"/></body>
      </worldbody></mujoco>""")
    data = mujoco.MjData(model)
    data.qvel[:3] = (-4.5, 0.0, 0.2)
    times, vel = [], []
    for k in range(150):
        times.append(k * 0.002)
        vel.append(data.qvel[:3].copy())
        mujoco.mj_step(model, data, s.control_substeps)
    J, _ = ballistic_impulse(times, vel, 1.8, gravity=(0, 0, 0))
    p_ball = 40.0 * data.qvel[6:9]
    np.testing.assert_allclose(J, p_ball, atol=1e-9 + 1e-9 * np.linalg.norm(p_ball))
    assert J[0] < -8.1  # at least the block's momentum: it bounced back


# ---------------------------------------------------------------------------------------------
# Hof's bound


def test_hof_bound_hand_computed_case():
    """A 70 kg body, COM 1 m high over the origin, support rectangle x in [-0.1, 0.2], y in
    [-0.15, 0.15]: omega_0 = sqrt(9.81) = 3.1321 1/s; d = 0.2 (0 deg), 0.15 (90 deg), 0.1 (180
    deg), 0.15 / sin 45 = 0.21213 (45 deg); J_max = 70 omega_0 d."""
    poly = [(-0.1, -0.15), (0.2, -0.15), (0.2, 0.15), (-0.1, 0.15)]
    b = hof_bound([0, 45, 90, 180], 70.0, 1.0, (0.0, 0.0), poly)
    w0 = 3.132091952673165
    assert b.omega0 == pytest.approx(w0, rel=1e-12)
    np.testing.assert_allclose(b.d_m, [0.2, 0.21213203435596426, 0.15, 0.1], rtol=1e-12)
    np.testing.assert_allclose(b.j_max_n_s, [43.849287, 46.509193, 32.886966, 21.924644], rtol=1e-6)
    with pytest.raises(ScenarioError, match="outside the support polygon"):
        ray_to_polygon_edge((1.0, 0.0), 0.0, poly)


def test_support_polygon_of_the_shipped_biped():
    """The MJCF: hip centres 0.0839788 m off the mid-plane, sole boxes 0.0461883 m half wide, so
    the polygon spans y = +-0.1301671 m; total mass 73.06 kg; the COM projects inside."""
    com_xy, h, mass, poly = support_polygon(Scenario())
    assert mass == pytest.approx(73.06, abs=1e-6)
    assert poly[:, 1].max() == pytest.approx(0.0839788 + 0.0461883, abs=1e-6)
    assert poly[:, 1].min() == pytest.approx(-(0.0839788 + 0.0461883), abs=1e-6)
    assert 0.7 < h < 0.9
    assert ray_to_polygon_edge(com_xy, 90.0, poly) == pytest.approx(0.1301671 - com_xy[1], abs=1e-6)


# ---------------------------------------------------------------------------------------------
# joint-space PD baseline and limits


@pytest.fixture(scope="module")
def pd():
    return JointPDController.from_mjcf(models.path("wendlandt"))


def test_joint_pd_is_the_pd_law(pd, wendlandt_mj):
    rng = np.random.default_rng(0)
    qpos = wendlandt_mj.key_qpos[0].copy()
    qvel = rng.standard_normal(18)
    dq = rng.standard_normal(12) * 0.05
    adr = [wendlandt_mj.joint(n).qposadr[0] for n in pd.joint_names]
    vadr = [wendlandt_mj.joint(n).dofadr[0] for n in pd.joint_names]
    qpos[adr] = np.radians((0.0, 40.0, 0.0, -77.4595, 0.0, 42.4595) * 2) + dq  # W's angles
    tau = pd.compute(qpos, qvel).torques
    np.testing.assert_allclose(tau, -pd.gains.kp * dq - pd.gains.kd * qvel[vadr], rtol=1e-12)
    assert pd.joint_names == JOINT_NAMES


def test_joint_pd_gravity_compensation_holds_the_weight_on_both_feet(wendlandt_mj):
    """Oracle: MuJoCo's generalized gravity force g(q) and foot Jacobians; static balance
    g = S^T tau + J_feet^T w must have a solution w for the compensation torques tau."""
    ctrl = JointPDController.from_mjcf(models.path("wendlandt"), gravity_compensation=True)
    m = wendlandt_mj
    d = mujoco.MjData(m)
    d.qpos[:] = m.key_qpos[0]
    d.qpos[3:7] = (0.9990482, 0.0, -0.0436194, 0.0)
    mujoco.mj_forward(m, d)
    tau = ctrl.compute(d.qpos, np.zeros(18)).gravity
    f = np.zeros(m.nv)
    for j, name in enumerate(ctrl.joint_names):
        f[m.joint(name).dofadr[0]] = tau[j]
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    rows = []
    for foot in ("left_foot", "right_foot"):
        mujoco.mj_jacBody(m, d, jp, jr, m.body(foot).id)
        rows += [jp.copy(), jr.copy()]
    J = np.vstack(rows)
    w = np.linalg.lstsq(J.T, d.qfrc_bias - f, rcond=None)[0]
    residual = np.linalg.norm(J.T @ w - (d.qfrc_bias - f))
    assert residual < 1e-4 * np.linalg.norm(d.qfrc_bias)
    # and without the joint torques there is none: the check can fail
    w0 = np.linalg.lstsq(J.T, d.qfrc_bias, rcond=None)[0]
    assert np.linalg.norm(J.T @ w0 - d.qfrc_bias) > 10.0


@pytest.mark.parametrize(
    "joint, body, point, axis, sign",
    [
        ("left_knee", "left_shank", (0, 0, -0.4), 0, -1),  # extension: foot forward (-x)
        ("left_ankle_dorsiflexion", "left_foot", (-0.2, 0, -0.05), 2, +1),  # toes (-x) go up
        ("left_hip_flexion", "left_thigh", (0, 0, -0.4), 0, -1),  # knee goes forward (-x)
        ("left_hip_abduction", "left_thigh", (0, 0, -0.4), 1, -1),  # left leg goes out (-y)
        ("left_ankle_inversion", "left_foot", (0, 0, -0.06), 1, +1),  # sole turns medially (+y)
        ("right_ankle_inversion", "right_foot", (0, 0, -0.06), 1, -1),  # right foot: medial is -y
        ("right_hip_rotation", "right_shank", (-0.3, 0, 0), 1, -1),  # internal: knee-front point to -y
    ],
)
def test_positive_torque_is_the_anatomical_direction_named_in_limits(joint, body, point, axis, sign):
    """Oracle: MuJoCo. Zero gravity, central body welded, straight legs (qpos0); +1 N m on the
    joint moves a point of the segment the way the name of the positive direction says
    (:data:`HUMAN_N_M_PER_KG` lists (negative, positive) directions). The biped faces -x, its
    left leg is on -y. Knee: from straight, an extending torque hyperextends it, the foot goes
    forward."""
    spec = mujoco.MjSpec.from_file(str(models.path("wendlandt")))
    spec.option.gravity = [0, 0, 0]
    spec.delete(spec.body("central_body").first_joint())
    spec.delete(spec.key("wendlandt_initial"))
    m = spec.compile()
    d = mujoco.MjData(m)
    d.ctrl[m.actuator(joint).id] = 1.0
    b = m.body(body).id
    mujoco.mj_step(m, d, 20)
    p_local = np.array(point, float)
    p = d.xpos[b] + d.xmat[b].reshape(3, 3) @ p_local
    d0 = mujoco.MjData(m)
    mujoco.mj_forward(m, d0)
    p0 = d0.xpos[b] + d0.xmat[b].reshape(3, 3) @ p_local
    moved = p - p0
    assert np.sign(moved[axis]) == sign and abs(moved[axis]) > 1e-6


def test_human_limits_clip_each_direction(pd):
    lim = torque_limits("human", body_mass_kg=73.0)
    knee = JOINT_NAMES.index("left_knee")
    ankle = JOINT_NAMES.index("right_ankle_dorsiflexion")
    assert lim.upper[knee] == pytest.approx(3.2 * 73.0)  # extension
    assert lim.lower[knee] == pytest.approx(-1.4 * 73.0)  # flexion
    assert lim.lower[ankle] == pytest.approx(-2.2 * 73.0)  # plantarflexion
    tau = np.zeros(12)
    tau[knee], tau[ankle] = -500.0, 500.0
    out = clip_torques(tau, lim)
    assert out[knee] == pytest.approx(-102.2) and out[ankle] == pytest.approx(0.6 * 73.0)
    assert np.all(clip_torques(tau, torque_limits("none")) == tau)
    assert set(HUMAN_N_M_PER_KG) == {n.split("_", 1)[1] for n in JOINT_NAMES}
    with pytest.raises(ScenarioError, match="valid torque-limit sets: 'human', 'none'"):
        torque_limits("robot")


# ---------------------------------------------------------------------------------------------
# one real trial


@pytest.mark.parametrize("physics", PHYSICS)
def test_real_trial_measures_the_block_hit_and_the_baseline_holds_still(physics):
    """W's throw at the joint-space PD baseline for 0.3 s on the real push scene: the block hits
    at about 0.08 s, pushes the body toward -x with an impulse between its momentum m v (a
    plastic hit) and 2 m v (a perfectly elastic one); then an unpushed 0.6 s stand survives."""
    base = Scenario(
        duration_s=0.3,
        controller="joint-pd",
        target_com_m=(0.0, 0.0, 1.035),
        target_tilt_deg=5.0,
        physics=physics,
    )
    spec = SweepSpec(axes={"speed_m_s": 4.5, "direction_deg": 180.0}, base=base)
    row = run_trial(spec.setup(spec.trials()[0]))
    assert row["block_contact_time_s"] == pytest.approx(0.08, abs=0.01)
    mv = 1.8 * 4.5
    assert -2 * mv < row["impulse_x_n_s"] < -mv
    assert abs(row["impulse_y_n_s"]) < 1e-6 * mv
    assert row["completed"] and not row["fell"] and row["diverged"] is None
    far = SweepSpec(
        axes={"speed_m_s": 0.5, "direction_deg": 0.0},
        base=base.with_overrides(duration_s=0.6),
        launch_distance_m=5.0,
    )
    row = run_trial(far.setup(far.trials()[0]))
    assert row["block_contact_time_s"] != row["block_contact_time_s"]  # NaN: never hit
    assert row["impulse_n_s"] == 0.0 and row["completed"] and not row["fell"]
    assert row["max_com_excursion_m"] < 0.02


def test_envelope_is_the_survived_prefix_per_direction():
    table = {
        "direction_deg": [0, 0, 0, 0, 90, 90, 90],
        "speed_m_s": [1, 2, 3, 4, 1, 2, 3],
        "impulse_n_s": [2, 4, 6, 8, 2, 4, 6],
        "error": [None] * 7,
        "fell": [False, False, True, False, False, False, False],
        "completed": [True] * 7,
        "controller_error": [None] * 7,
        "diverged": [None] * 7,
        "recovered": [True] * 7,
    }
    env = envelope(table)
    np.testing.assert_array_equal(env.directions_deg, [0, 90])
    np.testing.assert_array_equal(env.survived_max, [2, 3])
    assert env.failed_min[0] == 3 and math.isnan(env.failed_min[1])
