"""The ideal preset's waist-pull threshold (0.0231 m, 38.8 % BoS) is where its knees reach
straight, W's controller's singularity: past it, with W's min-norm split, the torques grow each
control period until MuJoCo's integration diverges; with the QP distribution the same pull keeps
every state finite and ends as a fall at the same magnitude (docs/validate.md, "The ideal's
waist-pull divergence"). The experiment runs on the QP since 2026-11-28; the min-norm rows here
name it (``distribution = "statics"``)."""

from __future__ import annotations

import math

import numpy as np
import pytest


def _pull(displacement_m: float, **extra):
    from biped.analysis.validate import EXPERIMENTS
    from biped.sim import simulate
    from biped.sim.scenario import Scenario
    from biped.sim.scene import build_scene

    exp = EXPERIMENTS["waist_pull"]
    s = Scenario(neuromotor="ideal", **{**exp.base, **exp.magnitude(displacement_m), **extra})
    scene = build_scene(s)
    r = simulate(s, scene=scene)
    rows = int(np.flatnonzero(np.any(r.qpos != 0.0, axis=1))[-1]) + 1  # the rows the run recorded
    jq = scene.joint_qpos_index
    knees = np.degrees(r.qpos[:rows][:, [jq[3], jq[9]]]).max(axis=1)  # the straighter knee; 0 = straight
    return s, r, rows, knees


@pytest.mark.slow
def test_ideal_waist_pull_divergence_is_the_knee_passing_straight_and_the_qp_makes_it_a_fall():
    """W's min-norm split (the protocol's until 2026-11-28): the largest pull held (0.0231 m) keeps both
    knees over 0.3 deg bent (they start 12 deg bent; MuJoCo's recorded angles); the next
    (0.0233 m) straightens a knee while the torques are still those of standing (under 300 N m),
    and only then do they grow past 1 kN and MuJoCo's integration diverges (the knee's Jacobian
    singular: W's controller has no straight-knee handling). The QP distribution (its bounded
    normal forces bound the torques) runs the same 0.0233 m pull with every recorded state
    finite and ends it as a fall, not a divergence; 0.0231 m it holds."""
    s, r, rows, knees = _pull(0.0231, distribution="statics")
    assert r.diverged is None and not r.fell and math.isclose(r.times[rows - 1], s.duration_s, abs_tol=0.01)
    assert knees.max() < -0.3, knees.max()

    s, r, rows, knees = _pull(0.0233, distribution="statics")
    assert r.diverged is not None and not r.fell
    tau = np.abs(r.torques[:rows]).max(axis=1)
    straight = int(np.argmax(knees > 0.0))
    assert knees[straight] > 0.0  # a knee passed straight ...
    assert tau[: straight + 1].max() < 300.0, tau[: straight + 1].max()  # ... with standing torques
    assert tau.max() > 1e3 and int(np.argmax(tau > 1e3)) > straight  # the blow-up follows it

    for d, falls in ((0.0231, False), (0.0233, True)):
        s, r, rows, _ = _pull(d, distribution="qp")
        assert r.diverged is None and r.controller_error is None, d
        assert np.isfinite(r.qpos).all() and np.isfinite(r.qvel).all() and np.isfinite(r.torques).all(), d
        assert r.fell is falls, (d, r.fall_time_s, r.fall_reason)
