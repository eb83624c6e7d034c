"""The motor-driven waist pull (biped.sim.perturbations.pull, docs/perturbations.md) against
MuJoCo's own momentum and the motor's kinematics: a pull-only cable on a free body."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from _helpers import paradigm_push

from biped.errors import ScenarioError
from biped.sim import Scenario, build_scene
from biped.sim.perturbations import of
from biped.sim.perturbations.pull import pull_rows
from biped.sim.scene import initial_state


def _free_pull(d: float, v: float, seconds: float):
    """The biped floating without gravity (no contacts, no controller, its joints all but locked by
    damping), pulled along -x."""
    sc = Scenario(physics="fast", perturbation="pull", pull_displacement_m=(-d, 0.0), pull_velocity_m_s=v,
                  pull_start_s=0.02)  # fmt: skip
    scene = build_scene(sc)
    m = scene.model
    m.opt.gravity[:] = 0.0
    hinges = [m.jnt_dofadr[j] for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    m.dof_damping[hinges] = 1e5  # the joints all but locked: one rigid body
    data = mujoco.MjData(m)
    q, qv = initial_state(scene, sc)
    q[scene.biped_qpos_index[2]] += 1.0  # in the air
    data.qpos[:], data.qvel[:] = q, qv
    mujoco.mj_forward(m, data)
    mujoco.mj_subtreeVel(m, data)
    driver = of(sc).driver(scene, m, data, None)
    root = m.body_rootid[scene.central_body]
    mass = m.body_subtreemass[root]
    p0 = mass * data.subtree_linvel[root].copy()
    rows = set(driver.rows.tolist())
    forces = []
    for k in range(round(seconds * sc.control_rate_hz)):
        if k in rows:
            driver.apply(k, k / sc.control_rate_hz, data)
        forces.append(data.xfrc_applied[scene.central_body, :3].copy())
        mujoco.mj_step(m, data, sc.control_substeps)
    mujoco.mj_forward(m, data)
    mujoco.mj_subtreeVel(m, data)
    return (
        sc,
        driver,
        np.array(forces),
        mass * data.subtree_linvel[root] - p0,
        data.subtree_linvel[root].copy(),
    )


def test_a_pull_only_cable_leaves_a_free_body_at_the_motors_speed():
    """The cable carries a free body along at the motor's peak speed and cannot slow it down
    (it only pulls): after the pull the body moves at ~v along the pull (up to ~10 % faster: the
    underdamped cable overshoots the motor's speed, then goes slack); MuJoCo's momentum change
    equals the impulse the driver says it applied (to 1 %); the force never pushes, points along
    the pull and is zero after the cable is let go."""
    v = 0.5
    sc, driver, forces, dp, vel = _free_pull(0.3, v, 1.2)
    info = driver.finish(None)
    assert np.linalg.norm(dp - info["impulse_applied_n_s"]) < 0.01 * np.linalg.norm(dp)
    assert -1.0 * v >= vel[0] >= -1.15 * v and abs(vel[1]) < 0.02
    assert np.all(forces[:, 0] <= 1e-9) and np.allclose(forces[:, 1:], 0.0)
    k0, k1 = pull_rows(sc)
    assert np.all(forces[k1:] == 0.0) and np.all(forces[: k0 + 1] == 0.0)
    assert info["peak_tension_n"] > 0.0
    # the motor's travel takes d / (0.75 v) (the trapezoid with peak v)
    assert (k1 - k0) / sc.control_rate_hz == pytest.approx(0.3 / (0.75 * v), abs=1.0 / sc.control_rate_hz)


def test_a_stiff_cable_imposes_the_displacement():
    """With the biped standing (W's controller), a 3 cm pull carries the pelvis 3 cm, to the
    cable's stretch at the peak tension plus 5 mm."""
    from biped.sim.push import simulate

    sc = Scenario(physics="fast", perturbation="pull", pull_displacement_m=(-0.03, 0.0), duration_s=0.4)
    r = simulate(sc)
    info = r.extra["perturbation"]
    from biped.sim.perturbations.pull import CABLE_STIFFNESS_N_M

    assert abs(info["pelvis_travel_m"] - 0.03) <= info["peak_tension_n"] / CABLE_STIFFNESS_N_M + 0.005


@pytest.mark.parametrize(
    ("keys", "words"),
    [
        ({"pull_velocity_m_s": 0.0}, "pull_velocity_m_s must be > 0"),
        ({"pull_velocity_m_s": 20.0}, "pull_velocity_m_s must be in (0, 10]"),
        ({"pull_displacement_m": (3.0, 0.0)}, "pull_displacement_m must be at most 2 m"),
        ({"pull_displacement_m": (0.1,)}, "pull_displacement_m must be 2 numbers"),
        ({"pull_start_s": -1.0}, "pull_start_s must be >= 0"),
    ],
)
def test_bad_pull_keys_are_one_line_errors(keys, words):
    with pytest.raises(ScenarioError, match=None) as e:
        Scenario(perturbation="pull", **keys)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_pull_keys_stay_out_of_a_default_scenario():
    """W's default summary.json keeps its keys: the pull's and step_program are left out at their
    defaults."""
    d = Scenario().to_dict()
    assert not {"pull_displacement_m", "pull_velocity_m_s", "pull_start_s", "step_program"} & set(d)
    assert Scenario(pull_velocity_m_s=0.3).to_dict()["pull_velocity_m_s"] == 0.3


def test_push_command_runs_the_pull_and_names_its_strategy(tmp_path):
    summary = paradigm_push(tmp_path / "run", "pull")
    assert summary["perturbation"]["paradigm"] == "pull"
    assert summary["perturbation"]["peak_tension_n"] > 0.0
    assert summary["response"]["strategy"] in ("ankle", "hip", "step", "fall")
