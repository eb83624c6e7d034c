"""W Alg. 4 (desired wrench), Alg. 5 (wrench distribution) and the controller's input checks.

References: closed forms of the PD law for states with a known error, finite differences in time
of the body-frame velocity, least squares (numpy.linalg.lstsq) for the minimum-norm split, the
wrench transfer between frames written from statics, MuJoCo's kinematics for the poses.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from biped.control import Gains, Target, WorkspaceController
from biped.control.recursions import alg5_wrench_distribution
from biped.errors import ScenarioError, SingularityError, StateError

OUTPUTS = (
    "torques",
    "P1",
    "z1",
    "accel_desired",
    "wrench_desired",
    "wrench_left",
    "wrench_right",
    "foot_wrench_left",
    "foot_wrench_right",
    "quat_error",
)


@pytest.fixture(scope="module")
def ctrl(wendlandt_path):
    return WorkspaceController.from_mjcf(wendlandt_path)


def near_initial(m, rng):
    """A random state near W's initial posture, any root orientation and velocity."""
    qpos = m.key_qpos[0].copy()
    quat = rng.normal(size=4)
    qpos[3:7] = quat / np.linalg.norm(quat)
    qpos[:3] += rng.normal(0, 0.1, 3)
    qpos[7:] += rng.uniform(-0.4, 0.4, m.nq - 7)
    return qpos, rng.normal(0.0, 1.0, m.nv)


def com_frame_state(m, d, body="central_body"):
    """World COM position, rotation, COM velocity and angular velocity (MuJoCo) of a body."""
    b = m.body(body).id
    mujoco.mj_forward(m, d)
    vel = np.zeros(6)
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, b, vel, 0)  # [rot; lin], world axes
    return d.xipos[b].copy(), d.ximat[b].reshape(3, 3).copy(), vel[3:].copy(), vel[:3].copy()


def quat_of(R):
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R).reshape(-1))
    return q


def rotvec_quat(v):
    q = np.zeros(4)
    mujoco.mju_axisAngle2Quat(q, v / np.linalg.norm(v), np.linalg.norm(v))
    return q


# --------------------------------------------------------------------------- W Alg. 4


def _body_velocity(t, R, pdot, acc, w, alpha):
    """V^b(t) = [R(t)^T pdot(t); R(t)^T w(t)] of a motion with world COM velocity pdot + acc t,
    angular velocity w + alpha t (space frame) and R(t) = exp(w^ t) R (exact to first order)."""
    q = np.zeros(4)
    mujoco.mju_mulQuat(q, rotvec_quat(w * t), quat_of(R))
    Rm = np.zeros(9)
    mujoco.mju_quat2Mat(Rm, q)
    Rm = Rm.reshape(3, 3)
    return np.concatenate([Rm.T @ (pdot + acc * t), Rm.T @ (w + alpha * t)])


def test_alg4_quaternion_sign_does_not_matter(ctrl, wendlandt_mj):
    rng = np.random.default_rng(6)
    for _ in range(5):
        qpos, qvel = near_initial(wendlandt_mj, rng)
        target = Target(
            com=tuple(rng.normal(0, 0.1, 3) + [0, 0, 1]),
            quat=tuple(rotvec_quat(rng.normal(size=3))),
            ang_vel=tuple(rng.normal(size=3)),
            ang_acc=tuple(rng.normal(size=3)),
        )
        ref = ctrl.compute(qpos, qvel, target=target)
        flipped = qpos.copy()
        flipped[3:7] *= -1.0
        neg_target = Target(
            com=target.com, quat=tuple(-np.array(target.quat)), ang_vel=target.ang_vel, ang_acc=target.ang_acc
        )
        for q, t in ((flipped, target), (qpos, neg_target), (flipped, neg_target)):
            out = ctrl.compute(q, qvel, target=t)
            for name in OUTPUTS:
                np.testing.assert_allclose(getattr(out, name), getattr(ref, name), rtol=1e-9, atol=1e-8)
        # a quaternion of any nonzero norm means the same orientation (MuJoCo normalizes it)
        scaled = qpos.copy()
        scaled[3:7] *= 3.0
        out = ctrl.compute(scaled, qvel, target=target)
        for name in OUTPUTS:
            np.testing.assert_allclose(getattr(out, name), getattr(ref, name), rtol=1e-9, atol=1e-8)


def test_alg4_zero_error_commands_the_desired_acceleration(ctrl, wendlandt_mj):
    """Target = current COM pose and velocity: X^b is the body-frame acceleration of a motion with
    the desired world accelerations, obtained here by central differences in time of
    V^b(t) = [R(t)^T pdot(t); R(t)^T w(t)]; F_1^bd = P_1 X^b + z_1."""
    m = wendlandt_mj
    d = mujoco.MjData(m)
    rng = np.random.default_rng(7)
    for _ in range(5):
        d.qpos[:], d.qvel[:] = near_initial(m, rng)
        p, R, pdot, w = com_frame_state(m, d)
        acc, alpha = rng.normal(0, 2, 3), rng.normal(0, 2, 3)
        target = Target(
            com=tuple(p),
            com_vel=tuple(pdot),
            com_acc=tuple(acc),
            quat=tuple(quat_of(R)),
            ang_vel=tuple(w),
            ang_acc=tuple(alpha),
        )
        out = ctrl.compute(d.qpos, d.qvel, target=target)
        h = 1e-5
        args = (R, pdot, acc, w, alpha)
        expected = (_body_velocity(h, *args) - _body_velocity(-h, *args)) / (2 * h)
        np.testing.assert_allclose(out.accel_desired, expected, rtol=0, atol=1e-7)
        np.testing.assert_allclose(out.wrench_desired, out.P1 @ expected + out.z1, rtol=1e-9, atol=1e-6)
        np.testing.assert_allclose(out.quat_error, [1, 0, 0, 0], atol=1e-12)


@pytest.mark.parametrize("angle_deg", [30.0, 200.0])
def test_alg4_pd_law_and_shorter_way_round(ctrl, wendlandt_mj, angle_deg):
    """At rest, COM off by e and rotated by angle about a world axis n from the target:
    X_c^s = -K_c^p e and X_R^s = -K_R^p q_e^v with q_e = +-(cos(a/2), sin(a/2) n), scalar >= 0, so
    past 180 deg the command turns the other (shorter) way."""
    m = wendlandt_mj
    d = mujoco.MjData(m)
    d.qpos[:] = m.key_qpos[0]
    p, R, _, _ = com_frame_state(m, d)
    n = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    a = math.radians(angle_deg)
    Rn = np.zeros(9)
    mujoco.mju_quat2Mat(Rn, rotvec_quat(n * a))
    R_target = Rn.reshape(3, 3).T @ R  # the body is the target rotated by +a about n
    e = np.array([0.02, -0.03, 0.05])
    gains = Gains(kp_com=(10.0, 20.0, 30.0), kp_rot=(40.0, 50.0, 60.0))
    target = Target(com=tuple(p - e), quat=tuple(quat_of(R_target)))
    out = ctrl.compute(d.qpos, d.qvel, target=target, gains=gains)
    qe_vec = math.sin(a / 2) * n * (1.0 if math.cos(a / 2) >= 0 else -1.0)
    np.testing.assert_allclose(out.quat_error[1:], qe_vec, atol=1e-12)
    assert out.quat_error[0] >= 0
    expected = np.concatenate([R.T @ (-np.array(gains.kp_com) * e), R.T @ (-np.array(gains.kp_rot) * qe_vec)])
    np.testing.assert_allclose(out.accel_desired, expected, atol=1e-10)


def test_target_axis_choice_reproduces_the_printed_quaternion():
    # W prints q_{0,d} = (0.99144486, -0.13052619, 0, 0): 15 deg about -X in (s, x, y, z) order
    np.testing.assert_allclose(Target.wendlandt(axis="-x").quat, [0.99144486, -0.13052619, 0, 0], atol=1e-8)
    # the text's reading, -Y, is the default
    np.testing.assert_allclose(Target.wendlandt().quat, [0.99144486, 0, -0.13052619, 0], atol=1e-8)
    np.testing.assert_allclose(Target().quat, Target.wendlandt().quat)
    np.testing.assert_allclose(Target.wendlandt().com, [-0.01, 0.0, 1.14])
    with pytest.raises(ScenarioError, match=r"'z'.*'-x', '-y'"):
        Target.wendlandt(axis="z")
    with pytest.raises(ScenarioError, match="unit quaternion"):
        Target(quat=(1.0, 1.0, 0.0, 0.0))


# --------------------------------------------------------------------------- W Alg. 5


def transfer(g, F):
    """Wrench F = [f; tau] at frame B's origin, B-coordinates -> the same wrench at frame A's
    origin in A-coordinates, g = g_{A,B} (statics: rotate, then add the moment p x f)."""
    R, p = g[:3, :3], g[:3, 3]
    f = R @ F[:3]
    return np.concatenate([f, R @ F[3:] + np.cross(p, f)])


def body_to_feet(m, d):
    """``g_{1,7}``, ``g_{1,13}``: the feet's COM frames in the central body's (MuJoCo kinematics)."""
    mujoco.mj_kinematics(m, d)
    pose = []
    for name in ("central_body", "left_foot", "right_foot"):
        b = m.body(name).id
        g = np.eye(4)
        g[:3, :3], g[:3, 3] = d.ximat[b].reshape(3, 3), d.xipos[b]
        pose.append(g)
    return tuple(np.linalg.solve(pose[0], pose[i]) for i in (1, 2))


def test_alg5_split_sums_and_is_minimum_norm(ctrl, wendlandt_mj):
    m = wendlandt_mj
    d = mujoco.MjData(m)
    rng = np.random.default_rng(8)
    for _ in range(20):
        d.qpos[:], d.qvel[:] = near_initial(m, rng)
        g1l, g1r = body_to_feet(m, d)
        G = np.hstack([np.column_stack([transfer(g, e) for e in np.eye(6)]) for g in (g1l, g1r)])
        out = ctrl.compute(d.qpos, d.qvel)
        Fd = out.wrench_desired
        # the two legs' shares add up to the desired wrench (to rounding)
        np.testing.assert_allclose(
            out.wrench_left + out.wrench_right, Fd, rtol=0, atol=1e-13 * np.abs(Fd).max()
        )
        # each share is its foot's wrench moved to the central body
        np.testing.assert_allclose(
            out.wrench_left, transfer(g1l, out.foot_wrench_left), atol=1e-9 * np.abs(Fd).max()
        )
        np.testing.assert_allclose(
            out.wrench_right, transfer(g1r, out.foot_wrench_right), atol=1e-9 * np.abs(Fd).max()
        )
        # minimum-norm solution of G [F_l; F_r] = F_1^bd
        x = np.linalg.lstsq(G, Fd, rcond=None)[0]
        np.testing.assert_allclose(
            np.concatenate([out.foot_wrench_left, out.foot_wrench_right]),
            x,
            rtol=0,
            atol=1e-10 * np.abs(x).max(),
        )


def _coincident_feet_xml(path) -> str:
    """W's biped with the right hip moved onto the left one and the left leg's axes: both feet
    coincide whenever both legs have the same joint angles."""
    xml = path.read_text()
    xml = xml.replace('name="right_hip_1" pos="0 0.0839788', 'name="right_hip_1" pos="0 -0.0839788')
    for right, left in (('"1 -0 -0"', '"-1 0 0"'), ('"-0 -0 1"', '"0 0 -1"'), ('"-1 -0 -0"', '"1 0 0"')):
        assert xml.count(right) == 1
        xml = xml.replace(right, left)
    return xml


def test_alg5_coincident_feet_share_equally(wendlandt_path):
    """G G^T = Ad^T Ad + Ad^T Ad is a sum of two positive-definite matrices, never singular: with
    coincident feet (G = [A^T A^T]) the minimum-norm split gives each foot exactly half."""
    m = mujoco.MjModel.from_xml_string(_coincident_feet_xml(wendlandt_path))
    d = mujoco.MjData(m)
    ctrl = WorkspaceController.from_mjcf(m)
    rng = np.random.default_rng(9)
    for _ in range(5):
        d.qpos[:] = m.key_qpos[0]
        d.qpos[7:13] += rng.uniform(-0.4, 0.4, 6)
        d.qpos[13:19] = d.qpos[7:13]
        d.qvel[:] = rng.normal(size=m.nv)
        d.qvel[12:18] = d.qvel[6:12]
        mujoco.mj_kinematics(m, d)
        lf, rf = m.body("left_foot").id, m.body("right_foot").id
        np.testing.assert_array_equal(d.xipos[lf], d.xipos[rf])
        out = ctrl.compute(d.qpos, d.qvel)
        np.testing.assert_allclose(out.wrench_left, 0.5 * out.wrench_desired, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(out.wrench_right, 0.5 * out.wrench_desired, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(out.foot_wrench_left, out.foot_wrench_right, rtol=1e-12, atol=1e-9)


def test_alg5_reports_a_numerically_singular_distribution():
    """G G^T is singular to double precision only when the feet are absurdly far from the body
    (cond(G G^T) ~ |p|^4); then the kernel refuses instead of returning garbage."""
    legs = "".join(
        f'<body name="{s}1" pos="0 {y} 0"><joint name="{s}j" axis="1 0 0"/><geom size="0.1"/>'
        f'<body name="{s}foot" pos="0 0 -1e9"><joint name="{s}k" axis="0 1 0"/><geom size="0.1"/>'
        f"</body></body>"
        for s, y in (("l", -0.1), ("r", 0.1))
    )
    xml = (
        f'<mujoco><worldbody><body name="torso"><freejoint/><geom size="0.2"/>{legs}'
        f"</body></worldbody></mujoco>"
    )
    ctrl = WorkspaceController.from_mjcf(xml, feet=("lfoot", "rfoot"))
    qpos = np.zeros(ctrl.tree.nq)
    qpos[3] = 1.0
    with pytest.raises(SingularityError, match=r"G G\^T is singular"):
        ctrl.compute(qpos, np.zeros(ctrl.tree.nv))
    # the kernel function itself: non-finite poses are refused, finite nearby ones are not
    g = np.tile(np.eye(4), (3, 1, 1))
    g[1, :3, 3] = [0.1, -0.1, -0.9]
    g[2, :3, 3] = [0.1, 0.1, -0.9]
    args = lambda g: (
        g,
        np.array([1, 2]),
        np.array([1, 1]),
        np.ones(6),
        np.zeros((4, 6)),
        np.zeros((3, 6, 6)),
        np.zeros((2, 3, 3)),
        *(np.zeros(6) for _ in range(4)),
    )
    assert alg5_wrench_distribution(*args(g))
    g[2, 0, 3] = np.nan
    assert not alg5_wrench_distribution(*args(g))


# --------------------------------------------------------------------------- bad input


def test_bad_states_raise_state_errors(ctrl, wendlandt_mj):
    qpos, qvel = wendlandt_mj.key_qpos[0].copy(), np.zeros(18)
    for call in (ctrl.compute, ctrl.torques, ctrl.link_velocities):
        for arr, i, val, where in (
            (qpos, 2, np.nan, "qpos[2]"),
            (qvel, 9, np.inf, "qvel[9]"),
            (qpos, 10, -np.inf, "qpos[10]"),
        ):
            bad = arr.copy()
            bad[i] = val
            args = (bad, qvel) if arr is qpos else (qpos, bad)
            with pytest.raises(StateError, match=rf"non-finite.*{re_escape(where)}"):
                call(*args)
        with pytest.raises(StateError, match=r"qpos must have shape \(19,\).*got \(18,\)"):
            call(qpos[:18], qvel)
        with pytest.raises(StateError, match=r"qvel \(18,\).*\(17,\)"):
            call(qpos, qvel[:17])
        zero = qpos.copy()
        zero[3:7] = 0.0
        with pytest.raises(StateError, match=r"root quaternion qpos\[3:7\] is zero"):
            call(zero, qvel)
    with pytest.raises(StateError, match="qpos must have shape"):
        ctrl.link_poses(np.zeros(7))
    with pytest.raises(ScenarioError, match="big_base must be a positive"):
        WorkspaceController(ctrl.tree, big_base=0.0)
    with pytest.raises(ScenarioError, match="target com must have 3 entries"):
        Target(com=(0.0, 1.0))
    with pytest.raises(ScenarioError, match="gains kp_rot must be finite"):
        Gains(kp_rot=(1.0, np.nan, 1.0))
    # a failed call leaves the controller usable
    np.testing.assert_allclose(ctrl.compute(qpos, qvel).torques, ctrl.compute(qpos, qvel).torques)


def re_escape(s):
    import re

    return re.escape(s)


def _adjoint_T(g):
    """Ad_g^T (6, 6) of a 4x4 transform, written out here from W eq. 3.7."""
    R, p = g[:3, :3], g[:3, 3]
    phat = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
    A = np.zeros((6, 6))
    A[:3, :3], A[:3, 3:], A[3:, 3:] = R, phat @ R, R
    return A.T


def test_alg5_printed_reading_is_selectable_and_differs(wendlandt_path, wendlandt_mj):
    """distribution="printed" follows W's print G = [Ad^T_{g_{1,7}} Ad^T_{g_{1,13}}] literally:
    its shares still sum to F_1^bd and are the minimum-norm solution of *that* G (numpy lstsq on
    MuJoCo's poses), and they differ from the statics split of the default."""
    m = wendlandt_mj
    d = mujoco.MjData(m)
    printed = WorkspaceController.from_mjcf(wendlandt_path, distribution="printed")
    statics = WorkspaceController.from_mjcf(wendlandt_path)
    rng = np.random.default_rng(21)
    for _ in range(10):
        d.qpos[:], d.qvel[:] = near_initial(m, rng)
        A1l, A1r = (_adjoint_T(g) for g in body_to_feet(m, d))
        out = printed.compute(d.qpos, d.qvel)
        Fd = out.wrench_desired
        scale = np.abs(Fd).max()
        np.testing.assert_allclose(out.wrench_left + out.wrench_right, Fd, rtol=0, atol=1e-12 * scale)
        x = np.linalg.lstsq(np.hstack([A1l, A1r]), Fd, rcond=None)[0]
        np.testing.assert_allclose(
            np.concatenate([out.foot_wrench_left, out.foot_wrench_right]),
            x,
            rtol=0,
            atol=1e-10 * np.abs(x).max(),
        )
        np.testing.assert_allclose(out.wrench_left, A1l @ x[:6], rtol=0, atol=1e-9 * scale)
        ref = statics.compute(d.qpos, d.qvel)
        np.testing.assert_allclose(ref.wrench_desired, Fd, rtol=1e-12, atol=1e-9)
        assert np.abs(ref.wrench_left - out.wrench_left).max() > 1e-3 * scale


def test_unknown_distribution_is_rejected(wendlandt_path):
    with pytest.raises(ScenarioError, match="valid: \\('statics', 'printed', 'qp'\\)"):
        WorkspaceController.from_mjcf(wendlandt_path, distribution="paper")
