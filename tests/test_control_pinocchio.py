"""W Alg. 2 (velocity propagation) and Alg. 3 (workspace dynamics) against Pinocchio.

The same MJCF file is loaded by Pinocchio (``pin.buildModelFromMJCF``); states are converted from
MuJoCo's qpos/qvel layout. Pinocchio's joint frames are MuJoCo's body frames; W's link frames are
MuJoCo's inertial frames (COM, principal axes), reached by the constant offset ``(body_ipos,
body_iquat)`` of each body.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from biped.control import Target, WorkspaceController

pin = pytest.importorskip("pinocchio")


class PinBiped:
    """Pinocchio's model of an MJCF file plus the MuJoCo -> Pinocchio state conversion."""

    def __init__(self, path):
        self.mj = mujoco.MjModel.from_xml_path(str(path))
        self.model = pin.buildModelFromMJCF(str(path))
        # Pinocchio's MJCF parser keeps its default gravity; use the file's
        self.model.gravity = pin.Motion(np.concatenate([self.mj.opt.gravity, np.zeros(3)]))
        self.data = self.model.createData()
        self.qidx, self.vidx = [], []
        for j in range(1, self.mj.njnt):
            jm = self.model.joints[self.model.getJointId(self.mj.joint(j).name)]
            self.qidx.append((self.mj.jnt_qposadr[j], jm.idx_q))
            self.vidx.append((self.mj.jnt_dofadr[j], jm.idx_v))

    def state(self, qpos, qvel):
        """Pinocchio (q, v) of a MuJoCo state of a model whose joint 0 is the free joint.

        MuJoCo: qpos[:7] = world position and (w, x, y, z) quaternion of the root body frame,
        qvel[:3] its origin's world velocity, qvel[3:6] its angular velocity in the body frame.
        Pinocchio: q[:7] = (x, y, z, qx, qy, qz, qw) of the free flyer, which its MJCF parser puts
        after a constant joint placement; v[:6] = [v; w] of the root body in its LOCAL frame.
        """
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, qpos[3:7] / np.linalg.norm(qpos[3:7]))
        R = R.reshape(3, 3)
        placement = self.model.jointPlacements[1].actInv(pin.SE3(R, qpos[:3].copy()))
        q = np.zeros(self.model.nq)
        v = np.zeros(self.model.nv)
        q[:7] = pin.SE3ToXYZQUAT(placement)
        v[:3] = R.T @ qvel[:3]
        v[3:6] = qvel[3:6]
        for a, b in self.qidx:
            q[b] = qpos[a]
        for a, b in self.vidx:
            v[b] = qvel[a]
        return q, v

    def com_frame(self, body: str):
        """(frame id, SE3 body frame -> COM principal frame) of a MuJoCo body."""
        b = self.mj.body(body).id
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, self.mj.body_iquat[b])
        return self.model.getFrameId(body), pin.SE3(R.reshape(3, 3), self.mj.body_ipos[b].copy())


def random_state(m: mujoco.MjModel, rng, speed: float = 1.0):
    """A random MuJoCo (qpos, qvel): any root pose, hinge angles in [-pi, pi] about qpos0."""
    qpos = m.qpos0.copy()
    qpos[:3] = rng.normal(0.0, 1.0, 3)
    quat = rng.normal(size=4)
    qpos[3:7] = quat / np.linalg.norm(quat)
    qpos[7:] += rng.uniform(-np.pi, np.pi, m.nq - 7)
    return qpos, rng.normal(0.0, speed, m.nv)


# --------------------------------------------------------------------------- W Alg. 2


def test_alg2_body_velocities_equal_pinocchio(tree_case):
    path, feet = tree_case
    ctrl = WorkspaceController.from_mjcf(path, feet=feet)
    pb = PinBiped(path)
    frames = [pb.com_frame(name) for name in ctrl.tree.body_names]
    rng = np.random.default_rng(2)
    worst_v = worst_g = 0.0
    for _ in range(100):
        qpos, qvel = random_state(pb.mj, rng, speed=2.0)
        q, v = pb.state(qpos, qvel)
        pin.forwardKinematics(pb.model, pb.data, q, v)
        pin.updateFramePlacements(pb.model, pb.data)
        V = ctrl.link_velocities(qpos, qvel)
        g = ctrl.link_poses(qpos)
        for k, (fid, com) in enumerate(frames):
            body_twist = pin.getFrameVelocity(pb.model, pb.data, fid, pin.LOCAL)
            expected = com.actInv(body_twist).vector  # [v; w] at the COM, principal axes
            worst_v = max(worst_v, np.abs(V[k] - expected).max() / (1 + np.abs(expected).max()))
            pose = (pb.data.oMf[fid] * com).homogeneous
            worst_g = max(worst_g, np.abs(g[k] - pose).max())
    assert worst_v < 1e-12
    assert worst_g < 1e-12


def test_link_poses_equal_mujoco_with_joint_reference_angles(asym_xml_path):
    """MuJoCo's ``ref`` (qpos0) shifts the zero of a hinge; poses must follow MuJoCo's xipos/ximat."""
    xml = (
        asym_xml_path.read_text()
        .replace('name="lj2"', 'name="lj2" ref="0.7"')
        .replace('name="rj3"', 'name="rj3" ref="-1.2"')
    )
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    ctrl = WorkspaceController.from_mjcf(m, feet=("lfoot", "rfoot"))
    ids = [m.body(name).id for name in ctrl.tree.body_names]
    rng = np.random.default_rng(3)
    for _ in range(20):
        d.qpos[:], _ = random_state(m, rng)
        mujoco.mj_kinematics(m, d)
        g = ctrl.link_poses(d.qpos)
        np.testing.assert_allclose(g[:, :3, 3], d.xipos[ids], atol=1e-12)
        np.testing.assert_allclose(g[:, :3, :3], d.ximat[ids].reshape(-1, 3, 3), atol=1e-12)


# --------------------------------------------------------------------------- W Alg. 3


def exact_workspace_dynamics(pb: PinBiped, body: str, feet, qpos, qvel):
    """Exact fixed-feet workspace inertia and bias of ``body`` (its COM principal frame).

    M qdd + c = J1^T F + Jc^T lam,  Jc qdd + Jcdot qd = 0  (both feet's COM frames do not
    accelerate),  V1dot = J1 qdd + J1dot qd. Eliminating qdd and lam:
    F = Lam V1dot + z with Lam = (J1 K J1^T)^-1, K = Mi - Mi Jc^T (Jc Mi Jc^T)^-1 Jc Mi and
    z = Lam (J1 K c + J1 Mi Jc^T (Jc Mi Jc^T)^-1 Jcdot qd - J1dot qd). Body Jacobians and
    J qd-dot terms (spatial accelerations with qdd = 0) in Pinocchio's LOCAL frames.
    """
    model, data = pb.model, pb.data
    q, v = pb.state(qpos, qvel)
    pin.computeJointJacobians(model, data, q)
    pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
    pin.updateFramePlacements(model, data)
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    c = pin.nonLinearEffects(model, data, q, v)

    def jac(name):
        fid, com = pb.com_frame(name)
        X = com.toActionMatrixInverse()  # body frame -> COM frame (constant)
        J = X @ pin.getFrameJacobian(model, data, fid, pin.LOCAL)
        Jdqd = X @ pin.getFrameAcceleration(model, data, fid, pin.LOCAL).vector
        return J, Jdqd

    J1, J1d = jac(body)
    parts = [jac(f) for f in feet]
    Jc = np.vstack([p[0] for p in parts])
    Jcd = np.concatenate([p[1] for p in parts])
    Mi = np.linalg.inv(M)
    Lc = np.linalg.inv(Jc @ Mi @ Jc.T)
    K = Mi - Mi @ Jc.T @ Lc @ Jc @ Mi
    Lam = np.linalg.inv(J1 @ K @ J1.T)
    z = Lam @ (J1 @ K @ c + J1 @ Mi @ Jc.T @ Lc @ Jcd - J1d)
    parts = {"M": M, "c": c, "J1": J1, "J1d": J1d, "Jc": Jc, "Jcd": Jcd, "v": v}
    return Lam, z, parts


def _rel(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


def nominal_state(m: mujoco.MjModel, rng):
    """A random state near the model's first keyframe (or qpos0): any root pose and velocity,
    hinges within 0.4 rad of the nominal bent-knee posture (legs far from singular)."""
    qpos, qvel = random_state(m, rng)
    base = m.key_qpos[0] if m.nkey else m.qpos0
    qpos[7:] = base[7:] + rng.uniform(-0.4, 0.4, m.nq - 7)
    return qpos, qvel


def test_alg3_big_base_converges_to_exact_fixed_feet_dynamics(tree_case):
    """P1 -> (J1 K J1^T)^-1 and z1 -> exact bias, the relative error falling like 1/factor."""
    path, feet = tree_case
    pb = PinBiped(path)
    factors = [1e2, 1e3, 1e4, 1e6]
    ctrls = [WorkspaceController.from_mjcf(path, feet=feet, big_base=f) for f in factors]
    body = ctrls[0].tree.body_names[0]
    rng = np.random.default_rng(4)
    for _ in range(6):
        qpos, qvel = nominal_state(pb.mj, rng)
        Lam, z, _ = exact_workspace_dynamics(pb, body, feet, qpos, qvel)
        for name, exact in (("P1", Lam), ("z1", z)):
            err = np.array([_rel(getattr(c.compute(qpos, qvel), name), exact) for c in ctrls])
            assert 9.0 < err[1] / err[2] < 11.0, (name, err)  # 1e3 -> 1e4
            assert 90.0 < err[2] / err[3] < 110.0, (name, err)  # 1e4 -> 1e6
            assert err[0] < 1e-2 and err[3] < 1e-6, (name, err)


def test_torques_give_the_commanded_acceleration_with_feet_fixed(tree_case):
    """The whole controller (Alg. 1-6): with both feet rigidly fixed, the computed joint torques
    accelerate the central body by the commanded X^b (W Alg. 4), to the big-base error.

    Pinocchio's dynamics with the feet's COM frames held at zero acceleration:
    M qdd + c = S^T tau + Jc^T lam, Jc qdd + Jcdot qd = 0; V1dot = J1 qdd + J1dot qd.
    """
    path, feet = tree_case
    pb = PinBiped(path)
    ctrl = WorkspaceController.from_mjcf(path, feet=feet)
    body = ctrl.tree.body_names[0]
    rng = np.random.default_rng(10)
    for _ in range(6):
        qpos, qvel = nominal_state(pb.mj, rng)
        quat = rng.normal(size=4)
        target = Target(
            com=tuple(rng.normal(0, 0.05, 3) + [0, 0, 1]),
            quat=tuple(quat / np.linalg.norm(quat)),
            com_vel=tuple(rng.normal(size=3)),
            ang_acc=tuple(rng.normal(size=3)),
        )
        out = ctrl.compute(qpos, qvel, target=target)
        _, _, p = exact_workspace_dynamics(pb, body, feet, qpos, qvel)
        tau = np.zeros(pb.model.nv)
        for name, t in zip(ctrl.joint_names, out.torques, strict=True):
            tau[pb.model.joints[pb.model.getJointId(name)].idx_v] = t
        Mi = np.linalg.inv(p["M"])
        Jc = p["Jc"]
        lam = np.linalg.solve(Jc @ Mi @ Jc.T, -p["Jcd"] - Jc @ Mi @ (tau - p["c"]))
        qdd = Mi @ (tau - p["c"] + Jc.T @ lam)
        V1dot = p["J1"] @ qdd + p["J1d"]
        assert np.abs(out.accel_desired).max() > 1.0  # a real command, not a trivial zero
        np.testing.assert_allclose(
            V1dot, out.accel_desired, rtol=0, atol=1e-5 * np.abs(out.accel_desired).max()
        )
