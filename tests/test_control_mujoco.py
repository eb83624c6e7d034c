"""W Alg. 6 and the whole controller against MuJoCo's kinematics and dynamics.

- Alg. 6: torques = J^T F~ per leg, J from central finite differences of the foot-to-body
  transform in MuJoCo's forward kinematics (foot fixed, the central body moves).
- Static check: the biped with both feet fixed, at rest at a target pose, is held still by the
  computed torques: with MuJoCo's mass matrix, bias forces and foot Jacobians (hard constraints),
  and with MuJoCo's own (soft) weld constraints.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from biped.control import Target, WorkspaceController


def foot_to_body(m, d, foot: int, body: int) -> np.ndarray:
    """4x4 pose of the body's COM frame in the foot's COM frame, from MuJoCo's xipos/ximat."""

    def pose(b):
        g = np.eye(4)
        g[:3, :3] = d.ximat[b].reshape(3, 3)
        g[:3, 3] = d.xipos[b]
        return g

    return np.linalg.solve(pose(foot), pose(body))


def leg_jacobian_fd(m, qpos, foot_name: str, body_name: str, h: float = 1e-6):
    """(6, nv) J with V_body^b = J qdot when the foot is fixed (root columns zero), by central
    differences: column j = vee(g^-1 dg/dtheta_j), g = g_{foot, body}."""
    d = mujoco.MjData(m)
    foot, body = m.body(foot_name).id, m.body(body_name).id
    J = np.zeros((6, m.nv))
    for j in range(1, m.njnt):
        gs = []
        for s in (1.0, -1.0):
            d.qpos[:] = qpos
            d.qpos[m.jnt_qposadr[j]] += s * h
            mujoco.mj_kinematics(m, d)
            gs.append(foot_to_body(m, d, foot, body))
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        g = foot_to_body(m, d, foot, body)
        X = np.linalg.solve(g, (gs[0] - gs[1]) / (2 * h))
        J[:, m.jnt_dofadr[j]] = [X[0, 3], X[1, 3], X[2, 3], X[2, 1], X[0, 2], X[1, 0]]
    return J


def test_alg6_torques_are_jacobian_transpose_per_leg(tree_case):
    path, feet = tree_case
    m = mujoco.MjModel.from_xml_path(str(path))
    ctrl = WorkspaceController.from_mjcf(path, feet=feet)
    body = ctrl.tree.body_names[0]
    hinge_dofs = np.array([m.jnt_dofadr[m.joint(n).id] for n in ctrl.joint_names])
    rng = np.random.default_rng(5)
    for _ in range(10):
        qpos = m.qpos0.copy()
        quat = rng.normal(size=4)
        qpos[3:7] = quat / np.linalg.norm(quat)
        qpos[7:] += rng.uniform(-np.pi, np.pi, m.nq - 7)
        Fl, Fr = rng.normal(0, 100, 6), rng.normal(0, 100, 6)
        tau = ctrl.leg_torques(qpos, Fl, Fr)
        expected = np.zeros(m.nv)
        for foot, F in zip(feet, (Fl, Fr), strict=True):
            J = leg_jacobian_fd(m, qpos, foot, body)
            expected += J.T @ F  # the other leg's columns are zero in J
        np.testing.assert_allclose(tau, expected[hinge_dofs], rtol=0, atol=1e-8 * np.abs(expected).max())
        # and the full controller passes its own split through the same recursion
        out = ctrl.compute(qpos, rng.normal(size=m.nv))
        np.testing.assert_allclose(
            out.torques, ctrl.leg_torques(qpos, out.wrench_left, out.wrench_right), rtol=1e-12, atol=1e-9
        )


# --------------------------------------------------------------------------- static check

FEET = ("left_foot", "right_foot")


def body_jacobian(m, d, b):
    """(6, nv) Jacobian of body b's COM-frame body velocity [v; w] (MuJoCo, inertial frame)."""
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    mujoco.mj_jacBodyCom(m, d, jp, jr, b)
    R = d.ximat[b].reshape(3, 3)
    return np.vstack([R.T @ jp, R.T @ jr])


def place_central_body(m, qpos, com, quat, feet=FEET, iters=50):
    """qpos with the central body's COM frame at (com, quat) and the feet's body frames where
    they are in ``qpos`` (Newton's method on MuJoCo's kinematics and Jacobians)."""
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    ids = [m.body(f).id for f in feet]
    goal = [(d.xpos[b].copy(), d.xmat[b].reshape(3, 3).copy()) for b in ids]
    root = m.body("central_body").id
    Ri = np.zeros(9)
    mujoco.mju_quat2Mat(Ri, m.body_iquat[root])
    Rt = np.zeros(9)
    mujoco.mju_quat2Mat(Rt, np.asarray(quat, dtype=float))
    Rb = Rt.reshape(3, 3) @ Ri.reshape(3, 3).T
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, Rb.reshape(-1))
    d.qpos[3:7] = q
    d.qpos[:3] = np.asarray(com) - Rb @ m.body_ipos[root]
    for _ in range(iters):
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        err, rows = [], []
        for b, (p, R) in zip(ids, goal, strict=True):
            Rc = d.xmat[b].reshape(3, 3)
            S = R @ Rc.T
            err += [p - d.xpos[b], 0.5 * np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]])]
            jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
            mujoco.mj_jacBody(m, d, jp, jr, b)
            rows += [jp[:, 6:], jr[:, 6:]]
        e = np.concatenate(err)
        if np.abs(e).max() < 1e-13:
            return d.qpos.copy()
        d.qpos[7:] += np.linalg.solve(np.vstack(rows), e)
    raise AssertionError(f"inverse kinematics did not converge: {np.abs(e).max()}")


def hard_constraint_qacc(m, d, tau):
    """MuJoCo's dynamics with both feet rigidly fixed (feet at rest): M qdd + c = tau + Jc^T lam,
    Jc qdd = 0 (the Jc-dot qd term vanishes at rest)."""
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, M, d.qM) if hasattr(d, "qM") else mujoco.mj_fullM(m, d, M)
    Jc = np.vstack([body_jacobian(m, d, m.body(f).id) for f in FEET])
    Mi = np.linalg.inv(M)
    rhs = tau - d.qfrc_bias
    lam = np.linalg.solve(Jc @ Mi @ Jc.T, -Jc @ Mi @ rhs)
    return Mi @ (rhs + Jc.T @ lam)


def welded(m_source_xml: str) -> mujoco.MjModel:
    """The biped with both feet welded to the world by MuJoCo equality constraints (as stiff as
    MuJoCo allows: impedance 0.9999)."""
    eq = "".join(
        f'<weld name="{f}_weld" body1="{f}" solimp="0.9999 0.9999 0.001" solref="0.004 1"/>' for f in FEET
    )
    xml = m_source_xml.replace("<actuator>", f"<equality>{eq}</equality>\n  <actuator>", 1)
    return mujoco.MjModel.from_xml_string(xml)


def weld_in_place(m, d):
    """Set the welds' relative poses to the feet's current poses (zero constraint violation)."""
    mujoco.mj_kinematics(m, d)
    for e, f in enumerate(FEET):
        b = m.body(f).id
        R = d.xmat[b].reshape(3, 3)
        m.eq_data[e, 3:6] = -R.T @ d.xpos[b]  # the world's pose in the foot's frame
        m.eq_data[e, 6:10] = d.xquat[b] * [1, -1, -1, -1]


def _target_here(m, d):
    root = m.body("central_body").id
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, d.ximat[root])
    return Target(com=tuple(d.xipos[root]), quat=tuple(q))


@pytest.mark.parametrize("pose", ["w_initial", "w_set_point"])
def test_static_torques_hold_the_biped_with_feet_fixed(wendlandt_path, pose):
    base = mujoco.MjModel.from_xml_path(str(wendlandt_path))
    m = welded(wendlandt_path.read_text())
    d = mujoco.MjData(m)
    qpos = base.key_qpos[base.key("wendlandt_initial").id].copy()
    if pose == "w_set_point":  # W's set point: COM (-1, 0, 114) cm, 15 deg about -y; feet in place
        target = Target.wendlandt()
        qpos = place_central_body(base, qpos, target.com, target.quat)
    d.qpos[:] = qpos
    d.qvel[:] = 0.0
    weld_in_place(m, d)
    mujoco.mj_forward(m, d)
    assert np.abs(d.efc_pos).max() < 1e-12
    root = m.body("central_body").id
    target = _target_here(m, d) if pose == "w_initial" else Target.wendlandt()
    if pose == "w_set_point":
        np.testing.assert_allclose(d.xipos[root], target.com, atol=1e-12)
    ctrl = WorkspaceController.from_mjcf(wendlandt_path)
    out = ctrl.compute(d.qpos, d.qvel, target=target)
    np.testing.assert_allclose(out.accel_desired, 0.0, atol=1e-9)  # at the target, at rest
    tau = np.zeros(m.nv)
    tau[[m.jnt_dofadr[m.joint(n).id] for n in ctrl.joint_names]] = out.torques
    J1 = body_jacobian(m, d, root)
    # rigid feet: every joint and the body stay at rest (only the 1e-6 big-base error remains)
    idle = hard_constraint_qacc(m, d, np.zeros(m.nv))
    held = hard_constraint_qacc(m, d, tau)
    assert np.linalg.norm(idle) > 5.0
    assert np.abs(held).max() < 1e-5 * np.abs(idle).max()
    assert np.abs(J1 @ held).max() < 1e-5 * np.abs(J1 @ idle).max()
    # MuJoCo's own weld constraints are soft (impedance < 1): the light hip and ankle bodies leak
    # part of the unconstrained acceleration into the legs, yet the central body stays put
    d.qfrc_applied[:] = 0.0
    mujoco.mj_forward(m, d)
    idle_mj = J1 @ d.qacc
    d.qfrc_applied[:] = tau
    mujoco.mj_forward(m, d)
    held_mj = J1 @ d.qacc
    assert np.linalg.norm(held_mj) < 0.03 * np.linalg.norm(idle_mj), (held_mj, idle_mj)
