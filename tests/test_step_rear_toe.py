"""The rear foot on its toe is no support after the step (``StepProgramConfig.rear_toe_free_deg``;
docs/validate.md, "The young's rear foot flung"): with the rear foot trailing
(``rear_trails``), after the step in double support, the QP is not given the rear foot while its
sole is tilted more than the angle, the tilt checked against the foot's own quaternion
(MuJoCo's ``xquat``: the sole normal's angle from the vertical, ``acos(1 - 2 (x^2 + y^2))``)."""

from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from biped.analysis.validate import EXPERIMENTS
from biped.control.step_program import StepProgramConfig
from biped.errors import ScenarioError
from biped.sim import Scenario
from biped.sim.push import controller_policy
from biped.sim.scene import build_scene, initial_state


def test_rear_toe_free_must_be_a_number_at_least_zero():
    with pytest.raises(ScenarioError, match="rear_toe_free_deg must be a number >= 0"):
        StepProgramConfig(rear_toe_free_deg=-1.0)


def _quat_tilt_deg(d, body: int) -> float:
    _, x, y, _ = d.xquat[body]
    return math.degrees(math.acos(min(1.0, 1.0 - 2.0 * (x * x + y * y))))


def test_the_rear_foot_tilted_past_the_angle_is_no_support_after_the_step():
    exp = EXPERIMENTS["step_release"]
    s = Scenario(neuromotor="young", **{**exp.base, **exp.preset_keys["young"], **exp.magnitude(5.0)})
    scene = build_scene(s)
    c = controller_policy(s, scene)
    assert c.program.rear_trails  # validate's young program
    c.program = replace(c.program, rear_toe_free_deg=25.0)
    c.reset()
    q0, _ = initial_state(scene, s)
    q = np.array(q0[scene.biped_qpos_index])
    names = list(scene.joint_names)
    ankle = 7 + names.index("right_ankle_dorsiflexion")  # the right foot: the rear one
    m, d = c.model, c.data
    a0 = float(q[ankle])
    seen = []
    for da in np.arange(-42.0, 43.0, 4.0):  # the rear foot rolled either way from the stance
        q[ankle] = a0 + math.radians(da)
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        tilt = _quat_tilt_deg(d, c._foot[1])
        assert c._tilt_deg(1) == pytest.approx(tilt, abs=1e-6)
        c.phase, c.steps = "double", [{"foot": "left"}]
        assert c._flags(True, True) == (True, tilt < 25.0), (da, tilt)
        c.steps = [{"foot": "right"}]  # the tilted foot is the front one: a support
        assert c._flags(True, True) == (True, True)
        c.phase, c.steps = "double", []  # before the step: the stepping controller's flags
        assert c._flags(True, True) == (True, True)
        seen.append(tilt)
    assert min(seen) < 10.0 and max(seen) > 30.0  # both sides of the angle were tried
    c.program = replace(c.program, rear_toe_free_deg=0.0)  # off: the program before
    c.phase, c.steps = "double", [{"foot": "left"}]
    assert c._flags(True, True) == (True, True)
