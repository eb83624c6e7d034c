"""B's closed-loop runs (Figs. 25, 30, 31, 36, 37) against closed forms and static balance."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize

from biped.errors import ScenarioError, StateError
from biped.planar import analysis as an
from biped.planar import body_leg as bl
from biped.planar import pendulum as pd
from biped.planar import runs


def test_pendulum_fig_25_run_settles_upright():
    tr = runs.simulate_pendulum()  # B's defaults: newton-euler (eq. 4.30), Euler, dt 0.02, 20 s
    assert tr.states.shape == (1001, 2) and tr.time[-1] == pytest.approx(20.0)
    assert abs(tr.states[-1, 0]) < 5e-3
    # the ground carries the weight once it has settled
    assert tr.forces["fy"][-1] == pytest.approx(tr.params.m * tr.params.g, rel=1e-3)


def test_pendulum_linear_run_matches_expm():
    p = pd.PendulumParams()
    lin = an.analyze_pendulum(p, runs.PENDULUM_GAINS)
    tr = runs.simulate_pendulum(p, "lagrange-linear", x0=(0.2, 0.0), dt=0.005, duration=2.0,
                                integrator="rk4", hold=False)  # fmt: skip
    expected = scipy.linalg.expm((lin.A + lin.B @ lin.K) * 2.0) @ np.array([0.2, 0.0])
    np.testing.assert_allclose(tr.states[-1], expected, atol=1e-10)


def test_body_leg_forms_b_claims_identical():
    """Nonlinear Lagrangian and (derived) Newton-Euler runs agree to rounding; the linearized
    run that B's Lisp calls "Lagrangian" does not (0.1 rad and more from x0 = (0.5, 0, 1, 0))."""
    lag = runs.simulate_body_leg(method="lagrange")
    ne = runs.simulate_body_leg(method="newton-euler")
    lin = runs.simulate_body_leg(method="lagrange-linear")
    assert np.abs(lag.states - ne.states).max() < 1e-10
    assert np.abs(lag.states[:, 2] - lin.states[:, 2]).max() > 0.1
    for tr in (lag, ne, lin):  # all settle
        assert np.abs(tr.states[-1]).max() < 0.02
    assert set(ne.forces) == {"F", "F_r"} and not lag.forces


def test_b_printed_newton_euler_diverges_from_b_initial_state():
    """Measured: eq. 3.42 as printed (and as B's Lisp integrates it) does not come back upright
    from x0 = (0.5, 0, 1, 0) with B's gains, neither with Heun nor with B's frozen Heun."""
    for integrator in ("heun", "heun-frozen"):
        try:
            tr = runs.simulate_body_leg(method="newton-euler-printed", integrator=integrator)
        except StateError as exc:
            assert "diverged" in str(exc)
        else:
            assert np.abs(tr.states[:, 2]).max() > 3.0


def test_set_points_reach_static_balance():
    """With set points, the nonlinear loop settles where gravity and the feedback torques balance
    (eq. 3.18/3.24 with zero rates), found here by a root finder."""
    p = bl.BodyLegParams()
    g = runs.BODY_LEG_GAINS
    alpha = (0.05, -0.1)
    tr = runs.simulate_body_leg(p, "lagrange", g, x0=(0.0, 0.0, 0.0, 0.0), duration=15.0,
                                alpha=alpha, integrator="rk4")  # fmt: skip

    def balance(t):
        M1 = -g[0] * (t[0] - alpha[0])
        M2 = -g[2] * (t[1] - alpha[1])
        return [
            -p.m * p.g * p.r * math.sin(t[0]) - (M1 - M2),
            -p.m * p.g * p.l * math.sin(t[1]) - M2,
        ]

    eq = scipy.optimize.fsolve(balance, alpha, xtol=1e-13)
    np.testing.assert_allclose(tr.states[-1, 0::2], eq, atol=1e-6)
    np.testing.assert_allclose(tr.states[-1, 1::2], 0.0, atol=1e-5)


def test_run_errors():
    with pytest.raises(ScenarioError, match="unknown body-leg method 'kane'.*'newton-euler'"):
        runs.simulate_body_leg(method="kane")
    with pytest.raises(ScenarioError, match="unknown integrator"):
        runs.simulate_pendulum(integrator="leapfrog")
    with pytest.raises(StateError, match="must be finite"):
        runs.simulate_body_leg(x0=(0.5, math.nan, 1.0, 0.0))
    with pytest.raises(ScenarioError, match="dt must be finite and > 0"):
        runs.simulate_pendulum(dt=0.0)
    # too weak a stiffness (K < m g l): the pendulum falls over and keeps spinning up; an explicit
    # Euler loop with a huge rate gain blows up, reported with the time
    with pytest.raises(StateError, match="diverged"):
        runs.simulate_pendulum(gains=(1e4, 2e6), dt=0.02, duration=5.0)
