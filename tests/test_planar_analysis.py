"""Linear analysis of B's body-leg model (eq. 3.55-3.80) and gain design, against sympy, finite
differences, Routh-Hurwitz, matrix exponentials and python-control."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from biped.planar import analysis as an
from biped.planar import body_leg as bl
from biped.planar import pendulum as pd
from biped.planar import runs, symbolic

P = bl.BodyLegParams()
B_GAINS = [runs.BODY_LEG_GAINS_EQ_3_83, runs.BODY_LEG_GAINS]


def _numeric(expr_matrix, params, p):
    return np.array(
        expr_matrix.subs(dict(zip(params, (p.m, p.I, p.r, p.l, p.g), strict=True))).evalf(), dtype=float
    )


def test_ab_closed_form_symbolic_and_finite_differences_agree():
    A_s, B_s, params = symbolic.body_leg_linearization()
    for p in (P, bl.BodyLegParams(m=70, I=12, r=2.5, l=0.9, g=9.81)):
        A, B = an.ab_matrices(p)
        np.testing.assert_allclose(A, _numeric(A_s, params, p), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(B, _numeric(B_s, params, p), rtol=1e-12, atol=1e-15)
        for method in ("lagrange", "newton-euler", "lagrange-linear"):
            A_fd, B_fd = an.body_leg_linearized(p, method)
            np.testing.assert_allclose(A_fd, A, rtol=1e-6, atol=1e-6)
            np.testing.assert_allclose(B_fd, B, rtol=1e-6, atol=1e-12)


def test_printed_eq_3_58_3_59_typos_are_exactly_two_signs():
    A, B = an.ab_matrices(P)
    Ap, Bp = an.ab_matrices_as_printed(P)
    assert [tuple(i) for i in np.argwhere(~np.isclose(A, Ap))] == [(1, 2)]
    assert [tuple(i) for i in np.argwhere(~np.isclose(B, Bp))] == [(3, 0)]


def test_eq_3_80_matches_symbolic_determinant():
    poly, ks, params = symbolic.body_leg_characteristic_polynomial()
    rng = np.random.default_rng(5)
    for gains in [*B_GAINS, *rng.uniform(0, 5e4, size=(4, 4))]:
        sub = dict(zip(params, (P.m, P.I, P.r, P.l, P.g), strict=True)) | dict(zip(ks, gains, strict=True))
        expected = [float(c.subs(sub)) for c in poly.all_coeffs()]
        np.testing.assert_allclose(an.characteristic_polynomial(P, gains), expected, rtol=1e-12)
        # and its roots are the closed-loop eigenvalues
        res = an.analyze_body_leg(P, gains)
        np.testing.assert_allclose(
            np.sort_complex(np.roots(res.char_poly)), np.sort_complex(res.eigenvalues), rtol=1e-7
        )


def test_routh_hurwitz_agrees_with_eigenvalues():
    rng = np.random.default_rng(6)
    n_stable = 0
    for _ in range(300):
        gains = rng.uniform(0, [5e4, 5e3, 5e4, 5e3])
        res = an.analyze_body_leg(P, gains)
        if abs(res.margin) < 1e-6:
            continue
        assert an.routh_hurwitz_stable(res.char_poly) == res.stable
        n_stable += res.stable
    assert 10 < n_stable < 290  # both outcomes were exercised


def test_b_gain_sets_are_stable_and_closed_loop_follows_expm():
    """Both of B's gain sets are stable; the linear run (RK4, continuous loop) equals expm."""
    for gains in B_GAINS:
        res = an.analyze_body_leg(P, gains)
        assert res.stable
    res = an.analyze_body_leg(P, runs.BODY_LEG_GAINS)
    tr = runs.simulate_body_leg(P, "lagrange-linear", runs.BODY_LEG_GAINS, duration=1.0,
                                dt=0.001, integrator="rk4", hold=False)  # fmt: skip
    x_exact = scipy.linalg.expm((res.A + res.B @ res.K) * 1.0) @ np.array([0.5, 0, 1.0, 0])
    np.testing.assert_allclose(tr.states[-1], x_exact, atol=1e-9)


def test_pendulum_analysis_quadratic():
    p = pd.PendulumParams()
    res = an.analyze_pendulum(p, runs.PENDULUM_GAINS)
    J = p.I + p.m * p.l**2
    k, kd = runs.PENDULUM_GAINS
    disc = kd**2 - 4 * J * (k - p.m * p.g * p.l)
    roots = (-kd + np.array([1, -1]) * np.sqrt(complex(disc))) / (2 * J)
    np.testing.assert_allclose(np.sort_complex(res.eigenvalues), np.sort_complex(roots))
    assert res.stable
    assert not an.analyze_pendulum(p, (0.9 * p.m * p.g * p.l, 2000)).stable


def test_pole_placement_places_poles():
    A, B = an.ab_matrices(P)
    poles = np.array([-2.0, -3.0, -4.0, -5.0])
    K = an.place_poles_gains(A, B, poles)
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(A + B @ K).real), np.sort(poles), rtol=1e-8)


def test_lqr_solves_riccati_and_matches_cost():
    A, B = an.ab_matrices(P)
    Q, R = an.bryson_weights()
    res = an.lqr(A, B, Q, R)
    P_ = res.P
    residual = A.T @ P_ + P_ @ A - P_ @ B @ np.linalg.solve(R, B.T @ P_) + Q
    assert np.abs(residual).max() < 1e-8 * np.abs(Q).max()
    assert np.all(res.eigenvalues.real < 0)
    # the closed-loop cost of x0 (a Lyapunov equation, independent of the Riccati solver)
    x0 = np.array([0.05, 0.0, 0.1, 0.0])
    Acl = A + B @ res.K
    W = res.K.T @ R @ res.K + Q
    Lyap = scipy.linalg.solve_continuous_lyapunov(Acl.T, -W)
    assert x0 @ Lyap @ x0 == pytest.approx(x0 @ P_ @ x0, rel=1e-8)
    control = pytest.importorskip("control")
    K_ref, _, _ = control.lqr(A, B, Q, R)
    np.testing.assert_allclose(res.K, -np.asarray(K_ref), rtol=1e-6)


def test_best_local_gains_beat_b_and_are_verified():
    res = an.best_local_gains(P, maxiter=60)
    assert np.all(res.gains >= res.bounds[:, 0]) and np.all(res.gains <= res.bounds[:, 1])
    check = an.analyze_body_leg(P, res.gains)
    assert check.margin == pytest.approx(res.margin, rel=1e-9)
    for gains in B_GAINS:
        assert res.margin > an.analyze_body_leg(P, gains).margin + 1.0


def test_stability_map_marks_b_gains_and_the_static_boundary():
    m = an.stability_map(P, np.linspace(0, 5e4, 26), np.array([0.0, 1000.0, 4000.0, 40000.0]))
    # B's gain sets (K1 = 25000 -> column 13) are stable
    assert m.margin[2, 13] > 0 and m.margin[3, 13] > 0
    # constant coefficient (K1 - m g r)(K2 - m g l): K1 < m g r with K2 > m g l is unstable
    mgr = P.m * P.g * P.r
    cols = m.k_theta1 < mgr
    assert np.all(m.margin[2:, cols] < 0)
    # K2 = 0 < m g l with large K1 is unstable too
    assert np.all(m.margin[0, m.k_theta1 > mgr] < 0)
