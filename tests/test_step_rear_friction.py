"""The rear foot's friction after the step (``SteppingConfig.post_step_friction_scale``, which
``step_reach = "leg"``, validate's one-step lean release, sets to
``biped.sim.policies.POST_STEP_FRICTION_SCALE``; docs/validate.md, "The rear foot's friction after
the step"): the double support after the step plans its friction at that share of the floor's,
so that the QP no longer holds the trunk with lateral forces at the friction limit of a rear foot
that landed on its toe edge with the QP's minimum load. Checked on MuJoCo's recorded state and
against the friction pyramid's closed form."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from biped.analysis.validate import EXPERIMENTS
from biped.control.stepping import SteppingConfig
from biped.sim import Scenario, build_scene, policies
from biped.sim.policies import POST_STEP_FRICTION_SCALE, controller_policy
from biped.sim.push import run_closed_loop

LEAN_DEG = 11.0  # the ideal's first fall by the staircase before the change (1.93 s)


def _scenario(lean: float = LEAN_DEG, **changes) -> Scenario:
    """Validate's one-step lean release of the ideal preset, as ``run_trial`` builds it."""
    exp = EXPERIMENTS["step_release"]
    return Scenario(neuromotor="ideal", **{**exp.base, **exp.magnitude(lean), **changes})


def _run(s: Scenario, on_step=None):
    scene = build_scene(s)
    pol = controller_policy(s, scene)
    return scene, pol, run_closed_loop(s, scene, pol, on_step=on_step)


def test_the_key_is_set_only_by_the_legs_reach_with_the_feedback_stepper():
    """Off by default (the sweeps' and W's stepping unchanged), on with ``step_reach = "leg"`` and
    the feedback stepper (validate's ideal preset), off with the step program (its young lunge)."""
    assert SteppingConfig().post_step_friction_scale is None
    assert SteppingConfig.for_trigger("qp").post_step_friction_scale is None
    for reach, program, want in (("fixed", "feedback", None), ("leg", "feedback", POST_STEP_FRICTION_SCALE),
                                 ("leg", "program-trail", None)):  # fmt: skip
        s = Scenario(stepping=True, step_reach=reach, step_program=program, distribution="qp")
        pol = controller_policy(s, build_scene(s))
        assert pol.stepping.post_step_friction_scale == want
        assert (pol._ctrl_post is pol.ctrl) == (want is None)


def test_an_11_deg_release_the_ideal_fell_from_ends_still_on_its_two_feet(monkeypatch):
    """MuJoCo's run, validate's protocol (7 s): without the margin the ideal's one step lands
    (0.29 m, 0.41 s) and the biped falls (measured 1.93 s) after its rear foot slid away (0.4 m back
    and out); with it the same step ends with the COM still (< 5 cm/s, MuJoCo's qvel) and the rear
    foot within 10 cm of where it stood at the touchdown (MuJoCo's foot frames)."""
    s = _scenario()
    scene, pol, r = _run(s)
    assert not r.fell and len(pol.steps) == 1
    assert float(np.linalg.norm(r.qvel[-1, :3])) < 0.05
    front = ("left", "right").index(pol.steps[0]["foot"])
    k = int(np.searchsorted(r.times, pol.steps[0]["touch_down_s"]))
    slide = np.linalg.norm(r.feet_pos[k:, 1 - front, :2] - r.feet_pos[k, 1 - front, :2], axis=1)
    assert slide.max() < 0.10
    monkeypatch.setattr(policies, "POST_STEP_FRICTION_SCALE", None)  # the controller before
    _, pol0, r0 = _run(s)
    assert pol0._ctrl_post is pol0.ctrl and len(pol0.steps) == 1
    assert r0.fell  # the fall this change removes (the test can fail)
    k0 = int(np.searchsorted(r0.times, pol0.steps[0]["touch_down_s"]))
    far = np.linalg.norm(r0.feet_pos[k0:, 1 - front, :2] - r0.feet_pos[k0, 1 - front, :2], axis=1)
    assert far.max() > 0.25


def _sole_force(m, d, foot_body: int, wrench) -> np.ndarray:
    """The force of a foot wrench given in the foot's COM principal frame (the controller's
    ``foot_wrench_*``), in the foot body's frame (W's sole axes): MuJoCo's ``ximat``, ``xmat``."""
    world = d.ximat[foot_body].reshape(3, 3) @ np.asarray(wrench[:3])
    return d.xmat[foot_body].reshape(3, 3).T @ world


def test_the_post_step_qp_keeps_each_foots_shear_inside_the_scaled_pyramid(monkeypatch):
    """0.3 s after the touchdown of the 11 deg step (MuJoCo's state of the run without the margin,
    where the rear foot was sliding; its controller's target, gains and feet): the post-step QP's
    foot forces satisfy the friction pyramid ``|f_x|, |f_y| <= scale mu f_z`` on the sole's axes
    (its closed form, mu the floor's 1.0), and the stepping QP's own at that state asks a foot
    for more than that share."""
    s = _scenario(duration_s=0.75)
    scene = build_scene(s)
    post = controller_policy(s, scene)._ctrl_post  # the margin on
    monkeypatch.setattr(policies, "POST_STEP_FRICTION_SCALE", None)
    pol = controller_policy(s, scene)
    assert post is not pol.ctrl and pol._ctrl_post is pol.ctrl
    ratios = {}

    def grab(m, data):
        if abs(data.time - 0.7) > 1e-6:
            return
        assert pol.phase == "double" and len(pol.steps) == 1
        q, v = data.qpos[scene.biped_qpos_index].copy(), data.qvel[scene.biped_qvel_index].copy()
        d = pol.data
        d.qpos[:], d.qvel[:] = q, v
        mujoco.mj_forward(pol.model, d)
        target = pol._leg_capped(pol.target, (0, 1))
        for name, ctrl in (("post", post), ("plain", pol.ctrl)):
            out = ctrl.compute(q, v, target=target, gains=pol.gains, feet_in_contact=(True, True))
            fs = [_sole_force(pol.model, d, pol._foot[i], w)
                  for i, w in enumerate((out.foot_wrench_left, out.foot_wrench_right))]  # fmt: skip
            assert all(f[2] > 0 for f in fs)
            ratios[name] = [max(abs(f[0]), abs(f[1])) / f[2] for f in fs]

    run_closed_loop(s, scene, pol, on_step=grab)
    scale = POST_STEP_FRICTION_SCALE * s.friction
    assert max(ratios["post"]) <= scale + 1e-3
    assert max(ratios["plain"]) > scale + 0.05


@pytest.mark.parametrize("bad", [0.0, -0.1, float("nan")])
def test_a_bad_scale_is_refused_by_the_qp(bad):
    """The QP's weights refuse a friction scale that is not a finite number > 0 (one line)."""
    from biped.errors import ScenarioError

    s = Scenario(stepping=True, step_reach="fixed", distribution="qp")
    scene = build_scene(s)
    pol = controller_policy(s, scene)
    from dataclasses import replace

    with pytest.raises(ScenarioError, match="friction_scale must be a finite number > 0"):
        type(pol)(pol.config, replace(pol.stepping, post_step_friction_scale=bad), pol.joint_names)
