"""Braking after the lunge (``step_program = "program-trail"``: the step program on the predicted
state with the rear foot trailing after the step; docs/validate.md, "Braking after the lunge"):
a young lean the program fell from after its step's landing now ends at rest on both feet
(MuJoCo's recorded state), and the key's bad values."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from biped.analysis.validate import EXPERIMENTS, _step_measures
from biped.control.step_program import StepProgramConfig
from biped.errors import ScenarioError
from biped.sim import Scenario
from biped.sim.push import simulate
from biped.sim.scene import build_scene


def test_rear_trails_is_a_bool():
    with pytest.raises(ScenarioError, match="rear_trails must be true or false"):
        StepProgramConfig(rear_trails=1)  # type: ignore[arg-type]
    assert Scenario(step_program="program-trail").step_program == "program-trail"


def _com_speed(scene, r, k: int) -> float:
    """The whole-body COM's horizontal speed [m/s] at recorded row ``k`` (MuJoCo's subtree)."""
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:] = r.qpos[k]
    d.qvel[:] = r.qvel[k]
    mujoco.mj_forward(m, d)
    mujoco.mj_subtreeVel(m, d)
    return float(np.hypot(*d.subtree_linvel[scene.central_body][:2]))


def test_a_young_10_deg_lunge_the_program_fell_from_ends_at_rest_with_the_rear_foot_trailing():
    """A 10 deg young release (validate's one-step protocol, 6 s): the step program on the
    predicted state lands its step and falls later (measured: 0.81 m, 698 ms, falls at 3.09 s, the
    front knee folding to 107 deg after the rear leg's height cap sank the hips); with the rear foot
    trailing the same step (the same landing: the change acts only after it) ends at rest, the
    COM slower than 2 cm/s over the last 0.5 s and both feet in contact and flat on the floor over
    the last 1 s, one recorded step; the rear foot rose off its flat position on the way (its heel
    up, rolled onto its toe, it trails). (Measured in a 7 s run: both soles flat from 3.97 s, the
    COM slower than 2 cm/s from 4.99 s to the end; the 6 s run is its first 6 s to the bit, 1 s
    less of the forward model's simulation.)"""
    exp = EXPERIMENTS["step_release"]
    base = {**exp.base, **exp.magnitude(10.0), "duration_s": 6.0}
    runs = {}
    for program in ("program-predicted", "program-trail"):
        s = Scenario(neuromotor="young", step_program=program, **base)
        scene = build_scene(s)
        runs[program] = (s, scene, simulate(s, scene=scene))
    s, _, old = runs["program-predicted"]
    assert old.fell, "the program without the trailing rear foot fell here (docs/validate.md)"
    s, scene, r = runs["program-trail"]
    assert not r.fell and r.diverged is None, r.fall_time_s
    n, length, contact = _step_measures(r, s)
    assert n == 1 and length > 0.6, (n, length)
    assert (length, contact) == pytest.approx(_step_measures(old, s)[1:])  # the same landing
    k = len(r.times) - 1
    assert r.times[k] == pytest.approx(6.0)
    rate = s.control_rate_hz
    speeds = [_com_speed(scene, r, j) for j in range(k - round(0.5 * rate), k + 1)]
    assert max(speeds) < 0.02, max(speeds)
    last = slice(k - round(1.0 * rate), k + 1)
    assert bool(np.all(r.left_contact[last])) and bool(np.all(r.right_contact[last]))
    flat = np.abs(r.feet_pos[last, :, 2] - r.feet_pos[0, :, 2])
    assert flat.max() < 0.01, flat.max()
    rear = 1 - ("left", "right").index(r.extra["steps"][0]["foot"])
    assert float(np.max(r.feet_pos[:, rear, 2] - r.feet_pos[0, rear, 2])) > 0.05
