"""Stepping only when the feet cannot hold (issue #23): pushes at the edge of the QP's own
feet-in-place envelope are recovered without a step; a step's XCoM at touchdown (Hof's extrapolated
COM, recorded for the comparison with Hof, Vermerris & Gjaltema 2010) against MuJoCo's whole-body
COM of the recorded state; the stance foot's slip against MuJoCo's foot poses."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from _helpers import goal_push_scenario, leg_geoms, run_qp_stepping

from biped.control import capture as cp
from biped.control.capture import xcom_offset
from biped.sim.push import simulate
from biped.sim.scene import build_scene


def _sweep_scenario(speed, direction, *flags):
    """One `biped sweep --distribution qp` trial (hold task, 1.8 kg block at 1.2 m, fast physics,
    early stop), 4 s like the envelopes of docs/sweep.md, stepping with ``step_trigger = "qp"``."""
    from biped.cli import build_parser
    from biped.cli.sweep import build_spec

    args = ["sweep", "--speed", str(speed), "--direction", str(direction), "--distribution", "qp"]
    sets = ["--set", "duration_s=4", "--set", 'step_trigger="qp"']
    spec = build_spec(build_parser().parse_args([*args, *sets, *flags]))
    return spec.scenario(spec.trials()[0])


def test_step_trigger_key():
    from biped.control.stepping import SteppingConfig
    from biped.errors import ScenarioError
    from biped.sim import Scenario

    # the default is "qp"; without stepping the key stays out (W's outputs as before), with
    # stepping it is recorded (files without it were stepping with the old default, "capture")
    assert Scenario().step_trigger == "qp" and "step_trigger" not in Scenario().to_dict()
    assert Scenario(stepping=True).to_dict()["step_trigger"] == "qp"
    assert Scenario(step_trigger="capture").to_dict()["step_trigger"] == "capture"
    with pytest.raises(ScenarioError, match="step_trigger"):
        Scenario(step_trigger="late")
    q = SteppingConfig.for_trigger("qp")
    assert q.holding_sensed and q.lateral_margin_m == 0.0 and q.limits.max_back == 0.45
    assert SteppingConfig.for_trigger("capture") == SteppingConfig()


def test_default_trigger_is_qp_where_users_see_it(tmp_path):
    """`biped sweep --stepping` and `biped push --stepping` without a trigger: the sweep file's
    scenario, the trial's controller and the push's summary.json all say "qp" (the controller's
    parameters those of ``SteppingConfig.for_trigger("qp")``, not "capture"'s); an old stepping
    sweep file without the key (the old default) is refused, not resumed with "qp"."""
    import json

    from biped.cli import build_parser, main
    from biped.cli.sweep import build_spec
    from biped.control.stepping import SteppingConfig
    from biped.sim.policies import controller_policy
    from biped.sim.scenario import stored_values
    from biped.sim.sweep.store import spec_difference

    spec = build_spec(
        build_parser().parse_args(["sweep", "--speed", "3", "--direction", "180", "--stepping"])
    )
    assert spec.to_dict()["scenario"]["step_trigger"] == "qp"
    sc = spec.scenario(spec.trials()[0])
    pol = controller_policy(sc, build_scene(sc))
    assert pol.stepping == SteppingConfig.for_trigger("qp", max_steps=sc.max_steps)
    assert pol.stepping != SteppingConfig.for_trigger("capture", max_steps=sc.max_steps)
    old = spec.to_dict()
    del old["scenario"]["step_trigger"]
    assert "step_trigger: 'capture' in the file, 'qp' now" in spec_difference(old, None, spec)
    assert stored_values(old["scenario"])["step_trigger"] == "capture"  # what the old file ran
    assert main(["push", "--stepping", "--duration", "0.02", "--no-video", "--out", str(tmp_path / "p")]) == 0
    summary = json.loads((tmp_path / "p" / "summary.json").read_text())
    assert summary["scenario"]["step_trigger"] == "qp"


def test_trigger_waits_while_the_capture_point_returns():
    """The rate condition: outside the polygon but moving back in (the hip strategy turning it)
    does not fire; moving out fires after `hold` calls; without a rate the old rule fires."""
    poly = cp.support_polygon([((0.0, 0.0), 0.0, 0.1, 0.05)])
    xi = np.array([0.12, 0.0])  # 2 cm beyond the front edge
    back, out = np.array([-0.05, 0.0]), np.array([0.05, 0.0])
    trig = cp.CaptureTrigger(0.0, 0.02, 3, 0.0, min_rate_m_s=0.0)
    assert not any(trig.update(poly, xi, back) for _ in range(10))
    assert [trig.update(poly, xi, out) for _ in range(3)] == [False, False, True]
    old = cp.CaptureTrigger(0.0, 0.02, 3, 0.0)
    assert [old.update(poly, xi, back) for _ in range(3)] == [False, False, True]
    # sideways (beyond the y-extent): the outward direction is +y
    trig = cp.CaptureTrigger(0.0, 0.02, 1, 0.0, min_rate_m_s=0.0)
    assert not trig.update(poly, np.array([0.0, 0.07]), np.array([0.5, -0.01]))
    assert trig.update(poly, np.array([0.0, 0.07]), np.array([-0.5, 0.01]))


@pytest.mark.slow
@pytest.mark.parametrize(("speed", "direction"), [(15, 0), (13, 90), (9, 180)])
def test_push_the_qp_holds_is_held_without_a_step(speed, direction):
    """At the edge of the QP's feet-in-place envelope by the strict rule (front 15, side 13,
    behind 9 m/s; docs/sweep.md): the QP alone recovers it, and so does stepping, without a step."""
    qp = simulate(_sweep_scenario(speed, direction))
    assert qp.recovered and not qp.fell
    r = simulate(_sweep_scenario(speed, direction, "--stepping"))
    assert r.extra["steps"] == []
    assert r.recovered and r.extra["final_com_speed_m_s"] < 0.05


@pytest.mark.slow
def test_front_push_the_feet_hold_only_on_their_toes_steps_and_ends_at_rest():
    """16 m/s from the front: the QP alone keeps the capture point inside the polygon, 1.2 cm from
    its heel edge at 0.4-0.8 s, then, rocking back, within 2 cm of the toe edge from ~2.2 s, and
    falls over it at ~3.1 s (traced). The slow trigger (xi within ``dwell_margin_m`` of the edge
    for ``dwell_s``) steps once, back, at 0.66 s (measured), and the run is at rest over the new
    feet at 4 s (the strict rule). Without it (``dwell_s`` None) the step comes at >= 3 s and
    the run ends not at rest."""
    sc = _sweep_scenario(16, 0, "--stepping")
    r = simulate(sc)
    steps = r.extra["steps"]
    assert len(steps) == 1 and not steps[0]["sideways"], steps
    assert steps[0]["start_s"] < 1.0
    assert steps[0]["position_m"][0] > r.feet_pos[0, :, 0].max() + 0.1  # back: +x, the biped faces -x
    assert r.recovered and r.extra["final_com_speed_m_s"] < 0.05
    old = run_qp_stepping(sc, dwell_s=None)
    assert old.extra["steps"] and old.extra["steps"][0]["start_s"] >= 3.0
    assert not old.recovered


@pytest.mark.slow
def test_front_push_beyond_hofs_bound_ends_at_rest_over_the_new_feet():
    """20 m/s from the front (0 deg): an impulse above Hof's feet-in-place bound for that
    direction (J_max = m omega_0 d from MuJoCo's COM and sole corners, biped.analysis) is
    recovered by the strict rule (at rest over the final feet's set point) with one step, back
    (Hof, Vermerris & Gjaltema 2010: people are done within two steps). The backward step lands
    wide enough that the capture point lies inside the new sole across too (``side_margin_m``):
    landing on the predicted capture point across, the body drifted sideways over the new foot
    and two sideways steps followed (measured: 3 steps, the last sliding 12 cm)."""
    from biped.analysis import feet_in_place_bound
    from biped.sim.sweep.trial import measure

    sc = _sweep_scenario(20, 0, "--stepping")
    r = simulate(sc)
    j_max = float(feet_in_place_bound([0.0], sc).j_max_n_s[0])
    assert measure(r, np.asarray(r.block_velocity)).impulse_horizontal_n_s > j_max  # (Hof: horizontal)
    steps = r.extra["steps"]
    assert len(steps) == 1 and not steps[0]["sideways"], steps
    assert steps[0]["position_m"][0] > r.feet_pos[0, :, 0].max() + 0.2  # back: +x, the biped faces -x
    assert r.recovered and r.extra["final_com_speed_m_s"] < 0.05


@pytest.mark.slow
def test_touchdown_xcom_and_slip_against_mujoco():
    """A sideways step (15 m/s at 90 deg, beyond the QP's 13): the XCoM recorded at touchdown is
    x + v / omega_0 of the whole-body COM that MuJoCo computes from the recorded state (the scene's
    own model, block included, not the controller's copy), the landing lies outward of it (Hof
    2010), and the stance slip equals the stance sole's displacement in MuJoCo's foot poses."""
    sc = _sweep_scenario(15, 90, "--stepping")
    r = simulate(sc)
    assert r.extra["steps"], "expected a step"
    st = r.extra["steps"][0]
    scene = build_scene(sc)
    m, d = scene.model, mujoco.MjData(scene.model)
    root = int(m.body_rootid[scene.central_body])
    k = int(np.argmin(np.abs(r.times - st["touch_down_s"])))
    d.qpos[:], d.qvel[:] = r.qpos[k], r.qvel[k]
    mujoco.mj_forward(m, d)
    mujoco.mj_subtreeVel(m, d)
    com, v = d.subtree_com[root], d.subtree_linvel[root]
    xi = com[:2] + v[:2] / math.sqrt(-m.opt.gravity[2] / com[2])
    np.testing.assert_allclose(st["xcom_m"], xi, atol=1e-6)
    stance = 1 - ("left", "right").index(st["foot"])
    assert st["xcom_offset_m"] == pytest.approx(
        xcom_offset(st["position_m"][:2], xi, r.feet_pos[k, stance, :2]), abs=0.01
    )
    assert st["xcom_offset_m"] > 0.0
    # the stance sole centre (the middle of its heel and toe boxes' outer ends, from MuJoCo's
    # geom poses) from the step's start to touchdown
    k0 = int(np.argmin(np.abs(r.times - st["start_s"])))
    foot = ("left", "right")[stance]
    moved = np.linalg.norm(_sole_centre(m, d, r.qpos[k], foot) - _sole_centre(m, d, r.qpos[k0], foot))
    assert st["stance_slip_m"] == pytest.approx(moved, abs=0.002)


def _sole_centre(m, d, qpos, foot):
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    h, t = (m.geom(f"{foot}_{p}").id for p in ("heel", "toe"))
    ends = []
    for g, sign in ((h, -1.0), (t, 1.0)):
        k = 0  # the boxes' x axis is the foot's long axis (the heel box is wider than long)
        e = d.geom_xmat[g].reshape(3, 3)[:, k]
        e = e if (d.geom_xpos[t] - d.geom_xpos[h]) @ e > 0 else -e  # heel -> toe
        ends.append(d.geom_xpos[g] + sign * m.geom_size[g][k] * e)
    return 0.5 * (ends[0] + ends[1])[:2]


@pytest.mark.slow
def test_goal_push_recovers_with_the_qp_trigger():
    """W's goal push of tests/test_stepping.py (4 kg at 8 m/s from behind, 32 N s, faithful
    physics, 4 s) with ``step_trigger = "qp"``: recovered by the strict rule within the three
    steps allowed. The hit yaws the body ~50 deg, and after two forward steps the capture point
    leaves the feet past the right foot, on the side away from the left one: the third step
    crosses over (``crossover``). Without the crossover the left foot stepped on its own side,
    away from the capture point, and the biped fell (measured)."""
    sc = goal_push_scenario()
    assert sc.physics == "faithful"
    r = simulate(sc)
    steps = r.extra["steps"]
    assert 1 <= len(steps) <= 3 and any(st["crossover"] for st in steps), steps
    assert r.recovered and r.extra["final_com_speed_m_s"] < 0.05, r.extra
    old = run_qp_stepping(sc, crossover=False)
    assert old.fell


@pytest.mark.slow
def test_tumble_in_single_support_is_a_fall_not_a_divergence():
    """22 m/s at 45 deg (beyond the stepping envelope), without the crossover: the biped
    cartwheels during its second swing, the stance foot in the air. The stance sole over 10 cm up is left out of the QP
    (``airborne_stance``), as a foot in the air in double support: the run ends in a fall. With
    the QP loading the foot in the air MuJoCo diverged (measured at 1.09 s)."""
    sc = _sweep_scenario(22, 45, "--stepping")
    scene = build_scene(sc)

    def run(**kw):  # without the crossover (with it this push falls otherwise, no tumble)
        return run_qp_stepping(sc, scene, crossover=False, **kw)

    assert simulate(sc).diverged is None
    r = run()
    assert r.fell and r.diverged is None
    assert run(airborne_stance=False).diverged is not None


@pytest.mark.slow
def test_crossover_step_clears_the_stance_leg_with_leg_contacts_on():
    """13 m/s at 90 deg, faithful physics: the QP alone holds the push for 2 s, the slow trigger
    steps the left foot, and the capture point then leaves the polygon past that foot, on the
    side away from the right foot: the right foot crosses behind the left one (a crossover,
    issue #23) and the run ends at rest (the strict rule). MuJoCo's contacts between the two legs
    are switched on (the scene has none: every biped geom is contype 2, conaffinity 1): none occurs
    in any recorded state, and the run is the same as without them. Without the crossover the
    right foot steps inward to 13 cm from the left one and the run is not at rest at 4 s (three
    steps, the third sliding 13.5 cm; measured)."""
    sc = _sweep_scenario(13, 90, "--stepping", "--physics", "faithful")
    plain = simulate(sc)
    scene = build_scene(sc)
    m = scene.model
    left, right = leg_geoms(m, "left"), leg_geoms(m, "right")
    assert left and right and not set(left) & set(right)
    for gs, own, other in ((left, 4, 8), (right, 8, 4)):
        m.geom_contype[gs] = own
        m.geom_conaffinity[gs] = 1 | other
    r = run_qp_stepping(sc, scene)
    steps = r.extra["steps"]
    assert len(steps) == 2 and steps[1]["crossover"] and not steps[0]["crossover"], steps
    assert steps[1]["foot"] == "right" and steps[1]["position_m"][1] < steps[0]["position_m"][1] - 0.1
    assert r.recovered and r.extra["final_com_speed_m_s"] < 0.05
    d = mujoco.MjData(m)
    lset, rset = set(left), set(right)
    touching = 0
    for q in r.qpos:
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        for c in d.contact[: d.ncon]:
            a, b = int(c.geom1), int(c.geom2)
            touching += (a in lset and b in rset) or (a in rset and b in lset)
    assert touching == 0
    np.testing.assert_allclose(r.qpos[-1], plain.qpos[-1], atol=1e-9)
    old = run_qp_stepping(sc, crossover=False)
    assert not any("crossover" in st for st in old.extra["steps"]) and not old.recovered


def _sole_centres(scene, qpos):
    """The two soles' centres (world, (2, 3)) of MuJoCo's recorded state ``qpos``: the mean of each
    foot body's geoms' centres (its heel and toe boxes)."""
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_forward(m, d)
    out = []
    for side in ("left", "right"):
        b = m.body(f"{side}_foot").id
        geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] == b]
        out.append(np.mean([d.geom_xpos[g] for g in geoms], axis=0))
    return np.array(out)


@pytest.mark.slow
def test_closing_step_brings_the_feet_back_to_a_comfortable_stance():
    """16 m/s from behind (fast physics, 4 s) with ``closing_step`` on (issue #23 item 2; off in
    the "qp" set): one backward step leaves the feet 43 cm apart along the push; once at rest the
    closing step brings one foot back beside the other. By MuJoCo's recorded feet at the end: not
    crossed (each foot on its own side, as at the start), the lateral distance of the sole centres
    within 5 cm of the starting stance's, the stagger within 5 cm; at rest by the strict rule. The
    closing step is recorded (``closing``) and not counted among the recovery steps (the sweep's
    ``step_count``). Without it the feet stay staggered."""
    sc = _sweep_scenario(16, 180, "--stepping")
    scene = build_scene(sc)

    r = run_qp_stepping(sc, scene, closing_step=True)
    steps = r.extra["steps"]
    assert [st["closing"] for st in steps] == [False, True], steps
    start, end = _sole_centres(scene, r.qpos[0]), _sole_centres(scene, r.qpos[-1])
    w0, w1 = start[1] - start[0], end[1] - end[0]  # the right sole centre from the left one
    assert w0[1] > 0.1 and w1[1] > 0.0  # the right foot on its own side (+y), start and end
    assert abs(w1[1] - w0[1]) <= 0.05 and abs(w1[0] - w0[0]) <= 0.05, (w0, w1)
    assert r.recovered and r.extra["final_com_speed_m_s"] < 0.05, r.extra
    old = run_qp_stepping(sc, scene, closing_step=False)
    oe = _sole_centres(scene, old.qpos[-1])
    assert abs((oe[1] - oe[0])[0] - w0[0]) > 0.3 and old.recovered  # staggered, at rest


@pytest.mark.slow
def test_crossover_push_ends_uncrossed_after_the_closing_step():
    """18 m/s from the side (fast physics) with ``closing_step`` on: a sideways step, then a
    crossover (the left foot lands right of the right one); at rest, the closing step uncrosses
    the feet. By MuJoCo's recorded feet at the end: the right foot on its own side again, the
    lateral distance of the sole centres within 5 cm of the starting stance's, the stagger within
    5 cm; at rest by the strict rule. The closing step starts at ~3.1 s: this needs a 6 s trial
    (at 4 s the run survives, not yet at rest; docs/sweep.md). Without it the feet stay crossed."""
    sc = _sweep_scenario(18, 90, "--stepping").with_overrides(duration_s=6.0)
    scene = build_scene(sc)

    r = run_qp_stepping(sc, scene, closing_step=True)
    steps = r.extra["steps"]
    assert any(st["crossover"] for st in steps) and [st["closing"] for st in steps][-1], steps
    start, end = _sole_centres(scene, r.qpos[0]), _sole_centres(scene, r.qpos[-1])
    w0, w1 = start[1] - start[0], end[1] - end[0]  # the right sole centre from the left one
    assert w0[1] > 0.1 and w1[1] > 0.0  # the right foot on its own side (+y), start and end
    assert abs(w1[1] - w0[1]) <= 0.05 and abs(w1[0] - w0[0]) <= 0.05, (w0, w1)
    assert r.recovered and r.extra["final_com_speed_m_s"] < 0.05, r.extra
    oe = _sole_centres(scene, run_qp_stepping(sc, scene, closing_step=False).qpos[-1])
    assert (oe[1] - oe[0])[1] < 0.0  # crossed: the right foot left of the left one
