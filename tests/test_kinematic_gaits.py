"""What B's code does not guarantee and the gaits must: stance feet on the ground without
sliding, swing feet clear of floor and stair edges, continuous joint angles. Over whole runs.

Oracles: MuJoCo's kinematics of the figure's MJCF (not the package's forward kinematics), the
terrain heights recomputed here from the stair blocks, B's closed forms eq. 4.20, 4.22, 4.23.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from biped.errors import ScenarioError
from biped.kinematic import (
    JOINT_NAMES,
    GaitParams,
    demo,
    figure_mjcf,
    jump,
    stair_geometry,
    step_forward,
    step_upward,
    walk_metrics,
)

RATE = 100.0
N_SOLE = 11  # points along each sole


def _terrain_z(blocks, x):
    z = np.zeros_like(x)
    for x0, x1, top in blocks:
        z = np.where((x >= x0) & (x < x1), np.maximum(z, top), z)
    return z


def _soles_by_mujoco(motion):
    """(T, 2, N_SOLE, 3) points along the left and right soles, from MuJoCo's foot frames."""
    d_ = motion.dims
    m = mujoco.MjModel.from_xml_string(figure_mjcf(d_))
    d = mujoco.MjData(m)
    from scipy.spatial.transform import Rotation

    quat = Rotation.from_matrix(motion.pelvis_rot).as_quat()[:, [3, 0, 1, 2]]
    adr = [m.joint(n).qposadr[0] for n in JOINT_NAMES]  # motion.angles' columns
    local = np.stack(
        [
            np.linspace(-d_.heel_back, d_.toe_front, N_SOLE),
            np.zeros(N_SOLE),
            np.full(N_SOLE, -d_.ankle_height),
        ],
        1,
    )
    feet = [m.body("left_foot").id, m.body("right_foot").id]
    T = motion.times.size
    out = np.empty((T, 2, N_SOLE, 3))
    for t in range(T):
        d.qpos[:3], d.qpos[3:7] = motion.pelvis_pos[t], quat[t]
        d.qpos[adr] = motion.angles[t]
        mujoco.mj_kinematics(m, d)
        for j, b in enumerate(feet):
            out[t, j] = d.xpos[b] + local @ d.xmat[b].reshape(3, 3).T
    return out


PLANS = {
    "forward": lambda: step_forward(steps=6),
    "upstairs": lambda: step_upward(steps=5),
    "upstairs_steep": lambda: step_upward(steps=4, rise=0.17, run=0.30),
    "jump": lambda: jump(),
    "jump_no_somersault": lambda: jump(params=GaitParams(somersault=False)),
    "demo": lambda: demo(),
}


@pytest.fixture(scope="module", params=list(PLANS))
def run(request):
    plan = PLANS[request.param]()
    motion = plan.sample(RATE)
    return request.param, plan, motion, _soles_by_mujoco(motion)


def test_no_sole_point_below_the_floor_or_a_stair(run):
    name, plan, _motion, soles = run
    gap = soles[..., 2] - _terrain_z(plan.terrain.blocks, soles[..., 0])
    assert gap.min() > -1e-3, f"{name}: a sole is {-gap.min() * 1e3:.3f} mm inside the terrain"


def test_stance_feet_stand_on_the_ground_and_do_not_slide(run):
    """While a foot bears weight its sole is on the floor or tread (within 1 mm) and no point of
    it moves more than 1 mm from where it stood when the stance began."""
    name, plan, motion, soles = run
    gap = soles[..., 2] - _terrain_z(plan.terrain.blocks, soles[..., 0])
    n_runs = 0
    for j in range(2):
        st = np.concatenate([[False], motion.stance[:, j], [False]]).astype(int)
        starts, stops = np.flatnonzero(np.diff(st) == 1), np.flatnonzero(np.diff(st) == -1)
        for a, b in zip(starts, stops, strict=True):
            n_runs += 1
            assert np.max(np.abs(gap[a:b, j])) < 1e-3, f"{name}: stance sole off the ground"
            slip = np.linalg.norm(soles[a:b, j] - soles[a, j], axis=-1).max()
            assert slip < 1e-3, f"{name}: stance foot slides {slip * 1e3:.3f} mm"
    assert n_runs >= 2


def test_swing_feet_clear_floor_and_stair_edges(run):
    """A swinging (or flying) sole is never inside the terrain and, in the middle half of its
    swing, at least 1 cm above the highest terrain under any of its points (stair nosings
    included)."""
    name, plan, motion, soles = run
    gap = soles[..., 2] - _terrain_z(plan.terrain.blocks, soles[..., 0])
    # the terrain under the sole can be higher between sample points: check the block edges too
    for j in range(2):
        ph = motion.swing_phase[:, j]
        mid = np.isfinite(ph) & (ph >= 0.25) & (ph <= 0.75)
        assert np.any(mid), f"{name}: no swing of foot {j}"
        xa, xb = soles[:, j, 0, 0], soles[:, j, -1, 0]
        za, zb = soles[:, j, 0, 2], soles[:, j, -1, 2]
        low = np.minimum(za, zb)
        for x0, x1, top in plan.terrain.blocks:
            over = (np.maximum(xa, xb) >= x0) & (np.minimum(xa, xb) < x1)
            assert np.all(low[mid & over] - top > 0.01), f"{name}: swing sole within 1 cm of a stair"
        assert gap[mid, j].min() > 0.01, f"{name}: mid-swing clearance {gap[mid, j].min() * 100:.2f} cm"
        swinging = ~motion.stance[:, j]
        assert gap[swinging, j].min() > -1e-9


def test_walk_metrics_agree_with_the_independent_check(run):
    _name, plan, motion, soles = run
    met = walk_metrics(motion)
    assert met.max_penetration_m < 1e-3 and met.max_stance_slip_m < 1e-3
    gap = soles[..., 2] - _terrain_z(plan.terrain.blocks, soles[..., 0])
    ph = motion.swing_phase
    mid = np.isfinite(ph) & (ph >= 0.25) & (ph <= 0.75)
    # the metric checks the whole sole segment, the samples here 11 points: it can only be lower
    assert met.min_swing_clearance_m <= gap[mid].min() + 1e-9
    assert met.min_swing_clearance_m > gap[mid].min() - 0.02


def test_joint_angles_and_velocities_are_continuous_at_every_gait_change():
    """At every segment boundary of B's demo (gait changes, each footfall, each jump phase) the
    joint angles and the pelvis agree from both sides, and so do their one-sided derivatives."""
    for plan in (demo(), jump(params=GaitParams(somersault=False))):
        h = 1e-6
        for tb in plan.starts[1:-1]:
            m = plan.evaluate(np.array([tb - 2 * h, tb - h, tb, tb + h, tb + 2 * h]))
            a = np.column_stack([m.angles, m.pelvis_pos])
            assert np.max(np.abs(a[1] - a[3])) < 1e-4, f"jump at t = {tb:.4f} s"
            v_left, v_right = (a[2] - a[0]) / (2 * h), (a[4] - a[2]) / (2 * h)
            assert np.max(np.abs(v_left - v_right)) < 1e-2, f"velocity jump at t = {tb:.4f} s"


def test_no_large_joint_step_between_frames():
    m = demo().sample(200.0)
    assert np.max(np.abs(np.diff(m.angles, axis=0))) < 0.06  # < 12 rad/s at 200 Hz
    assert walk_metrics(m).max_joint_step_rad < 0.06


def test_level_double_support_and_mid_stance_follow_eq_4_20_and_4_22():
    """At each double support of steady walking both legs are B's bar at +-20 deg: hip-ankle
    distance P1 cos 20 deg (eq. 4.20); at mid-stance the pelvis is 2 x 0.08 l1 higher (eq. 4.22)."""
    plan = step_forward(steps=6)
    d = plan.dims
    P1, a = d.leg, math.radians(20)
    starts = plan.starts
    ds = starts[2:6]  # double supports between regular steps
    mid = 0.5 * (starts[2:5] + starts[3:6])  # steps with regular steps on both sides
    m = plan.evaluate(np.concatenate([ds, mid]))
    lm = m.landmarks()
    k = ds.size
    for side in ("left", "right"):
        dist = np.linalg.norm(lm[f"{side}_hip"][:k] - lm[f"{side}_ankle"][:k], axis=1)
        np.testing.assert_allclose(dist, P1 * math.cos(a), atol=1e-9)
        ang = np.degrees(
            np.arctan2(
                np.abs(lm[f"{side}_hip"][:k, 0] - lm[f"{side}_ankle"][:k, 0]),
                lm[f"{side}_hip"][:k, 2] - lm[f"{side}_ankle"][:k, 2],
            )
        )
        np.testing.assert_allclose(ang, 20.0, atol=1e-7)
    z_ds, z_mid = m.pelvis_pos[:k, 2], m.pelvis_pos[k:, 2]
    np.testing.assert_allclose(z_ds, d.ankle_height + P1 * math.cos(a) ** 2, atol=1e-9)
    np.testing.assert_allclose(z_mid - z_ds[:3], 2 * 0.08 * d.thigh, atol=1e-9)
    ends = plan.evaluate(np.array([0.0, plan.duration])).landmarks()
    for side in ("left", "right"):  # six footfalls of L = P1 sin(2 alpha)
        assert ends[f"{side}_heel"][1, 0] - ends[f"{side}_heel"][0, 0] == pytest.approx(
            6 * P1 * math.sin(2 * a)
        )


def test_default_stairs_are_bediz_minus_10_to_plus_30_deg():
    """Default rise = eq. 4.23 at 30 deg; at each double support on the stairs the trailing leg
    is at 10 deg and the leading one at 30 deg from the vertical."""
    plan = step_upward(steps=5)
    d = plan.dims
    rise, _run, a_up = stair_geometry(d, plan.params)
    assert rise == pytest.approx(d.leg * (1 - math.cos(math.radians(30))), abs=1e-12)
    assert math.degrees(a_up) == pytest.approx(30.0, abs=1e-9)
    m = plan.evaluate(plan.starts[2:5])
    lm = m.landmarks()
    for t in range(3):
        angs = sorted(
            abs(
                math.degrees(
                    math.atan2(
                        lm[f"{s}_hip"][t, 0] - lm[f"{s}_ankle"][t, 0],
                        lm[f"{s}_hip"][t, 2] - lm[f"{s}_ankle"][t, 2],
                    )
                )
            )
            for s in ("left", "right")
        )
        assert angs == pytest.approx([10.0, 30.0], abs=1e-7)
    assert plan.climbed == pytest.approx(5 * rise)


def test_bad_parameters_say_what_is_valid():
    with pytest.raises(ScenarioError, match="speed must be a positive number"):
        step_forward(speed=0.0)
    with pytest.raises(ScenarioError, match="steps must be an integer >= 1"):
        step_forward(steps=0)
    with pytest.raises(ScenarioError, match="stair run must be at least"):
        step_upward(run=0.1)
    with pytest.raises(ScenarioError, match="use a shorter run or rise"):
        step_upward(rise=0.35, run=0.9)
    with pytest.raises(ScenarioError, match="alpha must be in"):
        GaitParams(alpha=60)
