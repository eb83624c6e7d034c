"""The QP wrench distribution (distribution="qp", beyond W): contact-feasible foot wrenches.

Oracles the project did not compute: the contact wrench cone against its definition (the
nonnegative span of the sole corners' friction-pyramid edges, by scipy's NNLS); foot and body
poses from MuJoCo; the legs' weight from MuJoCo's subtree masses and centres of mass; a second
QP solver (quadprog beside the default daqp) and a solver-free KKT
certificate on the same problems; the
optimality bound of a regularised least-squares problem; MuJoCo's compiled joint damping.
"""

from __future__ import annotations

import itertools

import mujoco
import numpy as np
import pytest
from _helpers import random_states
from scipy.optimize import nnls

from biped.control import WorkspaceController
from biped.control.distribution import RELAXED, SOLVED, ZEROED, QPWeights, cone_rows
from biped.control.limits import clip_torques, torque_limits
from biped.errors import ScenarioError
from biped.model import sole_rectangles
from biped.spatial import adjoint, inverse, transform

HUMAN = torque_limits("human")


def _generators(X, Y, mu):
    """(6, 16) wrenches at the sole centre of the friction-pyramid edges at the sole's corners."""
    cols = []
    for sx, sy, ex, ey in itertools.product((-1, 1), repeat=4):
        p = np.array([sx * X, sy * Y, 0.0])
        u = np.array([ex * mu, ey * mu, 1.0])
        cols.append(np.concatenate([u, np.cross(p, u)]))
    return np.array(cols).T


def _in_cone(w, X, Y, mu, tol=1e-7):
    """Residual of the best nonnegative combination of the generators, relative to |w|."""
    _, res = nnls(_generators(X, Y, mu), w)
    return res <= tol * max(1.0, np.linalg.norm(w))


def _rows(X, Y, mu, fmin=0.0, fmax=1e12):
    Ct, b = np.zeros((18, 6)), np.zeros(18)
    assert cone_rows(X, Y, mu, fmin, fmax, 0, Ct, b, 0) == 18
    return Ct, b


def test_cone_rows_are_the_span_of_the_corner_forces():
    """Caron et al.'s closed form (rows) equals the definition (NNLS on corner generators), on
    random wrenches either side of the boundary."""
    rng = np.random.default_rng(0)
    inside = outside = 0
    for _ in range(400):
        X, Y, mu = rng.uniform(0.03, 0.15), rng.uniform(0.02, 0.08), rng.uniform(0.1, 0.9)
        Ct, b = _rows(X, Y, mu)
        w = np.array(
            [
                rng.uniform(-1.2, 1.2) * mu,
                rng.uniform(-1.2, 1.2) * mu,
                1.0,
                rng.uniform(-1.2, 1.2) * Y,
                rng.uniform(-1.2, 1.2) * X,
                rng.uniform(-1.2, 1.2) * (X + Y) * mu,
            ]
        ) * rng.uniform(1, 500)
        slack = Ct @ w - b
        if np.min(np.abs(slack)) < 1e-6 * np.linalg.norm(w):
            continue
        rows_say = bool(np.all(slack >= 0))
        assert rows_say == _in_cone(w, X, Y, mu), (X, Y, mu, w, slack)
        inside += rows_say
        outside += not rows_say
    assert inside > 40 and outside > 40  # both sides were exercised


@pytest.fixture(scope="module")
def soles(wendlandt_path):
    return sole_rectangles(wendlandt_path)


def test_sole_rectangle_is_the_bottom_of_the_sole_boxes(wendlandt_mj, soles):
    """At W's initial state the soles are flat, 5 mm above the floor (the model's construction):
    the sole frame from the MJCF geoms sits on the lowest corners MuJoCo places, at their centre."""
    m = wendlandt_mj
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("wendlandt_initial").id)
    mujoco.mj_forward(m, d)
    for foot, sole in zip(("left", "right"), soles, strict=True):
        corners = []
        for part in ("heel", "toe"):
            g = m.geom(f"{foot}_{part}").id
            R = d.geom_xmat[g].reshape(3, 3)
            for s in itertools.product((-1, 1), repeat=3):
                corners.append(d.geom_xpos[g] + R @ (np.array(s) * m.geom_size[g]))
        corners = np.array(corners)
        bottom = corners[corners[:, 2] < corners[:, 2].min() + 1e-6]
        b = m.body(f"{foot}_foot").id
        g0s = transform(d.ximat[b].reshape(3, 3), d.xipos[b]) @ sole.g_foot_sole
        np.testing.assert_allclose(g0s[:3, 3], (bottom.min(0) + bottom.max(0)) / 2, atol=1e-9)
        np.testing.assert_allclose(g0s[2, 3], 0.005, atol=2e-4)
        np.testing.assert_allclose(g0s[:3, 2], [0, 0, 1], atol=2e-3)
        np.testing.assert_allclose(sole.half_length, np.ptp(bottom[:, 0]) / 2, atol=2e-3)
        np.testing.assert_allclose(sole.half_width, np.ptp(bottom[:, 1]) / 2, atol=2e-3)


def _sole_wrenches(m, d, out, soles):
    """The foot wrenches of ``out`` moved to the sole frames (numpy, MuJoCo's poses), and the
    same wrenches moved to the central body by MuJoCo's poses."""
    cb = m.body("central_body").id
    g01 = transform(d.ximat[cb].reshape(3, 3), d.xipos[cb])
    sole_w, body_w = [], []
    for foot, F, sole in zip(
        ("left", "right"), (out.foot_wrench_left, out.foot_wrench_right), soles, strict=True
    ):
        gfs = sole.g_foot_sole
        w = adjoint(gfs[:3, :3], gfs[:3, 3]).T @ F  # F_s = Ad^T_{g_{f,s}} F_f
        b = m.body(f"{foot}_foot").id
        g0s = transform(d.ximat[b].reshape(3, 3), d.xipos[b]) @ gfs
        gs1 = inverse(g0s) @ g01
        sole_w.append(w)
        body_w.append(adjoint(gs1[:3, :3], gs1[:3, 3]).T @ w)
    return sole_w, body_w


#: the flat sole's cones for every foot in contact: the random states below pitch the feet by up
#: to ~30 deg with both taken in contact, where the edge contact (tests/test_qp_edge_contact.py)
#: would leave a strip; these tests check the rectangle's rows and the solver on them
FLAT = QPWeights(edge_contact=False)


@pytest.fixture(scope="module")
def ctrls(wendlandt_path):
    return {
        "statics": WorkspaceController.from_mjcf(wendlandt_path),
        "qp": WorkspaceController.from_mjcf(wendlandt_path, distribution="qp", qp_weights=FLAT),
        "qp_human": WorkspaceController.from_mjcf(
            wendlandt_path, distribution="qp", torque_limits=HUMAN, qp_weights=FLAT
        ),
        # the legs taken as massless (the cones hold the legs' shares alone: QPWeights.leg_weight 0)
        "qp_massless": WorkspaceController.from_mjcf(
            wendlandt_path, distribution="qp", qp_weights=QPWeights(leg_weight=0.0, edge_contact=False)
        ),
        "qp_human_massless": WorkspaceController.from_mjcf(
            wendlandt_path,
            distribution="qp",
            torque_limits=HUMAN,
            qp_weights=QPWeights(leg_weight=0.0, edge_contact=False),
        ),
        "qp_quadprog": WorkspaceController.from_mjcf(
            wendlandt_path, distribution="qp", torque_limits=HUMAN, qp_solver="quadprog", qp_weights=FLAT
        ),
    }


def test_qp_wrenches_satisfy_every_cone_cop_and_torque_row(ctrls, wendlandt_mj, soles):
    """Legs taken as massless: each leg's share, moved to its sole, lies in the sole's cone."""
    m, ctrl = wendlandt_mj, ctrls["qp_human_massless"]
    wts = ctrl.qp.weights
    mu = wts.friction * wts.friction_scale
    lim = HUMAN.reorder(ctrl.joint_names)
    active = 0
    for d in random_states(m, 40, 1, vel=2.0):
        out = ctrl.compute(d.qpos, d.qvel)
        assert ctrl.qp.status == SOLVED
        sole_w, body_w = _sole_wrenches(m, d, out, soles)
        for w, sole, share, bw in zip(
            sole_w, soles, (out.wrench_left, out.wrench_right), body_w, strict=True
        ):
            scale = max(1.0, np.linalg.norm(w))
            assert wts.min_normal_n - 1e-6 * scale <= w[2] <= wts.max_normal_n + 1e-6 * scale
            assert _in_cone(w, sole.half_length, sole.half_width, mu, tol=1e-6)
            np.testing.assert_allclose(share, bw, atol=1e-8 * scale)  # MuJoCo's poses
        assert np.all(out.torques >= lim.lower - 1e-6) and np.all(out.torques <= lim.upper + 1e-6)
        # torques are W Alg. 6 of the legs' shares (the QP's torque map is that linear map)
        np.testing.assert_allclose(
            out.torques, ctrl.leg_torques(d.qpos, out.wrench_left, out.wrench_right), atol=1e-7
        )
        active += np.any(
            np.isclose(out.torques, lim.lower, atol=1e-6) | np.isclose(out.torques, lim.upper, atol=1e-6)
        )
    assert active > 0  # some states needed a torque row


def test_clipping_after_the_qp_is_a_no_op(ctrls, wendlandt_mj):
    """With the limits inside the QP, clipping afterwards changes nothing, at states where the
    min-norm split's torques are clipped heavily."""
    m = wendlandt_mj
    lim = HUMAN.reorder(ctrls["qp_human"].joint_names)
    clipped_statics = 0.0
    for d in random_states(m, 30, 2, vel=3.0):
        tau = ctrls["qp_human"].compute(d.qpos, d.qvel).torques
        np.testing.assert_allclose(clip_torques(tau, lim), tau, atol=1e-6)
        ts = ctrls["statics"].compute(d.qpos, d.qvel).torques
        clipped_statics = max(clipped_statics, np.max(np.abs(clip_torques(ts, lim) - ts)))
    assert clipped_statics > 10.0  # the states do push the torques past the limits


def test_qp_reproduces_a_feasible_min_norm_split(ctrls, wendlandt_mj, soles):
    """Where W's min-norm split already lies in the cones, the QP's weighted error is at most the
    regularisation cost of that split (it is a feasible point of the QP): the desired wrench is
    reproduced up to the regularisation."""
    m = wendlandt_mj
    wts = ctrls["qp_massless"].qp.weights
    mu = wts.friction * wts.friction_scale
    W = np.array([wts.force] * 3 + [wts.moment] * 3)
    reg = np.array([wts.reg_force] * 3 + [wts.reg_moment] * 3)
    checked = 0
    for d in random_states(m, 60, 3, spread=0.1, vel=0.3):
        mn = ctrls["statics"].compute(d.qpos, d.qvel)
        sole_mn, _ = _sole_wrenches(m, d, mn, soles)
        if not all(
            _in_cone(w, s.half_length, s.half_width, mu) and wts.min_normal_n <= w[2] <= wts.max_normal_n
            for w, s in zip(sole_mn, soles, strict=True)
        ):
            continue
        out = ctrls["qp_massless"].compute(d.qpos, d.qvel)
        err = out.wrench_left + out.wrench_right - out.wrench_desired
        bound = sum(reg @ w**2 for w in sole_mn) + wts.split * (sole_mn[0][2] - sole_mn[1][2]) ** 2
        assert W @ err**2 <= bound * (1 + 1e-6) + 1e-9
        np.testing.assert_allclose(
            out.wrench_left + out.wrench_right,
            mn.wrench_desired,
            atol=1e-2 * (1 + np.abs(mn.wrench_desired)).max() * 0.05,
        )
        checked += 1
    assert checked >= 10


def test_quadprog_matches_daqp_and_the_kkt_conditions(ctrls, wendlandt_mj):
    m = wendlandt_mj
    a, b = ctrls["qp_human"], ctrls["qp_quadprog"]
    assert (a.qp.solver, b.qp.solver) == ("daqp", "quadprog")
    for i, d in enumerate(random_states(m, 30, 4, vel=2.0)):
        ta = a.compute(d.qpos, d.qvel).torques
        tb = b.compute(d.qpos, d.qvel).torques
        xa, xb = a.qp.x.copy(), b.qp.x.copy()
        np.testing.assert_allclose(xa, xb, atol=1e-4 * (1 + np.abs(xa).max()))
        np.testing.assert_allclose(ta, tb, atol=1e-4 * (1 + np.abs(ta).max()))
        # solver-free certificate (KKT): x feasible and the cost gradient a nonnegative
        # combination of the active rows' normals (NNLS), so x is the convex QP's minimizer
        qp = a.qp
        G, av, C, lo = qp.Gq, qp.av, qp.Ct[: qp.rows], qp.b[: qp.rows]
        scale = 1 + np.abs(xa).max()
        slack = C @ xa - lo
        assert np.all(slack >= -1e-6 * scale)
        act = slack <= 1e-6 * scale
        grad = G @ xa - av
        if act.any():
            _, res = nnls(C[act].T, grad)
        else:
            res = np.linalg.norm(grad)
        assert res <= 1e-6 * (1 + np.linalg.norm(av)), (i, res)
        # one foot in the air: its six wrench entries are equality rows (both solvers agree)
        feet = (True, False) if i % 2 else (False, True)
        ta = a.compute(d.qpos, d.qvel, feet_in_contact=feet).torques
        tb = b.compute(d.qpos, d.qvel, feet_in_contact=feet).torques
        assert a.qp.status == b.qp.status == SOLVED
        np.testing.assert_allclose(a.qp.x, b.qp.x, atol=1e-4 * (1 + np.abs(b.qp.x).max()))
        np.testing.assert_allclose(ta, tb, atol=1e-4 * (1 + np.abs(tb).max()))


def test_a_foot_in_the_air_carries_nothing(ctrls, wendlandt_mj):
    ctrl = ctrls["qp_human"]
    right = [i for i, n in enumerate(ctrl.joint_names) if n.startswith("right")]
    for d in random_states(wendlandt_mj, 5, 5):
        out = ctrl.compute(d.qpos, d.qvel, feet_in_contact=(True, False))
        assert np.all(out.foot_wrench_right == 0) and np.all(out.wrench_right == 0)
        assert np.all(out.torques[right] == 0)
        assert out.foot_wrench_left[2] != 0
        out = ctrl.compute(d.qpos, d.qvel, feet_in_contact=(False, False))
        assert np.all(out.torques == 0)


@pytest.mark.parametrize("solver", ["quadprog", "daqp"])
@pytest.mark.parametrize("weights", [QPWeights(leg_weight=0.0), QPWeights(min_normal_n=400.0)])
def test_infeasible_qp_falls_back_without_an_exception(wendlandt_path, wendlandt_mj, solver, weights):
    """Limits too small for the minimum normal force: the QP is solved without it (documented).
    With the legs' weight in the cones the ground carries 142 N a foot at zero torque, so the
    minimum normal force must exceed that to make the QP infeasible."""
    from biped.control.limits import TorqueLimits

    tiny = TorqueLimits("tiny", HUMAN.joint_names, -0.01 * np.ones(12), 0.01 * np.ones(12))
    ctrl = WorkspaceController.from_mjcf(
        wendlandt_path, distribution="qp", torque_limits=tiny, qp_solver=solver, qp_weights=weights
    )
    d = next(random_states(wendlandt_mj, 1, 6))
    tau = ctrl.compute(d.qpos, d.qvel).torques
    assert ctrl.qp.status == RELAXED and ctrl.qp.fallbacks[RELAXED] == 1
    assert np.all(np.abs(tau) <= 0.01 + 1e-9)


@pytest.mark.parametrize("solver", ["quadprog", "daqp"])
def test_a_failed_solve_zeroes_the_wrenches_without_an_exception(wendlandt_path, wendlandt_mj, solver):
    """The documented last fallback, with the real solvers: a desired wrench that is not finite
    (or too large for double precision in the cost) leaves no solution; the call returns zero
    wrenches (status ZEROED, counted) instead of raising, and the next sane state solves again."""
    ctrl = WorkspaceController.from_mjcf(wendlandt_path, distribution="qp", qp_solver=solver, qp_weights=FLAT)
    d = next(random_states(wendlandt_mj, 1, 7))
    good = ctrl.compute(d.qpos, d.qvel).torques
    qp = ctrl.qp
    for k, bad in enumerate(
        (np.full(6, 1e300), np.array([np.inf, 0, 0, 0, 0, 0]), np.array([0, 0, np.nan, 0, 0, 0]))
    ):
        qp.build(ctrl._w.g, ctrl._w.gl, ctrl._both, bad)
        x = qp.solve()
        assert qp.status == ZEROED and qp.fallbacks[ZEROED] == k + 1
        assert np.all(x == 0)
    # the same through the controller: the solver itself raising twice ends in zero torques (the
    # Python path; the compiled call's, daqp's C function failing: tests/test_qp_call.py)
    ctrl._qf = ctrl._qi = qp._c = None
    calls = []

    def failing():
        calls.append(1)
        raise ValueError("constraints are inconsistent, no solution")

    qp._solve_once = failing
    out = ctrl.compute(d.qpos, d.qvel)
    assert len(calls) == 2 and qp.status == ZEROED
    assert np.all(out.torques == 0) and np.all(out.foot_wrench_left == 0)
    del qp._solve_once
    np.testing.assert_allclose(ctrl.compute(d.qpos, d.qvel).torques, good, rtol=1e-9, atol=1e-9)
    assert qp.status == SOLVED


def test_bad_qp_settings_are_one_line_errors(wendlandt_path):
    with pytest.raises(ScenarioError, match="moment"):
        QPWeights(moment=-1.0)
    with pytest.raises(ScenarioError, match="max_normal_n"):
        QPWeights(min_normal_n=100.0, max_normal_n=50.0)
    with pytest.raises(ScenarioError, match="distribution"):
        WorkspaceController.from_mjcf(wendlandt_path, distribution="lp")
    with pytest.raises(ScenarioError, match="leg_weight"):
        QPWeights(leg_weight=1.5)


def test_joint_damping_key_reaches_the_plant():
    from biped.sim.scenario import Scenario
    from biped.sim.scene import build_scene

    for value in (0.0, 0.7):
        scene = build_scene(Scenario(joint_damping_n_m_s=value))
        hinge = scene.model.jnt_dofadr[[scene.model.joint(n).id for n in scene.joint_names]]
        np.testing.assert_array_equal(scene.model.dof_damping[hinge], value)
    with pytest.raises(ScenarioError, match="joint_damping_n_m_s"):
        Scenario(joint_damping_n_m_s=-1.0)
    with pytest.raises(ScenarioError, match="distribution"):
        Scenario(distribution="lp")
    with pytest.raises(ScenarioError, match="qp_leg_weight"):
        Scenario(qp_leg_weight=-0.5)


@pytest.mark.slow
def test_w_default_push_recovers_with_the_qp():
    from biped.sim.push import simulate
    from biped.sim.scenario import Scenario

    result = simulate(Scenario(distribution="qp"))
    assert result.recovered and not result.fell and result.diverged is None
    # W's timeline: both heels rise after the block hits and come back down
    hit = result.block_contact_time_s
    for foot in ("left", "right"):
        kinds = [e.kind for e in result.events if e.foot == foot and e.time_s >= hit]
        assert "lift_off" in kinds and kinds[-1] == "touch_down"


def test_the_qp_policy_always_senses_the_feet(wendlandt_mj):
    """With W's fixed support the QP kept loading feet that had left the floor (sweep trials
    diverged); the "qp" policy takes the sensed feet whatever ``support`` says."""
    from biped.control.policy import PolicyConfig, make_policy

    d = next(random_states(wendlandt_mj, 1, 8))
    qp = make_policy(PolicyConfig(distribution="qp", support="fixed"))
    ws = make_policy(PolicyConfig(distribution="statics", support="fixed"))
    right = [i for i, n in enumerate(qp.joint_names) if n.startswith("right")]
    tau = qp(d.qpos, d.qvel, (True, False))
    assert np.all(tau[right] == 0) and np.any(tau != 0)
    assert np.any(ws(d.qpos, d.qvel, (True, False))[right] != 0)  # W's fixed feet ignore it
    both = qp(d.qpos, d.qvel, (True, True)).copy()
    assert np.any(both[right] != 0)


def test_unlimited_qp_torques_are_alg6_of_the_shares(ctrls, wendlandt_path, wendlandt_mj):
    """Without torque limits the QP's torques come from one Alg. 6 pass over the legs' shares
    instead of the torque map T x; both equal Alg. 6 of the shares (``leg_torques``, checked
    against MuJoCo in test_control_mujoco) and each other (limits too wide to bind)."""
    from biped.control.limits import TorqueLimits

    wide = TorqueLimits("wide", HUMAN.joint_names, -1e7 * np.ones(12), 1e7 * np.ones(12))
    mapped = WorkspaceController.from_mjcf(
        wendlandt_path, distribution="qp", torque_limits=wide, qp_weights=FLAT
    )
    ctrl = ctrls["qp"]
    assert not ctrl.qp.limited and mapped.qp.limited
    for i, d in enumerate(random_states(wendlandt_mj, 10, 9, vel=1.0)):
        feet = ((True, True), (True, False), (False, True))[i % 3]
        out = ctrl.compute(d.qpos, d.qvel, feet_in_contact=feet)
        ref = mapped.compute(d.qpos, d.qvel, feet_in_contact=feet)
        scale = 1 + np.abs(out.torques).max()
        np.testing.assert_allclose(
            out.torques, ctrl.leg_torques(d.qpos, out.wrench_left, out.wrench_right), atol=1e-9 * scale
        )
        np.testing.assert_allclose(out.torques, ref.torques, atol=1e-6 * scale)


def _leg_weight_mujoco(m, d, foot, sole):
    """The ground's wrench carrying one leg's weight, in the sole frame at the sole centre, from
    MuJoCo alone: the leg's subtree mass and centre of mass, the sole frame from MuJoCo's pose."""
    hip = m.body(f"{foot}_hip_1").id
    f = -m.body_subtreemass[hip] * m.opt.gravity
    b = m.body(f"{foot}_foot").id
    g0s = transform(d.ximat[b].reshape(3, 3), d.xipos[b]) @ sole.g_foot_sole
    R, p = g0s[:3, :3], g0s[:3, 3]
    return np.concatenate([R.T @ f, R.T @ np.cross(d.subtree_com[hip] - p, f)]), g0s


def test_the_legs_weight_in_the_cones_is_mujocos(ctrls, wendlandt_mj, soles):
    """The default QP's cones hold the ground's wrench: the leg's share plus the leg's weight.
    That weight (ContactQP.wg) is MuJoCo's subtree mass at its subtree COM; the ground wrench
    meets the normal-force, friction, lateral-CoP rows and the CoP row of the sole edge nearer
    the weight line; the share alone meets the far edge's CoP row and the yaw rows (the NNLS
    test above checks those rows against the cone's definition)."""
    m, ctrl = wendlandt_mj, ctrls["qp_human"]
    wts = ctrl.qp.weights
    mu = wts.friction * wts.friction_scale
    assert wts.leg_weight == 1.0  # the default
    beyond_share = 0
    for d in random_states(m, 30, 11, vel=2.0):
        out = ctrl.compute(d.qpos, d.qvel)
        assert ctrl.qp.status == SOLVED
        sole_w, _ = _sole_wrenches(m, d, out, soles)
        for f, (foot, w, sole) in enumerate(zip(("left", "right"), sole_w, soles, strict=True)):
            wg, _ = _leg_weight_mujoco(m, d, foot, sole)
            np.testing.assert_allclose(ctrl.qp.wg[f], wg, atol=1e-9 * np.linalg.norm(wg))
            X, Y = sole.half_length, sole.half_width
            gw = w + wg  # the ground's wrench on the foot, quasi-static
            tol = 1e-6 * max(1.0, np.linalg.norm(gw))
            assert wts.min_normal_n - tol <= gw[2] <= wts.max_normal_n + tol
            assert abs(gw[0]) <= mu * gw[2] + tol and abs(gw[1]) <= mu * gw[2] + tol
            assert abs(gw[3]) <= Y * gw[2] + tol  # lateral CoP tx / fz inside the sole
            x_leg = -wg[4] / wg[2]  # the weight line's x in the sole frame
            cop_ground = -gw[4] / gw[2]
            if x_leg < 0:  # near edge -X: the ground's CoP; far edge +X: the share's
                assert cop_ground >= -X - tol / gw[2]
                assert -w[4] <= X * w[2] + tol
                beyond_share += w[4] > X * w[2] + 1e-3  # the share's CoP past the near edge
            else:
                assert cop_ground <= X + tol / gw[2]
                assert w[4] <= X * w[2] + tol
                beyond_share += -w[4] > X * w[2] + 1e-3
            Ct, b = _rows(X, Y, mu)
            assert np.all(Ct[10:] @ w - b[10:] >= -tol)  # yaw rows on the share
    # some states used what the legs' weight adds: the share alone lies past the near edge
    assert beyond_share > 0
