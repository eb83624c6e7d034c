"""The rear foot put flat once the lunge has stopped (``StepProgramConfig.rear_rest_speed_m_s``;
docs/validate.md, "The young's rear foot at rest"): after the step, with ``rear_trails``, the
height set point is capped by the front leg alone while the body moves and by both legs once its
COM has slowed below the speed (latched). Checked against the cap's closed form on MuJoCo's
kinematics: a leg of hip-to-ankle length L, its hip a horizontal distance r from its ankle, the
ankle at its flat height z_a, reaches a hip height of z_a + sqrt(L^2 - r^2)."""

from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from biped.analysis.validate import EXPERIMENTS
from biped.control.step_program import REAR_FLAT_DEG, StepProgramConfig
from biped.control.workspace import Target
from biped.errors import ScenarioError
from biped.sim import Scenario
from biped.sim.push import controller_policy
from biped.sim.scene import build_scene, initial_state


def test_rear_rest_speed_must_be_a_number_at_least_zero():
    with pytest.raises(ScenarioError, match="rear_rest_speed_m_s must be a number >= 0"):
        StepProgramConfig(rear_rest_speed_m_s=-0.1)


def _closed_form_z(c, leg: int) -> float:
    """The central body's COM height at which leg ``leg``'s hip is as high as the leg reaches."""
    d = c.data
    hip, ank = d.xpos[c._hip[leg]], d.xpos[c._ankle[leg]]
    r = math.hypot(float(hip[0] - ank[0]), float(hip[1] - ank[1]))
    reach = c._ankle_z0 + math.sqrt(c.stepping.span_leg_m**2 - r**2)
    return float(d.xipos[c._root][2]) + reach - float(hip[2])


def test_the_rear_leg_caps_the_height_again_once_the_com_has_slowed():
    exp = EXPERIMENTS["step_release"]
    s = Scenario(neuromotor="young", **{**exp.base, **exp.preset_keys["young"], **exp.magnitude(5.0)})
    scene = build_scene(s)
    c = controller_policy(s, scene)
    assert c.program.rear_trails  # validate's young program
    c.program = replace(c.program, rear_rest_speed_m_s=0.1)
    c.reset()
    q0, _ = initial_state(scene, s)
    q = np.array(q0[scene.biped_qpos_index])
    names = list(scene.joint_names)
    # a lunge's pose: the left (landing) leg forward (the biped faces -x), the right one behind
    q[7 + names.index("left_hip_flexion")] = math.radians(35.0)
    q[7 + names.index("right_hip_flexion")] = math.radians(-25.0)
    q[7 + names.index("left_knee")] = math.radians(-30.0)
    m, d = c.model, c.data
    ankle = 7 + names.index("right_ankle_dorsiflexion")

    def rear_tilt_deg(a: float) -> float:
        q[ankle] = a
        d.qpos[:] = q
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)
        return math.degrees(math.acos(min(1.0, float(d.xmat[c._foot[1]][8]))))

    flat = min((math.radians(a) for a in np.arange(-40.0, 40.5, 0.5)), key=rear_tilt_deg)
    assert rear_tilt_deg(flat + math.radians(20.0)) > 10.0  # the rear foot on its toe (or heel)
    c._ankle_z0 = float(np.mean([d.xpos[a][2] for a in c._ankle]))
    c.phase, c.steps = "double", [{"foot": "left"}]
    high = Target.wendlandt(com=(0.0, 0.0, 3.0))
    front, rear = _closed_form_z(c, 0), _closed_form_z(c, 1)
    assert rear < front - 0.02, (front, rear)  # the rear leg reaches less high in this pose

    def capped(vx: float) -> float:
        v = np.zeros(m.nv)
        v[0] = vx  # the free joint's x velocity: the whole body moving
        d.qvel[:] = v
        mujoco.mj_forward(m, d)
        return float(c._leg_capped(high, (0, 1)).com[2])

    assert capped(-0.5) == pytest.approx(front, abs=1e-9)  # lunging: the front leg's cap alone
    assert capped(0.0) == pytest.approx(front, abs=1e-9)  # stopped, the rear foot tilted: the same
    assert not c._rear_rests
    assert rear_tilt_deg(flat) < REAR_FLAT_DEG  # the rear sole flat
    assert capped(0.0) == pytest.approx(min(front, rear), abs=1e-9)  # stopped: both legs'
    assert capped(-0.5) == pytest.approx(min(front, rear), abs=1e-9)  # latched
    # without the latch (0): the front leg's cap to the end, as the program was
    c.program = replace(c.program, rear_rest_speed_m_s=0.0)
    c._rear_rests = False
    assert capped(0.0) == pytest.approx(front, abs=1e-9)
