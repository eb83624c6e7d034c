"""Inverse dynamics of the kinematic gait on W's biped.

Oracles: MuJoCo's *forward* dynamics (the torques and foot wrenches found, applied to the biped,
must reproduce the prescribed accelerations), the momentum law sum F = m (c'' - g) with c'' the
second difference of MuJoCo's centre of mass along the motion (not the 1 ms differences the
inverse dynamics uses), and statics while standing still.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from biped.errors import ModelError
from biped.kinematic import FigureDims, GaitParams, jump, step_forward, step_upward
from biped.kinematic.dynamics import inverse_dynamics, load_biped

G = 9.81


@pytest.fixture(scope="module")
def biped():
    return load_biped()


@pytest.fixture(scope="module")
def walks(biped):
    out = {}
    for name, plan in (
        ("forward", step_forward(steps=3)),
        ("upstairs", step_upward(steps=2)),
        ("jump", jump(params=GaitParams(somersault=True))),
    ):
        motion = plan.sample(200.0)
        out[name] = (motion, inverse_dynamics(motion, biped))
    return out


@pytest.mark.parametrize("name", ["forward", "upstairs", "jump"])
def test_forward_dynamics_of_the_result_reproduces_the_motion(biped, walks, name):
    """Joint torques + foot wrenches (mj_applyFT at the sole centres) + the flight residual on the
    root, fed to mj_forward, give back the prescribed qacc."""
    _motion, res = walks[name]
    m = load_biped()  # contacts off, as in the inverse dynamics
    d = mujoco.MjData(m)
    names = list(res.joint_names)
    vadr = [m.joint(n).dofadr[0] for n in names]
    feet = [m.body("left_foot").id, m.body("right_foot").id]
    rng = np.random.default_rng(0)
    for t in rng.choice(res.times.size, 60, replace=False):
        d.qpos[:], d.qvel[:] = res.qpos[t], res.qvel[t]
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        qfrc = np.zeros(m.nv)
        qfrc[vadr] = res.torques[t]
        qfrc[:6] += res.residual[t]
        for j in range(2):
            if res.stance[t, j]:
                mujoco.mj_applyFT(
                    m, d, res.grf[t, j], res.grf_moment[t, j], res.sole_centre[t, j], feet[j], qfrc
                )
        d.qfrc_applied[:] = qfrc
        mujoco.mj_forward(m, d)
        scale = 1.0 + np.max(np.abs(res.qacc[t]))
        assert np.max(np.abs(d.qacc - res.qacc[t])) < 1e-6 * scale, f"{name} t={res.times[t]:.3f}"


@pytest.mark.parametrize("name", ["forward", "upstairs", "jump"])
def test_ground_forces_obey_the_momentum_law(biped, walks, name):
    """sum of foot forces + flight residual = m (c'' - g), c'' from 200 Hz second differences of
    MuJoCo's whole-body centre of mass (median error under 0.1 % of body weight; the
    acceleration jumps at the stance switches, where the 200 Hz difference smears it)."""
    _motion, res = walks[name]
    d = mujoco.MjData(biped)
    c = np.empty((res.times.size, 3))
    for t in range(res.times.size):
        d.qpos[:] = res.qpos[t]
        mujoco.mj_kinematics(biped, d)
        mujoco.mj_comPos(biped, d)
        c[t] = d.subtree_com[0]
    dt = res.times[1] - res.times[0]
    acc = (c[2:] - 2 * c[1:-1] + c[:-2]) / dt**2
    need = res.mass * (acc - np.array([0.0, 0.0, -G]))
    have = res.grf.sum(axis=1)[1:-1] + res.residual[1:-1, :3]
    err = np.linalg.norm(need - have, axis=1)
    mg = res.mass * G
    assert np.median(err) < 1e-3 * mg
    assert np.quantile(err, 0.95) < 1e-2 * mg


def test_standing_still_weight_splits_evenly_and_torques_mirror(walks):
    """In the jump's final stand: each foot carries half the weight, no horizontal force, and the
    left and right sagittal torques are equal."""
    motion, res = walks["jump"]
    k = np.flatnonzero(motion.labels == "jump: stand")[5:-5]
    np.testing.assert_allclose(res.grf[k, :, 2], res.mass * G / 2, rtol=1e-6)
    np.testing.assert_allclose(res.grf[k, :, :2], 0.0, atol=1e-6 * res.mass * G)
    names = list(res.joint_names)
    for j in ("hip_flexion", "knee", "ankle_dorsiflexion"):
        np.testing.assert_allclose(
            res.torques[k, names.index(f"left_{j}")], res.torques[k, names.index(f"right_{j}")], atol=1e-6
        )
    assert np.all(np.abs(res.residual[k]) < 1e-6)


def test_flight_needs_a_wrench_nothing_supplies(walks):
    """While both feet are off the ground the root's generalized force is left over: at least the
    body weight during the kinematic semicircle (a real body would fall)."""
    _motion, res = walks["jump"]
    flight = ~np.any(res.stance, axis=1)
    assert np.any(flight)
    assert np.max(np.linalg.norm(res.residual[flight, :3], axis=1)) > res.mass * G
    assert np.all(res.residual[~flight] == 0) or np.max(np.abs(res.residual[~flight])) < 1e-6
    s = res.summary()
    assert s["flight_frames"] == int(flight.sum())
    assert s["peak_flight_residual_force_N"] > res.mass * G


def test_single_support_of_b_gait_puts_the_cop_outside_the_sole(walks):
    """B's figure never shifts its weight sideways: in single support the centre of pressure the
    biped would need lies beside the stance foot (the finding reported in docs/walk.md)."""
    _motion, res = walks["forward"]
    single = res.stance.sum(axis=1) == 1
    s = res.summary()
    assert s["fraction_cop_outside_sole"] > 0.5
    lateral = np.abs(res.cop[..., 1] - res.sole_centre[..., 1])
    assert np.nanmedian(lateral[single & res.stance[:, 0], 0]) > res.sole_half[1]


def test_figure_with_other_legs_is_rejected(biped):
    dims = FigureDims.from_anthropometry()
    other = dataclasses.replace(dims, thigh=dims.thigh * 1.1)
    motion = step_forward(other, steps=1).sample(50.0)
    with pytest.raises(ModelError, match="thigh .* differs from the biped"):
        inverse_dynamics(motion, biped)
