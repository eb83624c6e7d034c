"""The constants of W's biped that biped.models defines once agree with what MuJoCo compiles from
the shipped MJCF: hinge names and order, W's initial state in the keyframe, total mass, gravity."""

from __future__ import annotations

import mujoco
import numpy as np

from biped import models
from biped.control import WorkspaceController
from biped.control.limits import MODEL_MASS_KG, torque_limits
from biped.sim.scenario import Scenario
from biped.sim.scene import build_scene


def test_joint_names_are_the_mjcf_hinges_in_w_order(wendlandt_mj):
    m = wendlandt_mj
    hinges = [m.joint(j).name for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    assert tuple(hinges) == models.JOINT_NAMES  # MuJoCo's qpos order = W's theta_2..theta_13
    # the controller's torques and the torque limits come in this order
    assert WorkspaceController.from_mjcf(models.path("wendlandt")).joint_names == models.JOINT_NAMES
    assert torque_limits("human").joint_names == models.JOINT_NAMES


def test_keyframe_is_w_initial_state(wendlandt_mj):
    m = wendlandt_mj
    q = m.key_qpos[m.key("wendlandt_initial").id]
    hinge_q = [q[m.jnt_qposadr[m.joint(n).id]] for n in models.JOINT_NAMES]
    np.testing.assert_allclose(np.degrees(hinge_q), models.W_INITIAL_ANGLES_DEG, atol=1e-7)
    np.testing.assert_allclose(q[:3], models.W_INITIAL_COM_M, atol=1e-12)
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    R = d.xmat[m.body("central_body").id].reshape(3, 3)
    tilt = np.radians(models.W_INITIAL_TILT_DEG)  # about -y: the body's z axis leans toward -x
    np.testing.assert_allclose(R[:, 2], [-np.sin(tilt), 0.0, np.cos(tilt)], atol=1e-6)


def test_mass_and_gravity_are_the_models(wendlandt_mj):
    assert abs(MODEL_MASS_KG - mujoco.mj_getTotalmass(wendlandt_mj)) < 1e-12
    assert round(MODEL_MASS_KG, 2) == 73.06
    np.testing.assert_array_equal(models.gravity(), wendlandt_mj.opt.gravity)
    np.testing.assert_array_equal(build_scene(Scenario()).model.opt.gravity, wendlandt_mj.opt.gravity)
