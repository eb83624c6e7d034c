"""Sensed support (beyond W): feet flagged off the ground are not big bases (Alg. 3) and take no
share of the desired wrench (Alg. 5). Checked against the exact workspace inertia of the same
constraint set computed from MuJoCo's mass matrix and body Jacobians, and against closed forms."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from biped.control import WorkspaceController
from biped.errors import StateError


def _body_jacobian(m, d, name):
    """Jacobian of the body twist [v; w] of a body's COM principal frame, in that frame (MuJoCo)."""
    b = m.body(name).id
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    mujoco.mj_jacBodyCom(m, d, jp, jr, b)
    R = d.ximat[b].reshape(3, 3)
    return np.vstack([R.T @ jp, R.T @ jr])


def _exact_workspace_inertia(m, d, fixed_feet):
    """(J1 K J1^T)^-1 with K the constrained inverse inertia for the given fixed feet (none: the
    free-floating system's operational-space inertia of the central body)."""
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    Mi = np.linalg.inv(M)
    J1 = _body_jacobian(m, d, "central_body")
    K = Mi
    if fixed_feet:
        Jc = np.vstack([_body_jacobian(m, d, f) for f in fixed_feet])
        K = Mi - Mi @ Jc.T @ np.linalg.solve(Jc @ Mi @ Jc.T, Jc @ Mi)
    return np.linalg.inv(J1 @ K @ J1.T)


def _state(m, rng):
    d = mujoco.MjData(m)
    d.qpos[:] = m.key_qpos[0]
    d.qpos[7:] += rng.uniform(-0.3, 0.3, m.nq - 7)
    d.qvel[:] = rng.normal(0.0, 1.0, m.nv)
    mujoco.mj_forward(m, d)
    return d


@pytest.fixture(scope="module")
def ctrl(wendlandt_path):
    return WorkspaceController.from_mjcf(wendlandt_path)


@pytest.mark.parametrize(
    "flags, fixed",
    [
        ((True, False), ("left_foot",)),
        ((False, True), ("right_foot",)),
        ((True, True), ("left_foot", "right_foot")),
    ],
)
def test_p1_equals_the_exact_inertia_of_the_feet_in_contact(ctrl, wendlandt_mj, flags, fixed):
    rng = np.random.default_rng(5)
    for _ in range(5):
        d = _state(wendlandt_mj, rng)
        exact = _exact_workspace_inertia(wendlandt_mj, d, fixed)
        P1 = ctrl.compute(d.qpos, d.qvel, feet_in_contact=flags).P1
        assert np.linalg.norm(P1 - exact) / np.linalg.norm(exact) < 1e-4


def test_no_foot_down_gives_the_free_floating_inertia_and_no_torque(ctrl, wendlandt_mj):
    """With no big base the AB recursion is exact: P1 is the free-floating operational-space
    inertia of the central body to rounding, and no wrench is distributed."""
    rng = np.random.default_rng(6)
    for _ in range(5):
        d = _state(wendlandt_mj, rng)
        out = ctrl.compute(d.qpos, d.qvel, feet_in_contact=(False, False))
        exact = _exact_workspace_inertia(wendlandt_mj, d, ())
        np.testing.assert_allclose(out.P1, exact, rtol=0, atol=1e-9 * np.abs(exact).max())
        assert not out.torques.any()
        assert not out.wrench_left.any() and not out.wrench_right.any()


def test_one_foot_down_takes_the_whole_wrench_and_the_free_leg_is_passive(ctrl, wendlandt_mj):
    rng = np.random.default_rng(7)
    names = ctrl.joint_names
    right = np.array([n.startswith("right_") for n in names])
    d = _state(wendlandt_mj, rng)
    out = ctrl.compute(d.qpos, d.qvel, feet_in_contact=(True, False))
    np.testing.assert_allclose(out.wrench_left, out.wrench_desired, rtol=1e-12, atol=1e-9)
    assert not out.wrench_right.any() and not out.foot_wrench_right.any()
    assert not out.torques[right].any() and out.torques[~right].any()
    # the stance leg's torques are Alg. 6 of the whole wrench on that leg alone
    np.testing.assert_allclose(
        out.torques, ctrl.leg_torques(d.qpos, out.wrench_desired, np.zeros(6)), rtol=1e-10, atol=1e-9
    )


def test_default_is_both_feet_fixed_as_in_w(ctrl, wendlandt_mj):
    d = _state(wendlandt_mj, np.random.default_rng(8))
    a = ctrl.compute(d.qpos, d.qvel)
    b = ctrl.compute(d.qpos, d.qvel, feet_in_contact=(True, True))
    np.testing.assert_array_equal(a.torques, b.torques)


def test_bad_contact_flags_are_rejected(ctrl, wendlandt_mj):
    d = _state(wendlandt_mj, np.random.default_rng(9))
    with pytest.raises(StateError, match="pair of booleans"):
        ctrl.compute(d.qpos, d.qvel, feet_in_contact=True)
