"""Convergence orders of the integrators on a problem with a closed-form solution."""

from __future__ import annotations

import numpy as np
import pytest

from biped.errors import ScenarioError
from biped.planar import integrators

# damped oscillator x'' + 2 z w x' + w^2 x = 0, x(0) = 1, x'(0) = 0: closed form below
W, Z, T_END = 3.0, 0.2, 2.0


def f(t, x):
    return np.array([x[1], -2 * Z * W * x[1] - W * W * x[0]])


def exact(t):
    wd = W * np.sqrt(1 - Z * Z)
    e = np.exp(-Z * W * t)
    return np.array(
        [
            e * (np.cos(wd * t) + Z * W / wd * np.sin(wd * t)),
            -e * (W * W / wd) * np.sin(wd * t),
        ]
    )


def _error(method, dt):
    xs = integrators.integrate(f, np.array([1.0, 0.0]), T_END, dt, method)
    return np.linalg.norm(xs[-1] - exact(T_END))


@pytest.mark.parametrize("method, order", sorted(integrators.ORDERS.items()))
def test_convergence_order(method, order):
    dts = np.array([0.02, 0.01, 0.005])
    errs = np.array([_error(method, dt) for dt in dts])
    observed = np.polyfit(np.log(dts), np.log(errs), 1)[0]
    assert observed == pytest.approx(order, abs=0.15)


def test_adaptive_is_accurate():
    assert _error("adaptive", 0.1) < 1e-8


def test_heun_frozen_is_first_order():
    """B's Newton-Euler Lisp step reuses the start accelerations: first order only."""
    dts = np.array([0.01, 0.005, 0.0025])
    errs = np.array([_error("heun-frozen", dt) for dt in dts])
    assert np.polyfit(np.log(dts), np.log(errs), 1)[0] == pytest.approx(1.0, abs=0.15)


def test_unknown_integrator():
    with pytest.raises(ScenarioError, match="unknown integrator 'midpoint'.*'rk4'"):
        integrators.get("midpoint")
