"""Stepping runs in the compiled loop (biped.sim.fused_step) against the Python loop.

The Python loop (``compiled=False``: ``SteppingController`` called every period) is the
reference: with the compiled loop running the double support (before the first step and after
each touchdown) and handing the swings back to Python, every record, the events, the steps, the
outcome and the early stop must be the same bit for bit: pushes from the front, behind and both
sides, with steps, both triggers, fast and faithful physics."""

from __future__ import annotations

import numpy as np
import pytest
from test_sim_fused import assert_same

from biped.control.stepping import SteppingController
from biped.sim import Scenario, build_scene, fused
from biped.sim.push import controller_policy, run_closed_loop


def _sweep_scenario(speed, direction, trigger, physics="fast", **keys):
    """One `biped sweep --distribution qp --stepping` trial (1.8 kg block at 1.2 m, early stop)."""
    from biped.cli import build_parser
    from biped.cli.sweep import build_spec

    args = ["sweep", "--speed", str(speed), "--direction", str(direction), "--distribution", "qp"]
    args += ["--physics", physics, "--stepping", "--set", f'step_trigger="{trigger}"']
    spec = build_spec(build_parser().parse_args(args))
    return spec.scenario(spec.trials()[0]).with_overrides(**keys)


def both(scenario: Scenario, monkeypatch):
    """(compiled run, Python run, the policy calls of the compiled run)."""
    scene = build_scene(scenario)
    calls = []
    real = SteppingController.__call__

    def counting(self, t, q, v, feet):
        calls.append(t)
        return real(self, t, q, v, feet)

    monkeypatch.setattr(SteppingController, "__call__", counting)
    pa = controller_policy(scenario, scene)
    assert fused.fused_controller(pa) is not None
    a = run_closed_loop(scenario, scene, pa, compiled=True)
    n_calls = len(calls)
    b = run_closed_loop(scenario, scene, controller_policy(scenario, scene), compiled=False)
    assert a.extra["steps"] == b.extra["steps"]
    assert a.stop_reason == b.stop_reason
    assert np.array_equal(a.target_com, b.target_com)
    return a, b, n_calls


def _check(a, b, n_calls, min_steps=1):
    assert_same(a, b)
    assert len(a.extra["steps"]) >= min_steps, a.extra["steps"]
    rows = len(a.times)
    # the swings (and the first call, the warm-up) were Python's, the rest compiled
    ends = [(s["touch_down_s"] or a.times[-1], s["start_s"]) for s in a.extra["steps"]]
    swing = sum(round(t1 / 0.002) - round(t0 / 0.002) + 1 for t1, t0 in ends)
    assert n_calls <= swing + 10 + rows // 50, (n_calls, swing, rows)


@pytest.mark.parametrize(
    ("speed", "direction", "trigger"),
    [(14, 90, "qp"), (12, 180, "qp"), (16, 0, "qp"), (11, 270, "capture"), (10, 180, "capture")],
)
def test_stepping_sweep_trials_fast(speed, direction, trigger, monkeypatch):
    """Sweep trials that step (sideways, from behind, the front's slow trigger), to the early stop
    or 3 s: the same run bit for bit, and most of it compiled."""
    a, b, n = both(_sweep_scenario(speed, direction, trigger, duration_s=3.0), monkeypatch)
    _check(a, b, n)


@pytest.mark.parametrize("trigger", ["capture", "qp"])
def test_goal_push_faithful(trigger, monkeypatch):
    """The issue's goal push (4 kg at 8 m/s from behind, faithful physics), 1.6 s: steps, both triggers."""
    sc = Scenario(stepping=True, distribution="qp", block_mass_kg=4.0, block_velocity_m_s=(-8.0, 0.0, 0.2),
                  duration_s=1.6, step_trigger=trigger)  # fmt: skip
    a, b, n = both(sc, monkeypatch)
    _check(a, b, n)


def test_min_norm_stepping_and_a_push_without_a_step(monkeypatch):
    """W's min-norm split (both feet fixed) with stepping, a 4 kg block from behind that makes it
    step; and W's own push, which takes no step: then the whole run but the warm-up is compiled."""
    sc = Scenario(stepping=True, physics="fast", block_mass_kg=4.0, block_velocity_m_s=(-8.0, 0.0, 0.2),
                  duration_s=1.5)  # fmt: skip
    a, b, n = both(sc, monkeypatch)
    _check(a, b, n)
    a, b, n = both(Scenario(stepping=True, physics="fast", duration_s=1.0), monkeypatch)
    assert_same(a, b)
    assert a.extra["steps"] == [] and n == 1  # the warm-up call alone


def test_step_program_with_a_nervous_system(monkeypatch):
    """The lean release of validate's ``step_release`` with the young nervous system (feedback
    delay, activation lag, rate limits) and the step program (weight transfer, planned swing):
    the release arms the trigger and moves the set point from Python rows, the controller sees
    the delayed state; the run is the same bit for bit."""
    from biped.control.step_program import StepProgram

    keys = {"friction": 1.0, "duration_s": 1.5, "perturbation": "release", "release_time_s": 0.1}
    keys |= {"stepping": True, "max_steps": 1, "distribution": "qp", "step_program": "program"}
    keys |= {"step_trigger": "capture"}  # validate's step release pins it
    sc = Scenario(**keys, release_lean_deg=9.0, neuromotor="young")
    scene = build_scene(sc)
    assert isinstance(controller_policy(sc, scene), StepProgram)
    a, b, n = both(sc, monkeypatch)
    _check(a, b, n)


def test_stepping_sweep_rows_unchanged(monkeypatch):
    """A stepping sweep trial (15 m/s from the side; ``run_trial``: its measurements, the steps' columns) gives the same
    row with the compiled loop as with the Python loop."""
    from biped.cli import build_parser
    from biped.cli.sweep import build_spec
    from biped.sim.sweep.trial import run_trial

    args = ["sweep", "--speed", "15", "--direction", "270", "--distribution", "qp", "--stepping"]
    args += ["--physics", "fast", "--set", 'step_trigger="qp"', "--set", "duration_s=2.0"]
    spec = build_spec(build_parser().parse_args(args))
    (setup,) = [spec.setup(t) for t in spec.trials()]
    made = []
    real = fused.fused_rows
    monkeypatch.setattr(fused, "fused_rows", lambda *a, **k: made.append(real(*a, **k)) or made[-1])
    compiled = run_trial(setup)
    assert len(made) == 1 and made[0] is not None
    monkeypatch.setattr(fused, "fused_rows", lambda *a, **k: None)
    python = run_trial(setup)
    assert compiled["step_count"] >= 1
    assert compiled.keys() == python.keys()
    for key in compiled:
        same = compiled[key] == python[key] or (compiled[key] != compiled[key] and python[key] != python[key])
        assert same, (key, compiled[key], python[key])


def test_closing_step_compiled_is_the_python_loop(monkeypatch):
    """With ``closing_step`` on (16 m/s from behind, 3 s: a backward step, then at rest the
    closing step): the compiled double support hands the closing check back (``I_CLOSE``), the
    shift and the swing run in Python; the same run bit for bit."""
    from biped.control.stepping_config import SteppingConfig

    orig = SteppingConfig.for_trigger
    monkeypatch.setattr(
        SteppingConfig,
        "for_trigger",
        classmethod(lambda cls, trig, **kw: orig(trig, **{"closing_step": True, **kw})),
    )
    a, b, n = both(_sweep_scenario(16, 180, "qp", duration_s=3.0), monkeypatch)
    assert [st["closing"] for st in a.extra["steps"]] == [False, True]
    assert_same(a, b)
