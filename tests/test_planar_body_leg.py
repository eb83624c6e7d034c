"""B's body on a massless leg: hand-written forms against a sympy.physics.mechanics derivation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from biped.errors import ScenarioError, SingularityError, StateError
from biped.planar import body_leg as bl
from biped.planar import integrators, symbolic


@pytest.fixture(scope="module")
def derived():
    return symbolic.body_leg().numeric()


def _cases(n=15, seed=2):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        p = bl.BodyLegParams(
            m=rng.uniform(10, 200), I=rng.uniform(1, 300), r=rng.uniform(0.5, 4),
            l=rng.uniform(0.1, 2), g=rng.uniform(1, 40),
        )  # fmt: skip
        x = rng.uniform([-1.5, -4, -1.5, -4], [1.5, 4, 1.5, 4])
        u = rng.uniform(-2e4, 2e4, size=2)
        yield p, x, u


@pytest.mark.parametrize("method", ["lagrange", "newton-euler"])
def test_nonlinear_forms_match_derivation(method, derived):
    """Eq. 3.18/3.24 and eq. 3.42 (derived right-hand side) at random states and torques."""
    fn = bl.BODY_LEG_METHODS[method]
    for p, x, u in _cases():
        acc, forces = derived((p.m, p.I, p.r, p.l, p.g), x[0::2], x[1::2], u)
        got = fn(p, x, u)
        np.testing.assert_allclose(got[:2], acc, rtol=1e-9, atol=1e-9)
        if method == "newton-euler":
            scale = p.m * p.g + abs(u).sum() / p.r + p.m * (p.r + p.l) * (x[1::2] ** 2).sum()
            assert got.F == pytest.approx(forces["F"], abs=1e-9 * scale)
            assert got.F_r == pytest.approx(forces["F_r"], abs=1e-9 * scale)


def test_leg_reaction_is_eq_3_28(derived):
    """The derived perpendicular force equals (M_1 - M_2) / r for any state (massless leg)."""
    for p, x, u in _cases(5, seed=3):
        _, forces = derived((p.m, p.I, p.r, p.l, p.g), x[0::2], x[1::2], u)
        assert forces["F_r"] == pytest.approx(bl.leg_reaction(p, *u), rel=1e-8, abs=1e-8)


def test_linear_form_is_the_derivations_tangent():
    """Eq. 3.51/3.54 equal the symbolic Jacobian of the derived model applied to (x, u)."""
    A, B, params = symbolic.body_leg_linearization()
    for p, x, u in _cases(5, seed=4):
        sub = dict(zip(params, (p.m, p.I, p.r, p.l, p.g), strict=True))
        An = np.array(A.subs(sub).evalf(), dtype=float)
        Bn = np.array(B.subs(sub).evalf(), dtype=float)
        xdot = An @ x + Bn @ u
        got = bl.lagrange_linear(p, x, u)
        np.testing.assert_allclose([got.theta1_ddot, got.theta2_ddot], xdot[1::2], rtol=1e-10)


def test_printed_newton_euler_row_differs_from_derivation(derived):
    """B's printed first row of eq. 3.42 is right only when cos(t2 - t1) = 1 or M_2 = 0."""
    p = bl.BodyLegParams()
    u = np.array([-3000.0, 5000.0])
    aligned = np.array([0.4, 0.3, 0.4, -0.2])
    np.testing.assert_allclose(bl.newton_euler_printed(p, aligned, u)[:3], bl.newton_euler(p, aligned, u)[:3])
    bent = np.array([0.5, 0.0, 1.0, 0.0])
    acc, _ = derived((p.m, p.I, p.r, p.l, p.g), bent[0::2], bent[1::2], u)
    assert abs(bl.newton_euler_printed(p, bent, u).theta2_ddot - acc[1]) > 1.0
    np.testing.assert_allclose(bl.newton_euler(p, bent, u)[:2], acc, rtol=1e-10)


def test_energy_is_conserved_without_torque():
    """T + V of eq. 3.10/3.11 is constant with M_1 = M_2 = 0 (RK4, small step)."""
    p = bl.BodyLegParams()
    x0 = np.array([0.05, 0.0, -0.1, 0.0])
    e0 = bl.energy(p, x0)
    u = np.zeros(2)

    def f(t, y):
        a = bl.newton_euler(p, y, u)
        return np.array([y[1], a[0], y[3], a[1]])

    x = integrators.integrate(f, x0, 0.5, 5e-4, "rk4")[-1]
    assert bl.energy(p, x) == pytest.approx(e0, rel=1e-9)


def test_singular_configuration_raises():
    """I = 0 with leg and body aligned: the 3x3 of eq. 3.42 and the 2x2 mass matrix are singular."""
    p = bl.BodyLegParams(I=0.0)
    x = np.array([0.2, 0.0, 0.2, 0.0])
    with pytest.raises(SingularityError, match="eq. 3.42"):
        bl.newton_euler(p, x, [0.0, 0.0])
    with pytest.raises(SingularityError, match="theta_1 != theta_2"):
        bl.lagrange(p, x, [0.0, 0.0])
    with pytest.raises(SingularityError, match="divide by the body inertia"):
        bl.lagrange_linear(p, x, [0.0, 0.0])
    # away from alignment the point-mass body is fine, and the two forms agree
    y = np.array([0.2, 0.1, 0.5, -0.3])
    np.testing.assert_allclose(bl.newton_euler(p, y, [10.0, 3.0])[:2], bl.lagrange(p, y, [10.0, 3.0])[:2])


def test_bad_state_errors():
    p = bl.BodyLegParams()
    with pytest.raises(StateError, match="must be finite"):
        bl.lagrange(p, [0.0, math.nan, 0.0, 0.0], [0.0, 0.0])
    with pytest.raises(StateError, match=r"shape \(4,\)"):
        bl.newton_euler(p, [0.0, 0.0, 0.0], [0.0, 0.0])
    with pytest.raises(ScenarioError, match="parameter r"):
        bl.BodyLegParams(r=-1.0)
