"""Linear analysis and gain design for Bediz's planar models (B III-E, IV-C-3a).

Conventions: x_dot = A x + B u (eq. 3.55) with x of eq. 3.1 and u = (M_1, M_2); a full state
feedback is u = K x (eq. 3.56, B's sign: the closed loop is A + B K, eq. 3.57); the local gains of
eq. 3.60 are K = -[[K_theta1, K_theta1dot, 0, 0], [0, 0, K_theta2, K_theta2dot]] with positive
K's. The stability margin is -max Re(eigenvalue) [1/s]: positive means asymptotically stable.
Units are B's (lb as mass, ft, s).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.signal
from numpy.typing import ArrayLike

from biped.errors import ScenarioError
from biped.planar import body_leg as bl
from biped.planar import pendulum as pd
from biped.planar._checks import check_state


# --------------------------------------------------------------------------- A, B matrices
def ab_matrices(p: bl.BodyLegParams) -> tuple[np.ndarray, np.ndarray]:
    """A (4, 4) and B (4, 2) of the linearized body-leg, eq. 3.58, 3.59 as derived.

    These follow from eq. 3.51 and 3.54 (which B's Lisp integrates); B's print of eq. 3.58 has
    A[1, 2] = +l^2 m^2 r g / (I m r^2) and of eq. 3.59 B[3, 0] = +l / (I r): both signs are wrong
    (see ``ab_matrices_as_printed`` and docs/posture.md).
    """
    m, I, r, l, g = p.m, p.I, p.r, p.l, p.g
    if I <= 0:
        raise ScenarioError("the linearized body-leg needs I > 0 (eq. 3.58 divides by I m r^2)")
    D = I * m * r * r
    J = I + m * l * l
    A = np.array(
        [
            [0.0, 1.0, 0.0, 0.0],
            [m * g * r * J / D, 0.0, -(l * l * m * m * r * g) / D, 0.0],
            [0.0, 0.0, 0.0, 1.0],
            [-l * m * g * r / (I * r), 0.0, m * g * l * r / (I * r), 0.0],
        ]
    )
    B = np.array([[0.0, 0.0], [J / D, -(l * m * r + J) / D], [0.0, 0.0], [-l / (I * r), (r + l) / (I * r)]])
    return A, B


def ab_matrices_as_printed(p: bl.BodyLegParams) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 3.58, 3.59 exactly as B prints them (two sign typos), for the record."""
    A, B = ab_matrices(p)
    A, B = A.copy(), B.copy()
    A[1, 2] = -A[1, 2]
    B[3, 0] = -B[3, 0]
    return A, B


def linearize(
    accel: Callable[[np.ndarray, np.ndarray], ArrayLike], nq: int, nu: int, eps: float = 1e-6, du: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """Central finite-difference Jacobians of x_dot = f(x, u) at x = 0, u = 0.

    accel(x, u) -> the nq accelerations (first nq entries of a form's result); states interleave
    (q_0, qd_0, q_1, qd_1, ...). ``eps`` is the state step [rad, rad/s], ``du`` the torque step
    (torques are O(1e4) in B's units, and the forms are linear in them). Returns A (2 nq, 2 nq),
    B (2 nq, nu).
    """

    def f(x, u):
        out = np.empty(2 * nq)
        out[0::2] = x[1::2]
        out[1::2] = np.asarray(accel(x, u), dtype=float)[:nq]
        return out

    n = 2 * nq
    x0, u0 = np.zeros(n), np.zeros(nu)
    A = np.empty((n, n))
    B = np.empty((n, nu))
    for j in range(n):
        e = np.zeros(n)
        e[j] = eps
        A[:, j] = (f(x0 + e, u0) - f(x0 - e, u0)) / (2 * eps)
    for j in range(nu):
        e = np.zeros(nu)
        e[j] = du
        B[:, j] = (f(x0, u0 + e) - f(x0, u0 - e)) / (2 * du)
    return A, B


def body_leg_linearized(p: bl.BodyLegParams, method: str = "lagrange") -> tuple[np.ndarray, np.ndarray]:
    """A, B by finite differences of a body-leg form (default: the nonlinear eq. 3.18, 3.24)."""
    fn = bl.BODY_LEG_METHODS[method]
    return linearize(lambda x, u: fn(p, x, u)[:2], 2, 2)


def pendulum_ab(p: pd.PendulumParams) -> tuple[np.ndarray, np.ndarray]:
    """A (2, 2), B (2, 1) of eq. 2.27 linearized at upright (theta = 0)."""
    J = p.I + p.m * p.l**2
    return np.array([[0.0, 1.0], [p.m * p.g * p.l / J, 0.0]]), np.array([[0.0], [1.0 / J]])


# --------------------------------------------------------------------------- feedback
def local_gain_matrix(gains: ArrayLike) -> np.ndarray:
    """K (2, 4) of eq. 3.60 from (K_theta1, K_theta1dot, K_theta2, K_theta2dot)."""
    k1, k1d, k2, k2d = check_state(gains, 4, "local gains (K1, K1D, K2, K2D)")
    return -np.array([[k1, k1d, 0.0, 0.0], [0.0, 0.0, k2, k2d]])


def characteristic_polynomial(p: bl.BodyLegParams, gains: ArrayLike) -> np.ndarray:
    """Coefficients (5,), highest power first, of eq. 3.80: I m r^2 det(s I - (A + B K)).

    s^4: I m r^2
    s^3: l r m K2d + I K1d + K1d m l^2 + r^2 m K2d
    s^2: I K1 - l^2 m^2 r g + m l^2 K1 - r^2 m^2 l g + r^2 m K2 + r m l K2 + K1d K2d - I m g r
    s^1: K1 K2d - l m g K1d + K1d K2 - m g r K2d
    s^0: m^2 g^2 r l - m g r K2 - K1 l m g + K1 K2 = (K1 - m g r)(K2 - m g l)
    """
    k1, k1d, k2, k2d = check_state(gains, 4, "local gains (K1, K1D, K2, K2D)")
    m, I, r, l, g = p.m, p.I, p.r, p.l, p.g
    return np.array(
        [
            r * r * I * m,
            l * r * m * k2d + I * k1d + k1d * m * l * l + r * r * m * k2d,
            I * k1 - l * l * m * m * r * g + m * l * l * k1 - r * r * m * m * l * g
            + r * r * m * k2 + r * m * l * k2 + k1d * k2d - I * m * g * r,
            k1 * k2d - l * m * g * k1d + k1d * k2 - m * g * r * k2d,
            m * m * g * g * r * l - m * g * r * k2 - k1 * l * m * g + k1 * k2,
        ]
    )  # fmt: skip


def hurwitz_minors(coeffs: ArrayLike) -> np.ndarray:
    """Leading principal minors of the Hurwitz matrix of a0 s^n + a1 s^(n-1) + ... + an (a0 > 0).

    All coefficients and all minors positive <=> all roots in the open left half plane (Routh-
    Hurwitz). For the quartic: a1, a1 a2 - a0 a3, a3 (a1 a2 - a0 a3) - a1^2 a4, a4 times that.
    """
    a = np.asarray(coeffs, dtype=float)
    if a[0] < 0:
        a = -a
    n = len(a) - 1
    H = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            k = 2 * j - i + 1
            if 0 <= k <= n:
                H[i, j] = a[k]
    return np.array([np.linalg.det(H[: i + 1, : i + 1]) for i in range(n)])


def routh_hurwitz_stable(coeffs: ArrayLike) -> bool:
    """True iff every root of the polynomial has a negative real part (Routh-Hurwitz test)."""
    a = np.asarray(coeffs, dtype=float)
    if a[0] < 0:
        a = -a
    return bool(np.all(a > 0) and np.all(hurwitz_minors(a) > 0))


@dataclass(frozen=True)
class LinearAnalysis:
    """Linearized closed loop: A, B, K (u = K x), eigenvalues of A + B K, the margin
    -max Re(lambda) [1/s], stable (margin > 0) and, for the local body-leg gains, eq. 3.80's
    coefficients (highest first)."""

    A: np.ndarray
    B: np.ndarray
    K: np.ndarray
    eigenvalues: np.ndarray
    margin: float
    stable: bool
    char_poly: np.ndarray | None = None

    def eigenvalue_pairs(self) -> list[list[float]]:
        """Eigenvalues as [[re, im], ...] sorted by real part, for JSON."""
        ev = sorted(self.eigenvalues, key=lambda z: (z.real, z.imag))
        return [[float(z.real), float(z.imag)] for z in ev]


def _analysis(A, B, K, char_poly=None) -> LinearAnalysis:
    ev = np.linalg.eigvals(A + B @ K)
    margin = float(-np.max(ev.real))
    return LinearAnalysis(A, B, K, ev, margin, margin > 0, char_poly)


def analyze_body_leg(p: bl.BodyLegParams, gains: ArrayLike) -> LinearAnalysis:
    """Closed-loop eigenvalues of eq. 3.57 with the local gains of eq. 3.60."""
    A, B = ab_matrices(p)
    return _analysis(A, B, local_gain_matrix(gains), characteristic_polynomial(p, gains))


def analyze_pendulum(p: pd.PendulumParams, gains: ArrayLike) -> LinearAnalysis:
    """Closed loop of eq. 2.27 linearized with M = -K_theta theta - K_thetadot theta_dot (4.32).

    Characteristic polynomial (I + m l^2) s^2 + K_thetadot s + (K_theta - m g l)."""
    k, kd = check_state(gains, 2, "pendulum gains (K_theta, K_thetadot)")
    A, B = pendulum_ab(p)
    cp = np.array([p.I + p.m * p.l**2, kd, k - p.m * p.g * p.l])
    return _analysis(A, B, -np.array([[k, kd]]), cp)


# --------------------------------------------------------------------------- gain design
def place_poles_gains(A: np.ndarray, B: np.ndarray, poles: ArrayLike) -> np.ndarray:
    """Full-state K (u = K x) placing the eigenvalues of A + B K at ``poles`` (scipy's
    ``place_poles``, which returns the opposite sign)."""
    res = scipy.signal.place_poles(A, B, np.asarray(poles))
    return -res.gain_matrix


@dataclass(frozen=True)
class LqrResult:
    """K (u = K x) minimizing the integral of x'Qx + u'Ru; P the Riccati solution (cost x0'P x0)."""

    K: np.ndarray
    P: np.ndarray
    eigenvalues: np.ndarray


def lqr(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray) -> LqrResult:
    """Continuous LQR via ``scipy.linalg.solve_continuous_are``: K = -R^-1 B' P."""
    P = scipy.linalg.solve_continuous_are(A, B, Q, R)
    K = -np.linalg.solve(R, B.T @ P)
    return LqrResult(K, P, np.linalg.eigvals(A + B @ K))


def bryson_weights(
    max_angle: float = 0.1, max_rate: float = 1.0, max_torque: float = 5000.0
) -> tuple[np.ndarray, np.ndarray]:
    """Bryson's rule weights for the body-leg: Q = diag(1/x_max^2), R = diag(1/u_max^2)."""
    q = np.array([max_angle, max_rate, max_angle, max_rate], dtype=float) ** -2
    return np.diag(q), np.eye(2) / max_torque**2


@dataclass(frozen=True)
class LocalGainSearch:
    """The local gains (K1, K1D, K2, K2D) with the largest stability margin inside ``bounds``
    ((4, 2) [low, high]), the margin [1/s] and eigenvalues."""

    gains: np.ndarray
    margin: float
    eigenvalues: np.ndarray
    bounds: np.ndarray


DEFAULT_LOCAL_BOUNDS = np.array([[0.0, 50000.0], [0.0, 5000.0], [0.0, 50000.0], [0.0, 5000.0]])


def best_local_gains(
    p: bl.BodyLegParams, bounds: ArrayLike | None = None, *, seed: int = 0, maxiter: int = 200
) -> LocalGainSearch:
    """Maximize the stability margin -max Re(lambda(A + B K_local)) over the local gains of eq.
    3.60 inside a box (default: 0..50000 for K1, K2 and 0..5000 for the rate gains, which holds
    both of B's sets). Differential evolution (scipy) then Nelder-Mead polish."""
    A, B = ab_matrices(p)
    bounds = DEFAULT_LOCAL_BOUNDS if bounds is None else np.asarray(bounds, dtype=float)
    if bounds.shape != (4, 2) or not np.all(bounds[:, 1] > bounds[:, 0]):
        raise ScenarioError(f"bounds must be (4, 2) [low, high] with high > low, got {bounds!r}")

    def neg_margin(k):
        return float(np.max(np.linalg.eigvals(A + B @ local_gain_matrix(k)).real))

    res = scipy.optimize.differential_evolution(
        neg_margin, bounds, seed=seed, maxiter=maxiter, tol=1e-10, polish=False
    )
    best = np.clip(res.x, bounds[:, 0], bounds[:, 1])
    pol = scipy.optimize.minimize(
        lambda k: neg_margin(np.clip(k, bounds[:, 0], bounds[:, 1])), best, method="Nelder-Mead",
        options={"xatol": 1e-6, "fatol": 1e-12, "maxiter": 4000},
    )  # fmt: skip
    cand = np.clip(pol.x, bounds[:, 0], bounds[:, 1])
    if neg_margin(cand) < neg_margin(best):
        best = cand
    ev = np.linalg.eigvals(A + B @ local_gain_matrix(best))
    return LocalGainSearch(best, float(-np.max(ev.real)), ev, bounds)


@dataclass(frozen=True)
class StabilityMap:
    """Margin -max Re(lambda) [1/s] on a grid: margin[i, j] at (k_theta1[j], k_theta2[i]), with
    the rate gains fixed."""

    k_theta1: np.ndarray
    k_theta2: np.ndarray
    k_theta1_dot: float
    k_theta2_dot: float
    margin: np.ndarray


def stability_map(
    p: bl.BodyLegParams, k_theta1: ArrayLike, k_theta2: ArrayLike, k_theta1_dot: float = 2500.0,
    k_theta2_dot: float = 400.0,
) -> StabilityMap:  # fmt: skip
    """The closed-loop margin over a (K_theta1, K_theta2) grid with the rate gains fixed."""
    A, B = ab_matrices(p)
    k1 = np.asarray(k_theta1, dtype=float)
    k2 = np.asarray(k_theta2, dtype=float)
    out = np.empty((len(k2), len(k1)))
    for i, b in enumerate(k2):
        for j, a in enumerate(k1):
            K = local_gain_matrix((a, k_theta1_dot, b, k_theta2_dot))
            out[i, j] = -np.max(np.linalg.eigvals(A + B @ K).real)
    return StabilityMap(k1, k2, float(k_theta1_dot), float(k_theta2_dot), out)
