"""W section 4 closed loop: the block hits, the loop is wired right, runs are reproducible."""

from __future__ import annotations

import csv
import json

import mujoco
import numpy as np
import pytest

from biped.cli import main
from biped.outputs.push import write_outputs, write_trajectory_csv
from biped.sim import Scenario, build_scene, simulate
from biped.sim.push import controller_policy, orientation_error_deg
from biped.sim.scene import initial_state, scene_spec, tilt_quat

MISS = {"block_position_m": (3.0, 3.0, 0.06), "block_velocity_m_s": (0.0, 0.0, 0.0)}


def test_block_hits_and_pushes_the_body_forward():
    """Contact recorded near W's 0.08 s, the block loses its momentum, the body moves to -x
    compared with the same run without the block."""
    hit = simulate(Scenario(duration_s=0.25))
    miss = simulate(Scenario(duration_s=0.25, **MISS))
    assert hit.block_contact_time_s is not None and 0.06 < hit.block_contact_time_s < 0.10
    assert miss.block_contact_time_s is None
    assert hit.block_momentum_before[0] == pytest.approx(-1.8 * 4.5)
    # after a hit with e = 0.2 the block moves away from the body (+x) or at least stopped
    assert hit.block_momentum_after[0] > -0.2 * abs(hit.block_momentum_before[0])
    k = np.searchsorted(hit.times, 0.2)
    assert hit.com[k, 0] - miss.com[k, 0] < -0.005  # pushed forward (-x) by more than 5 mm
    # the hit is off-centre (block at y = 0.1 m): it yaws the body
    assert abs(hit.quat[k, 3]) > abs(miss.quat[k, 3]) + 0.01


def test_same_scenario_gives_byte_identical_csv(tmp_path):
    s = Scenario(duration_s=0.15, joint_noise_deg=0.5, seed=7)
    a = write_trajectory_csv(simulate(s), tmp_path / "a.csv").read_bytes()
    b = write_trajectory_csv(simulate(s), tmp_path / "b.csv").read_bytes()
    c = write_trajectory_csv(simulate(s.with_overrides(seed=8)), tmp_path / "c.csv").read_bytes()
    assert a == b
    assert a != c  # the seed is used


def _welded_feet_model(scenario):
    """The push scene with both feet welded to the world where the initial state puts them:
    the controller's assumption (W Alg. 3's big base) made exact."""
    scene = build_scene(scenario)
    spec = scene_spec(scenario)
    for foot in ("left_foot", "right_foot"):
        spec.add_equality(
            type=mujoco.mjtEq.mjEQ_WELD,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            name1="world",
            name2=foot,
            solref=[2 * scenario.physics_timestep_s, 1.0],  # as stiff as stable
            solimp=[0.99, 0.999, 0.001, 0.5, 2.0],
        )
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = initial_state(scene, scenario)
    mujoco.mj_forward(model, data)
    for i in range(model.neq):  # relpose = the foot's pose in the world: zero violation at t = 0
        b = model.eq_obj2id[i]
        model.eq_data[i, :3] = 0.0
        model.eq_data[i, 3:6] = data.xpos[b]
        model.eq_data[i, 6:10] = data.xquat[b]
        model.eq_data[i, 10] = 1.0
    return scene, model, data


def test_controller_wiring_recovers_with_welded_feet():
    """With the feet welded (what the controller assumes) the closed loop, reading the biped's
    qpos/qvel out of the scene by name, drives the body to W's set point despite the block:
    errors far below the 2 cm / 2 deg of the issue at 3 s."""
    s = Scenario()
    scene, model, data = _welded_feet_model(s)
    policy = controller_policy(s, scene)
    for k in range(s.control_steps):
        data.ctrl[scene.actuator_index] = policy(
            k / s.control_rate_hz,
            data.qpos[scene.biped_qpos_index],
            data.qvel[scene.biped_qvel_index],
            (True, True),
        )
        mujoco.mj_step(model, data, s.control_substeps)
    com = data.xipos[scene.central_body]
    quat = data.qpos[scene.biped_qpos_index[3:7]]
    assert np.linalg.norm(com - np.array(s.target_com_m)) < 0.002
    assert orientation_error_deg(quat, tilt_quat("-y", 15.0)) < 0.2


@pytest.mark.slow
def test_centred_push_recovers_on_real_contacts():
    """W's experiment with the block thrown through the body's mid-plane (y = 0 instead of
    0.1 m): on MuJoCo's unilateral contacts the heels rise after the hit and come back, and the
    body reaches the set point (issue's criteria: < 2 cm, < 2 deg, no fall)."""
    r = simulate(Scenario(block_position_m=(0.5, 0.0, 1.2)))
    assert not r.fell and r.diverged is None
    assert r.recovered
    assert r.final_com_error_m < 0.02 and r.final_orientation_error_deg < 2.0
    heel_off = [
        e.time_s
        for e in r.events
        if e.part == "heel" and e.kind == "lift_off" and e.time_s > r.block_contact_time_s
    ]
    heel_on = [
        e.time_s
        for e in r.events
        if e.part == "heel" and e.kind == "touch_down" and e.time_s > r.block_contact_time_s
    ]
    assert heel_off and heel_off[0] - r.block_contact_time_s < 0.03  # heels rise after the hit
    assert heel_on and heel_on[0] < 0.6  # and come back (W: 0.36 / 0.38 s)


@pytest.mark.slow
def test_default_run_recovers():
    """`biped push` with no arguments: W's scenario recovers on MuJoCo's contacts (the issue's
    criteria at 3 s: COM error < 2 cm, orientation error < 2 deg, no fall), after the block hit
    near W's 0.08 s lifted the heels and they came back down."""
    r = simulate(Scenario())
    assert not r.fell and r.diverged is None and r.controller_error is None
    assert r.times[-1] == pytest.approx(3.0)
    assert r.final_com_error_m < 0.02 and r.final_orientation_error_deg < 2.0
    assert r.recovered
    assert 0.06 < r.block_contact_time_s < 0.10
    after = [e for e in r.events if e.time_s > r.block_contact_time_s]
    for foot in ("left", "right"):
        off = [e.time_s for e in after if e.foot == foot and e.part == "heel" and e.kind == "lift_off"]
        on = [e.time_s for e in after if e.foot == foot and e.part == "heel" and e.kind == "touch_down"]
        assert off and off[0] - r.block_contact_time_s < 0.03, foot  # heels rise after the hit
        assert on and on[-1] < 0.6, foot  # and are back (W: right 0.36 s, left 0.38 s)
    assert r.left_contact[-1] and r.right_contact[-1]


def test_outputs_columns_and_summary(tmp_path):
    r = simulate(Scenario(duration_s=0.1))
    write_outputs(r, tmp_path, video=False, replay=False, log=lambda m: None)
    with open(tmp_path / "trajectory.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 51  # t = 0, 2 ms, ..., 100 ms: the control rate
    assert float(rows[1]["time"]) == pytest.approx(0.002)
    need = [
        "time",
        "central_body_com_x",
        "central_body_com_y",
        "central_body_com_z",
        "quat_w",
        "quat_x",
        "quat_y",
        "quat_z",
        "block_x",
        "block_y",
        "block_z",
        "left_contact",
        "right_contact",
    ]
    for j in r.joint_names:
        need += [f"q_{j}", f"tau_{j}"]
    assert set(need) <= set(rows[0])
    assert float(rows[0]["central_body_com_z"]) == pytest.approx(1.035)
    summary = json.loads((tmp_path / "summary.json").read_text())
    for k in (
        "recovered",
        "fell",
        "final_com_error_m",
        "final_orientation_error_deg",
        "block_contact_time_s",
        "events",
        "wall_time_s",
        "realtime_factor",
        "control_rate_hz",
        "physics_timestep_s",
        "scenario",
    ):
        assert k in summary
    assert summary["scenario"]["block_mass_kg"] == 1.8
    for e in summary["events"]:
        assert set(e) == {"time_s", "foot", "part", "kind"}
        assert e["foot"] in ("left", "right") and e["part"] in ("heel", "toe")
        assert e["kind"] in ("lift_off", "touch_down")
    figs = sorted(p.name for p in (tmp_path / "figures").iterdir())
    assert len(figs) == 4 and "fig5_body_position.png" in figs  # PNG only by default (--svg adds SVG)


def test_cli_default_layout(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(
        [
            "push",
            "--quiet",
            "--no-video",
            "--no-replay",
            "--no-figures",
            "--duration",
            "0.05",
            "--block-velocity",
            "-4",
            "0",
            "0.1",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scenario"]["block_velocity_m_s"] == [-4.0, 0.0, 0.1]
    assert summary["scenario"]["duration_s"] == 0.05
    text = capsys.readouterr().out
    assert "final COM error" in text and str(out) in text


def test_a_fall_is_a_result_not_a_crash():
    """A 20 kg block at 6 m/s knocks the biped over (or makes the run diverge): the run ends
    early with fell/diverged set, never an exception."""
    r = simulate(
        Scenario(
            block_mass_kg=20.0, block_velocity_m_s=(-6.0, 0.0, 0.0), controller="joint-pd", duration_s=2.0
        )
    )
    assert r.fell or r.diverged
    assert not r.recovered
    assert r.times[-1] < 2.0


def test_ctrl_c_keeps_what_was_simulated(tmp_path):
    """A KeyboardInterrupt during the run returns the rows simulated so far, which are written."""

    def progress(t):
        if t >= 0.1:
            raise KeyboardInterrupt

    r = simulate(Scenario(duration_s=1.0), progress=progress)
    assert r.interrupted and not r.recovered
    assert 0.09 <= r.times[-1] < 0.2
    write_outputs(r, tmp_path, figures=False, video=False, replay=False)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["interrupted"] is True
    n = len((tmp_path / "trajectory.csv").read_text().splitlines())
    assert n == len(r.times) + 1


def test_figures_png_by_default_svg_on_request(tmp_path):
    """`biped push` writes its figures once, as PNG; `--svg` (formats=("png", "svg")) adds SVG; an
    unknown format is refused before anything is drawn."""
    from biped.errors import BipedError
    from biped.viz.push_figures import FIGURES, plot_push

    r = simulate(Scenario(duration_s=0.05))
    seen = []
    paths = plot_push(r, tmp_path / "both", formats=("png", "svg"), progress=lambda n, N: seen.append((n, N)))
    assert sorted(p.suffix for p in paths) == [".png"] * len(FIGURES) + [".svg"] * len(FIGURES)
    assert all(p.stat().st_size > 1000 for p in paths)
    assert seen == [(k, len(FIGURES)) for k in range(1, len(FIGURES) + 1)]
    with pytest.raises(BipedError, match="png, svg"):
        plot_push(r, tmp_path / "bad", formats=("jpg",))
    assert not (tmp_path / "bad").exists()
