"""Capture-point math against the LIPM's closed form, an ODE integration and geometry done
another way (scipy's hull, brute-force distances)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.spatial import ConvexHull

from biped.control import capture as cp
from biped.errors import ScenarioError

W = cp.omega0(0.95)


def _integrate(x0, v0, p, omega, t):
    """x'' = omega^2 (x - p) integrated numerically (RK45, tight tolerances): independent of the
    closed form."""
    sol = solve_ivp(
        lambda _, y: [y[2], y[3], omega**2 * (y[0] - p[0]), omega**2 * (y[1] - p[1])],
        (0.0, t),
        [*x0, *v0],
        rtol=1e-11,
        atol=1e-12,
    )
    return sol.y[:2, -1], sol.y[2:, -1]


def test_omega0_and_bad_height():
    assert cp.omega0(9.81 / 4.0, 9.81) == pytest.approx(2.0)
    with pytest.raises(ScenarioError, match="COM height"):
        cp.omega0(0.0)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-0.3, 0.3), min_size=6, max_size=6), st.floats(0.05, 0.8))
def test_lipm_closed_form_matches_integration(v, t):
    x0, v0, p = np.array(v[:2]), np.array(v[2:4]) * 3, np.array(v[4:])
    x, xd = cp.lipm_state(x0, v0, p, W, t)
    xn, xdn = _integrate(x0, v0, p, W, t)
    np.testing.assert_allclose(x, xn, atol=1e-8)
    np.testing.assert_allclose(xd, xdn, atol=1e-8)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-0.3, 0.3), min_size=6, max_size=6), st.floats(0.0, 0.8))
def test_predicted_capture_point_is_that_of_the_integrated_state(v, t):
    """xi(T) = p + (xi0 - p) e^{wT} equals x(T) + v(T)/w of the integrated pendulum."""
    x0, v0, p = np.array(v[:2]), np.array(v[2:4]) * 3, np.array(v[4:])
    xi0 = cp.capture_point(x0, v0, W)
    if t > 0:
        x, xd = _integrate(x0, v0, p, W, t)
    else:
        x, xd = x0, v0
    np.testing.assert_allclose(cp.predict_capture_point(xi0, p, W, t), x + xd / W, atol=1e-7)


def test_cop_at_capture_point_brings_pendulum_to_rest():
    x0, v0 = np.array([0.0, 0.0]), np.array([0.5, -0.2])
    xi = cp.capture_point(x0, v0, W)
    x, xd = _integrate(x0, v0, xi, W, 6.0)
    np.testing.assert_allclose(x, xi, atol=1e-4)
    np.testing.assert_allclose(xd, 0.0, atol=1e-3)
    # a CoP 1 cm short of it does not: the pendulum runs away
    x, xd = _integrate(x0, v0, xi - 0.01 * v0 / np.linalg.norm(v0), W, 6.0)
    assert np.linalg.norm(xd) > 1.0


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=16, max_size=16))
def test_hull_and_signed_distance_against_scipy(v):
    pts = np.array(v).reshape(8, 2)
    try:
        ref = ConvexHull(pts)
    except Exception:  # noqa: BLE001 - degenerate point sets
        return
    if ref.volume < 1e-3:
        return
    hull = cp.convex_hull(pts)
    assert len(hull) <= len(ref.vertices)  # collinear points dropped
    # CCW: positive shoelace area equal to scipy's
    area = 0.5 * np.sum(hull[:, 0] * np.roll(hull[:, 1], -1) - np.roll(hull[:, 0], -1) * hull[:, 1])
    assert area == pytest.approx(ref.volume, rel=1e-9)
    # signed distance: inside points have -d = distance to the nearest edge (brute force)
    for q in np.random.default_rng(0).uniform(-1.2, 1.2, (20, 2)):
        inside = np.all(ref.equations[:, :2] @ q + ref.equations[:, 2] <= 0)
        d = cp.signed_distance(hull, q)
        assert (d <= 1e-12) == inside
        if inside:
            assert -d == pytest.approx(np.min(-(ref.equations[:, :2] @ q + ref.equations[:, 2])))


def test_shrink_polygon_moves_each_edge_by_margin():
    sq = cp.support_polygon([((0.0, 0.0), 0.0, 0.1, 0.05)])
    small = cp.shrink_polygon(sq, 0.01)
    np.testing.assert_allclose(np.sort(np.abs(small), axis=0)[-1], [0.09, 0.04])
    two = cp.support_polygon([((0.0, -0.1), 0.0, 0.12, 0.046), ((0.05, 0.1), 0.2, 0.12, 0.046)])
    inner = cp.shrink_polygon(two, 0.02)
    for v in inner:  # every vertex of the shrunk polygon is 2 cm inside (on two edge lines)
        assert cp.signed_distance(two, v) == pytest.approx(-0.02)


def test_support_polygon_rotated_sole():
    poly = cp.support_polygon([((1.0, 2.0), math.pi / 2, 0.1, 0.05)])
    np.testing.assert_allclose(poly.min(axis=0), [0.95, 1.9])
    np.testing.assert_allclose(poly.max(axis=0), [1.05, 2.1])


def test_trigger_hysteresis():
    poly = cp.support_polygon([((0.0, 0.0), 0.0, 0.1, 0.1)])
    trig = cp.CaptureTrigger(margin_m=0.01, rearm_margin_m=0.03, hold=2)
    assert not trig.update(poly, (0.05, 0.0))  # well inside
    assert not trig.update(poly, (0.095, 0.0))  # inside the shrunk polygon's margin: count 1
    assert trig.update(poly, (0.095, 0.0))  # held twice: fire
    assert not trig.update(poly, (0.2, 0.0))  # disarmed
    assert not trig.update(poly, (0.08, 0.0))  # back inside but not by 3 cm: still disarmed
    assert not trig.armed
    trig.update(poly, (0.0, 0.0))
    assert trig.armed
    # a single excursion shorter than `hold` never fires
    assert not trig.update(poly, (0.2, 0.0))
    assert not trig.update(poly, (0.0, 0.0))
    assert not trig.update(poly, (0.2, 0.0))


def test_trigger_lateral_margin_fires_sideways_only():
    """Two 0.24 x 0.092 m soles 0.168 m apart (y extent +-0.13 m): with lateral_margin 3 cm, xi
    2 cm inside the side fires, 2 cm inside the front edge does not (the x margin stays 0); the
    excess of a point is its distance to the polygon's y-extent (here against the plain bounds)."""
    poly = cp.support_polygon([((0.0, -0.084), 0.0, 0.12, 0.046), ((0.0, 0.084), 0.0, 0.12, 0.046)])
    ymax = poly[:, 1].max()
    assert ymax == pytest.approx(0.13)
    for y in (0.11, -0.11, 0.3):
        assert cp.excess(poly, (0.0, y))[1] == pytest.approx(abs(y) - 0.13)
    side = cp.CaptureTrigger(margin_m=0.0, rearm_margin_m=0.02, hold=2, lateral_margin_m=0.03)
    front = cp.CaptureTrigger(margin_m=0.0, rearm_margin_m=0.02, hold=2, lateral_margin_m=0.03)
    assert not side.update(poly, (0.0, 0.11)) and side.update(poly, (0.0, 0.11))
    assert not front.update(poly, (-0.10, 0.0)) and not front.update(poly, (-0.10, 0.0))
    # re-arms only 2 cm inside the shrunk side: y < 0.13 - 0.03 - 0.02
    assert not side.update(poly, (0.0, 0.09)) and not side.armed
    side.update(poly, (0.0, 0.07))
    assert side.armed
    with pytest.raises(ScenarioError, match="lateral_margin_m"):
        cp.CaptureTrigger(margin_m=0.02, lateral_margin_m=0.01)


@pytest.mark.parametrize("lim", [cp.StepLimits(), cp.StepLimits(max_step=0.6, max_width=0.6)])
@settings(max_examples=60, deadline=None)
@given(x=st.floats(-1.5, 1.5), y=st.floats(-1.5, 1.5), side=st.sampled_from([-1.0, 1.0]))
def test_clamped_step_respects_reach_and_no_crossover(x, y, side, lim):
    """Default limits and the sideways ones (SteppingConfig.lateral_limits)."""
    stance = np.array([0.1, -0.2])
    p = cp.clamp_step(stance + [x, y], stance, side, lim)
    rel = p - stance
    assert np.linalg.norm(rel) <= lim.max_step + 1e-9
    assert lim.min_width - 1e-12 <= side * rel[1] <= lim.max_width + 1e-12
    assert rel[0] <= lim.max_back + 1e-12
    # a target already allowed is returned unchanged
    ok = stance + np.array([-0.2, side * 0.2])
    np.testing.assert_allclose(cp.clamp_step(ok, stance, side, lim), ok)


def test_step_target_lands_capture_point_inside_new_sole():
    """With the foot placed by step_target and the CoP moved there at touchdown, the integrated
    pendulum's capture point lies offset_m behind the new sole centre, inside it."""
    x0, v0 = np.array([0.0, 0.0]), np.array([-0.6, 0.05])
    p = np.array([0.0, 0.1])  # stance (right) sole centre
    T = 0.3
    xi0 = cp.capture_point(x0, v0, W)
    wide = cp.StepLimits(max_step=5.0, min_width=0.0, max_width=5.0, max_back=5.0)
    tgt = cp.step_target(xi0, p, W, T, p, side=-1.0, offset_m=0.03, limits=wide)
    x, xd = _integrate(x0, v0, p, W, T)
    xi_T = x + xd / W
    assert np.linalg.norm(tgt - xi_T) == pytest.approx(0.03, abs=1e-6)
    assert np.dot(tgt - xi_T, xi_T - p) > 0  # beyond it, away from the stance foot


def test_step_target_side_margin_puts_the_capture_point_inside_the_sole_across():
    """``side_margin_m``: a backward step over a stance foot on the left (the swing foot the right,
    side +1) whose predicted capture point lies 1 cm right of the stance sole: without the margin
    the sole centre lands about on xi_td across (the 3 cm offset runs along x); with 4 cm it lies
    4 cm right of the integrated pendulum's capture point at touchdown; a target already that far
    out is not moved, and the limits still apply (the 0.22 m width)."""
    x0, v0 = np.array([0.0, -0.08]), np.array([0.9, 0.15])
    p = np.array([0.0, -0.09])  # stance (left) sole centre, the CoP held there
    T = 0.25
    xi0 = cp.capture_point(x0, v0, W)
    wide = cp.StepLimits(max_step=5.0, min_width=0.0, max_width=5.0, max_back=5.0)
    x, xd = _integrate(x0, v0, p, W, T)
    xi_T = x + xd / W
    plain = cp.step_target(xi0, p, W, T, p, side=1.0, offset_m=0.03, limits=wide)
    assert 0.0 < plain[1] - xi_T[1] < 0.01
    tgt = cp.step_target(xi0, p, W, T, p, side=1.0, offset_m=0.03, limits=wide, side_margin_m=0.04)
    assert tgt[1] - xi_T[1] == pytest.approx(0.04, abs=1e-6)
    assert tgt[0] == pytest.approx(plain[0], abs=1e-12)
    half = 0.5 * (plain[1] - xi_T[1])
    far = cp.step_target(xi0, p, W, T, p, side=1.0, offset_m=0.03, limits=wide, side_margin_m=half)
    np.testing.assert_allclose(far, plain)
    capped = cp.step_target(xi0, p, W, T, p, side=1.0, offset_m=0.03, side_margin_m=0.5)
    assert capped[1] - p[1] == pytest.approx(cp.StepLimits().max_width)
