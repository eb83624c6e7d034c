"""B's single-link pendulum: every hand-written form against a sympy.physics.mechanics derivation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from biped.errors import ScenarioError, StateError
from biped.planar import integrators, symbolic
from biped.planar import pendulum as pd

FORMS = ["newton-euler", "newton-euler-2.10", "newton-euler-5x5", "lagrange"]


@pytest.fixture(scope="module")
def derived():
    return symbolic.pendulum().numeric()


def _random_cases(n=12, seed=1):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        p = pd.PendulumParams(
            m=rng.uniform(1, 200),
            I=rng.uniform(0, 1000),
            l=rng.uniform(0.2, 5),
            g=rng.uniform(1, 40),
        )
        yield p, rng.uniform(-3, 3), rng.uniform(-5, 5), rng.uniform(-5e3, 5e3)


@pytest.mark.parametrize("method", FORMS)
def test_forms_match_symbolic_derivation(method, derived):
    fn = pd.PENDULUM_METHODS[method]
    for p, th, thd, M in _random_cases():
        acc, forces = derived((p.m, p.I, p.l, p.g), (th,), (thd,), (M,))
        got = fn(p, th, thd, M)
        assert got.theta_ddot == pytest.approx(acc[0], rel=1e-9, abs=1e-9)
        if method.startswith("newton-euler"):
            scale = p.m * (p.g + p.l * thd**2) + abs(M) / p.l
            assert got.fx == pytest.approx(forces["fx"], abs=1e-9 * scale)
            assert got.fy == pytest.approx(forces["fy"], abs=1e-9 * scale)


def test_linear_form_is_tangent_of_nonlinear():
    p = pd.PendulumParams()
    for th in (1e-4, -2e-4):
        lin = pd.lagrange_linear(p, th, 0.0, 10.0).theta_ddot
        non = pd.lagrange(p, th, 0.0, 10.0).theta_ddot
        assert lin == pytest.approx(non, rel=1e-7)


def test_energy_is_conserved_without_torque():
    """Closed-form invariant: with M = 0 the Lagrangian form keeps T + V (RK4, small step)."""
    p = pd.PendulumParams()
    x0 = np.array([0.3, 0.0])
    e0 = pd.energy(p, *x0)

    def f(t, y):
        return np.array([y[1], pd.newton_euler_pitch(p, y[0], y[1], 0.0).theta_ddot])

    x = integrators.integrate(f, x0, 1.0, 1e-3, "rk4")[-1]
    assert pd.energy(p, *x) == pytest.approx(e0, rel=1e-9)
    assert x[0] > 0.3  # it falls (upright is unstable)


def test_static_reaction_carries_the_weight():
    """At rest upright with no torque, the ground pushes up with m g and nothing sideways."""
    p = pd.PendulumParams()
    for fn in (pd.newton_euler_5x5, pd.newton_euler_3x3, pd.newton_euler_pitch):
        r = fn(p, 0.0, 0.0, 0.0)
        assert r.theta_ddot == pytest.approx(0.0, abs=1e-12)
        assert r.fx == pytest.approx(0.0, abs=1e-9)
        assert r.fy == pytest.approx(p.m * p.g, rel=1e-12)


def test_bad_input_errors():
    p = pd.PendulumParams()
    with pytest.raises(StateError, match="theta must be finite"):
        pd.lagrange(p, math.nan, 0.0, 0.0)
    with pytest.raises(StateError, match="torque"):
        pd.newton_euler_pitch(p, 0.1, 0.0, math.inf)
    with pytest.raises(ScenarioError, match="parameter l must be finite and > 0"):
        pd.PendulumParams(l=0.0)
