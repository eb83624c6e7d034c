"""The closed loop's cheap records against MuJoCo itself: the foot poses read inside the loop (from
the forward pass of each period's first physics step) equal ``mj_kinematics`` of the recorded
state row by row, and the loop's physics equals a bare ``mj_step`` rollout of the recorded torques
bit for bit (splitting a period's steps changes nothing)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from biped.sim import Scenario, build_scene
from biped.sim.push import FOOT_BODIES, controller_policy, run_closed_loop
from biped.sim.scene import initial_state


@pytest.mark.parametrize("physics", ["faithful", "fast"])
def test_foot_poses_and_physics_match_mujoco(physics):
    sc = Scenario(physics=physics, duration_s=0.3)  # the block hits at ~0.08 s
    scene = build_scene(sc)
    r = run_closed_loop(sc, scene, controller_policy(sc, scene))
    assert len(r.times) == sc.control_steps + 1 and r.block_contact_time_s is not None
    m = scene.model
    d = mujoco.MjData(m)
    feet = [m.body(f).id for f in FOOT_BODIES]
    for k in range(len(r.times)):
        d.qpos[:] = r.qpos[k]
        mujoco.mj_kinematics(m, d)
        assert np.array_equal(r.feet_pos[k], d.xpos[feet]), k
        assert np.array_equal(r.feet_quat[k], d.xquat[feet]), k
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = initial_state(scene, sc)
    mujoco.mj_forward(m, d)
    for k in range(len(r.times) - 1):
        d.ctrl[scene.actuator_index] = r.torques[k]
        mujoco.mj_step(m, d, sc.control_substeps)
        assert np.array_equal(d.qpos, r.qpos[k + 1]) and np.array_equal(d.qvel, r.qvel[k + 1]), k
