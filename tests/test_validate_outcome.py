"""``biped validate``'s trials say what came of each run (``Trial.outcome``): a divergence is told
from a fall by MuJoCo's own warning counters, read from the MjData the run stepped, not by the
code's flag (docs/validate.md, "The trials' outcome")."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest


def _trial_and_mujoco_warnings(monkeypatch, distribution: str, displacement_m: float):
    """The ideal preset's waist pull at ``displacement_m`` with ``distribution``: (the Trial,
    MuJoCo's warning counts summed over every MjData made during the run, by warning type)."""
    import mujoco

    from biped.analysis.validate import EXPERIMENTS, run_trial

    made: list = []
    real = mujoco.MjData

    def counted(m):
        d = real(m)
        made.append(d)
        return d

    monkeypatch.setattr(mujoco, "MjData", counted)
    exp = EXPERIMENTS["waist_pull"]
    exp = dataclasses.replace(exp, base={**exp.base, "distribution": distribution})
    t = run_trial(exp, "ideal", displacement_m)
    monkeypatch.setattr(mujoco, "MjData", real)
    names = [n for n in dir(mujoco.mjtWarning) if n.startswith("mjWARN_")]
    counts = {n: sum(int(d.warning[int(getattr(mujoco.mjtWarning, n))].number) for d in made) for n in names}
    return t, counts


@pytest.mark.slow
def test_a_diverging_trial_says_diverged_and_a_fall_fell_as_mujoco_counts_them(monkeypatch):
    """W's min-norm split on the ideal preset's 0.0233 m waist pull straightens a knee and its
    torques grow until MuJoCo reports a bad acceleration (docs/validate.md, "The ideal's waist-pull
    divergence"): the trial says "diverged" and MuJoCo's mjWARN_BADQACC counter is non-zero; the
    QP's same pull falls: "fell", with every MuJoCo warning counter zero."""
    t, counts = _trial_and_mujoco_warnings(monkeypatch, "statics", 0.0233)
    assert counts["mjWARN_BADQACC"] >= 1, counts
    assert t.outcome == "diverged" and not t.survived and not t.passed, (t.outcome, t.detail)
    assert "diverged" in t.detail

    t, counts = _trial_and_mujoco_warnings(monkeypatch, "qp", 0.0233)
    assert not any(counts.values()), counts
    assert t.outcome == "fell" and t.fall_time_s is not None and t.detail == "", (t.outcome, t.detail)


def _run(**kw):
    rows = np.zeros((3, 4))
    base = dict(diverged=None, controller_error=None, fell=False, recovered=False, qpos=rows, qvel=rows,
                torques=rows)  # fmt: skip
    return SimpleNamespace(**{**base, **kw})


def test_outcome_reads_a_non_finite_state_as_a_divergence_before_an_error_or_a_fall():
    """A recorded NaN or infinity (a non-finite torque, say, which MuJoCo zeroes with a warning the
    loop does not flag) is a divergence; a divergence outranks the controller's error and the fall
    it may end in."""
    from biped.analysis.validate import outcome

    bad = np.zeros((3, 4))
    bad[2, 1] = math.nan
    inf = np.zeros((3, 4))
    inf[1, 0] = math.inf
    assert outcome(_run(qvel=bad))[0] == "diverged"
    assert outcome(_run(torques=inf, fell=True))[0] == "diverged"
    assert outcome(_run(diverged="MuJoCo's integration diverged", controller_error="x", fell=True)) == (
        "diverged",
        "MuJoCo's integration diverged",
    )
    assert outcome(_run(controller_error="t = 0.3 s: singular", fell=True)) == (
        "error",
        "t = 0.3 s: singular",
    )
    assert outcome(_run(fell=True)) == ("fell", "")
    assert outcome(_run(recovered=True)) == ("recovered", "")
    assert outcome(_run()) == ("survived", "")
