"""B's 3-link planar leg (eq. 4.12-4.19) and stepping geometry (eq. 4.20, 4.21, 4.23).

Oracles: the closed-form forward kinematics eq. 4.10-4.11, MuJoCo's kinematics of the figure's
MJCF (the ankle body where MuJoCo puts it), Thales' circle, and B's printed stair rise 0.267949.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from biped.errors import ReachError, ScenarioError
from biped.kinematic import (
    FigureDims,
    bar_foot,
    figure_mjcf,
    leg_fk,
    leg_ik,
    stair_angle,
    stair_elevation,
)


def _reachable_targets(rng, n, l1, l2):
    """Random ankle targets spread over the whole reachable annulus (and all directions)."""
    r = rng.uniform(abs(l1 - l2) + 1e-6, l1 + l2 - 1e-6, n)
    a = rng.uniform(-math.pi, math.pi, n)
    return r * np.cos(a), r * np.sin(a), rng.uniform(-math.pi, math.pi, n)


@pytest.mark.parametrize("knee", ["human", "reverse"])
@pytest.mark.parametrize("l1, l2", [(1.0, 1.0), (0.4073, 0.4187), (0.5, 0.2)])
def test_fk_of_ik_returns_the_target_to_1e_9(knee, l1, l2):
    """eq. 4.10-4.11 and 4.8 applied to the IK solution give back every random reachable target."""
    rng = np.random.default_rng(7)
    x, y, phi = _reachable_targets(rng, 5000, l1, l2)
    sol = leg_ik(x, y, phi, l1, l2, knee=knee)
    # eq. 4.10, 4.11 written out here, not through leg_fk
    t1, t12 = sol.theta1, sol.theta1 + sol.theta2
    xf = l1 * np.cos(t1) + l2 * np.cos(t12)
    yf = l1 * np.sin(t1) + l2 * np.sin(t12)
    ph = t12 + sol.theta3
    assert np.max(np.hypot(xf - x, yf - y)) < 1e-9
    assert np.max(np.abs(np.angle(np.exp(1j * (ph - phi))))) < 1e-9
    # and the package's leg_fk agrees
    xk, yk, _pk = leg_fk(sol.theta1, sol.theta2, sol.theta3, l1, l2)
    assert np.max(np.hypot(xk - x, yk - y)) < 1e-9


def test_knee_branch_is_explicit_human_knees_point_forward():
    """ "human": theta2 <= 0 and the knee lies ahead of the hip-ankle line; "reverse" the mirror
    image; both reach the same ankle."""
    rng = np.random.default_rng(3)
    l1, l2 = 0.41, 0.42
    x = rng.uniform(0.5, 0.8, 200)  # hanging legs
    y = rng.uniform(-0.3, 0.3, 200)
    ok = np.hypot(x, y) < l1 + l2
    x, y = x[ok], y[ok]
    for knee, sign in (("human", 1.0), ("reverse", -1.0)):
        s = leg_ik(x, y, 0.0, l1, l2, knee=knee)
        assert np.all(s.theta2 <= 0) if knee == "human" else np.all(s.theta2 >= 0)
        kx, ky = l1 * np.cos(s.theta1), l1 * np.sin(s.theta1)  # knee in the hip frame
        # signed side of the knee w.r.t. the hip->ankle line; forward (y) side is positive
        side = (x * ky - y * kx) / np.hypot(x, y)
        assert np.all(sign * side > 0)


def test_ik_angles_drive_mujoco_figure_ankle_onto_the_target():
    """MuJoCo's kinematics of the figure MJCF, driven by the IK angles of the left leg, puts the
    ankle (foot body origin) at the target: leg frame x down, y forward, hip at (0, w, 0)."""
    dims = FigureDims.from_anthropometry()
    m = mujoco.MjModel.from_xml_string(figure_mjcf(dims))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(11)
    x, y, phi = _reachable_targets(rng, 50, dims.thigh, dims.shank)
    sol = leg_ik(x, y, phi, dims.thigh, dims.shank)
    d.qpos[3] = 1.0  # pelvis at the origin, upright
    foot = m.body("left_foot").id
    for k in range(x.size):
        for name, val in (
            ("left_hip_flexion", sol.theta1[k]),
            ("left_knee", sol.theta2[k]),
            ("left_ankle_dorsiflexion", sol.theta3[k]),
        ):
            d.qpos[m.joint(name).qposadr[0]] = val
        mujoco.mj_kinematics(m, d)
        np.testing.assert_allclose(d.xpos[foot], [y[k], dims.hip_half_width, -x[k]], atol=1e-12)
        # foot pitch phi about -y: the foot's x axis is (cos phi, 0, sin phi) in the world
        R = d.xmat[foot].reshape(3, 3)
        np.testing.assert_allclose(R[:, 0], [math.cos(phi[k]), 0.0, math.sin(phi[k])], atol=1e-12)


def test_unreachable_target_names_distance_and_reach():
    with pytest.raises(ReachError, match=r"2\.1 m from the hip.*\[0, 2\] m"):
        leg_ik(2.1, 0.0, 0.0, 1.0, 1.0)
    with pytest.raises(ReachError, match=r"target index \(2,\).*reaches distances in \[0\.2, 1\.2\]"):
        leg_ik([1.0, 0.5, 0.1], [0.0, 0.0, 0.0], 0.0, 0.7, 0.5)
    with pytest.raises(ReachError, match="NaN"):
        leg_ik(float("nan"), 0.0, 0.0, 1.0, 1.0)
    with pytest.raises(ScenarioError, match="valid branches: 'human', 'reverse'"):
        leg_ik(1.0, 0.0, 0.0, 1.0, 1.0, knee="bird")
    with pytest.raises(ScenarioError, match="positive"):
        leg_ik(1.0, 0.0, 0.0, -1.0, 1.0)


def test_boundary_of_the_reach_is_reachable():
    """A straight leg (distance l1 + l2, rounded up by 1e-13) solves with theta2 = 0."""
    s = leg_ik(2.0 + 1e-13, 0.0, 0.0, 1.0, 1.0)
    assert abs(float(s.theta2)) < 1e-6 and abs(float(s.theta1)) < 1e-6


def test_stair_rise_of_eq_4_23_is_bediz_0_267949():
    """B's stairs rise 0.267949 units with l1 = l2 = 1: eq. 4.23 at 30 deg, 2 - sqrt(3)."""
    assert float(stair_elevation(math.radians(30), 1.0, 1.0)) == pytest.approx(0.267949, abs=1e-6)
    assert float(stair_elevation(math.radians(30), 1.0, 1.0)) == pytest.approx(2 - math.sqrt(3), abs=1e-15)
    assert math.degrees(float(stair_angle(2 - math.sqrt(3), 1.0, 1.0))) == pytest.approx(30.0, abs=1e-9)
    with pytest.raises(ScenarioError, match=r"\[0, l1 \+ l2\]"):
        stair_angle(3.0, 1.0, 1.0)


def test_bar_foot_lies_on_thales_circle_and_swing_leg_is_0_95_of_it():
    """eq. 4.20: the ankle at P1 cos(alpha) along the bar lies on the circle of diameter P1 through
    the hip; eq. 4.21 shortens the bar to 0.95 of that."""
    P1 = 2.0
    alpha = np.radians(np.linspace(-20, 20, 41))
    x, y = bar_foot(alpha, P1)
    np.testing.assert_allclose(np.hypot(x - P1 / 2, y), P1 / 2, atol=1e-15)
    np.testing.assert_allclose(np.arctan2(y, x), alpha, atol=1e-15)
    x3, y3 = bar_foot(alpha, P1, 0.95)
    np.testing.assert_allclose(np.hypot(x3, y3), 0.95 * np.hypot(x, y), atol=1e-15)
