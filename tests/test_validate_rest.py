"""The one-step lean's rule (docs/validate.md, "Recovered: at rest over the final feet"): a trial
counts only if it stands and is at rest over its final feet at the end of a 7 s run, and the
threshold is the largest lean with every lean below it recovered (the staircase)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from biped.analysis import validate
from biped.analysis.validate import EXPERIMENTS, RECOVERED, run_experiment, run_trial
from biped.sim import policies


def test_a_fall_after_four_seconds_counts_as_a_fall(monkeypatch):
    """MuJoCo's run: the ideal biped held at a 15.5 deg lean by the tether until 4.5 s, then let
    go: it steps, stands, and falls at 6.34 s, after the 4 s the other experiments run (the
    contact monitor's fall: the COM below the fall height or a body other than a foot on the
    floor). The one-step protocol's 7 s run counts the fall; the same trial cut at 6 s "survived".
    The specimen is the stepper without the rear foot's friction margin after the step (with it
    this trial stands: docs/validate.md, "The rear foot's friction after the step")."""
    monkeypatch.setattr(policies, "POST_STEP_FRICTION_SCALE", None)
    exp = EXPERIMENTS["step_release"]
    assert exp.criterion == RECOVERED and exp.base["duration_s"] >= 7.0
    late = dataclasses.replace(exp, base={**exp.base, "release_time_s": 4.5})
    t = run_trial(late, "ideal", 15.5)
    assert t.steps == 1 and not t.survived and not t.recovered and not t.passed
    assert t.fall_time_s is not None and 6.0 < t.fall_time_s < 7.0
    assert t.end_s == pytest.approx(t.fall_time_s, abs=0.01)  # the fall ends the run
    cut = dataclasses.replace(late, base={**late.base, "duration_s": 6.0})
    t6 = run_trial(cut, "ideal", 15.5)
    assert t6.survived and t6.fall_time_s is None  # what a shorter protocol would have counted


def test_a_trial_at_rest_ends_early_and_counts_with_its_speed_below_5_cm_s():
    """A small lean (ideal, 3 deg): the run ends at rest well before its 7 s (early_stop), counts
    as recovered, and its final COM speed (MuJoCo's qvel of the central body) is below the
    stepping rule's 5 cm/s, its COM within 2 cm of the set point over the final feet."""
    exp = EXPERIMENTS["step_release"]
    t = run_trial(exp, "ideal", 3.0)
    assert t.survived and t.recovered and t.passed
    assert t.end_s < 6.0 and t.final_com_speed_m_s < 0.05 and t.final_com_error_m < 0.02


def _fake_trial(passes):
    """A stand-in for :func:`run_trial`: the trial passes where ``passes(magnitude)``."""

    def run(exp, neuromotor, magnitude, running=None):  # running: the heartbeat (unused)
        ok = bool(passes(magnitude))
        return validate.Trial(exp.key, neuromotor, float(magnitude), exp.unit, ok, None if ok else 1.0,
                              0.0, 0.0, 0.0, 0.0, recovered=ok, passed=ok)  # fmt: skip

    return run


def test_staircase_stops_at_the_first_failure_below_an_island(monkeypatch):
    """Leans pass below 9.3 deg and between 11 and 20.5, fail at 9.3-11 and above 20.5: the
    staircase (2, 3, ... deg) fails first at 10, bisects [9, 10] and reports 9.25 (4 halvings,
    1/16 deg), every lean tried below it passed; the log bisection over [2, 40] of the same
    pattern (the old rule) jumps over the island to 20.5."""
    monkeypatch.setattr(validate, "run_trial", _fake_trial(lambda m: m < 9.3 or 11.0 <= m < 20.5))
    exp = EXPERIMENTS["step_release"]
    th = run_experiment(exp, "ideal", 9)
    assert th.value == pytest.approx(9.25) and th.bound == ""
    assert th.lowest_failure == pytest.approx(9.3125) and th.highest_pass == pytest.approx(9.25)
    assert all(t.passed for t in th.trials if t.magnitude <= th.value)
    assert [t.magnitude for t in th.trials][:9] == [2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0]
    bis = run_experiment(dataclasses.replace(exp, staircase=0.0), "ideal", 9)
    assert 20.0 < bis.value < 20.5  # the old search: above the island it never sampled
    quick = run_experiment(exp, "ideal", 3, quick=True)  # 2 deg steps, 3 halvings
    assert [t.magnitude for t in quick.trials][:5] == [2.0, 4.0, 6.0, 8.0, 10.0] and quick.value == 9.25


def test_staircase_bounds(monkeypatch):
    exp = EXPERIMENTS["step_release"]
    monkeypatch.setattr(validate, "run_trial", _fake_trial(lambda m: False))
    th = run_experiment(exp, "young", 9)
    assert th.bound == "<" and th.value == exp.lo and len(th.trials) == 1
    monkeypatch.setattr(validate, "run_trial", _fake_trial(lambda m: True))
    th = run_experiment(exp, "young", 9)
    assert th.bound == ">" and th.value == exp.hi and len(th.trials) == int(exp.hi - exp.lo) + 1
    assert math.isclose(max(t.magnitude for t in th.trials), exp.hi) and np.all([t.passed for t in th.trials])
