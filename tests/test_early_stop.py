"""Early stop (biped.sim.early_stop) for the paradigms and the block out of reach: the rule
never decides what the full run would not, and never decides while the perturbation acts."""

from __future__ import annotations

import numpy as np
import pytest

from biped.sim import early_stop
from biped.sim.sweep import SweepSpec, hold_scenario


def _run(es: bool, axes: dict, **keys):
    from biped.sim.push import run_closed_loop
    from biped.sim.sweep.trial import _scene_for, make_policy

    keys = {"physics": "fast", "distribution": "qp", **keys}
    base = hold_scenario().with_overrides(early_stop=es, **keys)
    spec = SweepSpec(axes=axes, base=base)
    setup = spec.setup(spec.trials()[0])
    scene = _scene_for(setup.scenario)
    return run_closed_loop(setup.scenario, scene, make_policy(setup, scene))


@pytest.mark.parametrize(("newtons", "falls"), [(150.0, False), (500.0, True)])
def test_a_force_pulse_late_in_quiet_stance_is_waited_for(newtons, falls):
    """The biped stands at rest for 0.6 s before the pulse: the rule may decide only after the
    pulse ends (Force.over_row); a 500 N pulse then fells it, as in the full run."""
    axes = {"magnitude": (newtons,), "direction_deg": (90.0,)}
    keys = {"perturbation": "force", "force_start_s": 0.6, "duration_s": 2.0}
    full, early = _run(False, axes, **keys), _run(True, axes, **keys)
    assert (early.fell, early.recovered) == (full.fell, full.recovered) == (falls, not falls)
    end = 0.6 + 0.15 + early_stop.HOLD_S
    if falls:
        assert early.stop_reason is None and early.fall_time_s == full.fall_time_s
    else:
        assert early.stop_reason == "at_rest" and end <= early.times[-1] < 1.9
        assert full.stop_reason is None and full.times[-1] == 2.0


def test_a_platform_run_stops_at_rest_over_the_moved_feet():
    """The set point moved with the platform (the driver's final_target): the stop is judged
    against it, after the ramp, with the platform's slide still."""
    axes = {"magnitude": (0.1,), "direction_deg": (0.0,)}
    keys = {"perturbation": "platform", "duration_s": 2.5}
    full, early = _run(False, axes, **keys), _run(True, axes, **keys)
    assert full.recovered and early.recovered and early.stop_reason == "at_rest"
    assert 0.4 + early_stop.HOLD_S <= early.times[-1] < 2.4
    assert np.linalg.norm(early.com[-1][:2] - early.target_com[:2]) < 0.01
    assert np.linalg.norm(early.target_com[:2] - full.target_com[:2]) < 1e-12
    assert abs(np.linalg.norm(early.target_com[:2] - early.com[0][:2]) - 0.1) < 0.005  # moved 0.1 m


def test_the_block_out_of_reach_need_not_lie_still():
    """A block rolling away 0.7 m off still ends the run (its energy cannot carry it back), and
    the outcome is the full run's."""
    axes = {"speed_m_s": (4.125,), "direction_deg": (164.0,)}
    full = _run(False, axes, distribution="statics")
    early = _run(True, axes, distribution="statics")
    assert full.recovered and early.recovered and early.stop_reason == "at_rest"
    speed = np.linalg.norm(early.block_velocity[-1])
    assert speed > early_stop.BLOCK_SPEED_M_S  # not still: out of reach
    travel = early_stop.REACH_FACTOR * speed**2 / (2 * 0.3 * 9.81)
    assert np.linalg.norm(early.block[-1][:2] - early.com[-1][:2]) > 0.3 + travel


def test_a_paradigm_that_does_not_say_when_it_is_over_runs_to_its_end(monkeypatch):
    """The interface's default over_row is 'never': a new paradigm without its own runs its
    duration even when the biped stands at rest (here the force with Force.over_row removed)."""
    from biped.sim.perturbations import Force, Perturbation

    monkeypatch.setattr(Force, "over_row", Perturbation.over_row)
    axes = {"magnitude": (150.0,), "direction_deg": (90.0,)}
    run = _run(True, axes, perturbation="force", duration_s=1.0)
    assert run.recovered and run.stop_reason is None and run.times[-1] == 1.0
