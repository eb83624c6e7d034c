"""Fixed-step and adaptive integrators for x_dot = f(t, x) (B IV-C-2).

Every stepper has the signature ``step(f, t, x, dt) -> x_next`` with x a float array (n,).
``euler`` is eq. 4.26, ``heun`` eq. 4.28/4.29 (both B's), ``rk4`` the classical Runge-Kutta
method, ``adaptive`` one call of ``scipy.integrate.solve_ivp`` (RK45, tolerances below) over the
step. ``heun_frozen`` is what B's Newton-Euler Lisp code actually does (its corrector reuses the
accelerations of the start of the step; see docs/posture.md): first order in the velocities.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.integrate import solve_ivp

from biped.planar._checks import Vector, check_choice

Rhs = Callable[[float, np.ndarray], np.ndarray]

ADAPTIVE_RTOL = 1e-10
ADAPTIVE_ATOL = 1e-12


def euler(f: Rhs, t: float, x: np.ndarray, dt: float) -> np.ndarray:
    """Euler step, eq. 4.26: x_{n+1} = x_n + f(x_n, t_n) dt (order 1)."""
    return x + dt * f(t, x)


def heun(f: Rhs, t: float, x: np.ndarray, dt: float) -> np.ndarray:
    """Heun step, eq. 4.28, 4.29: predictor x* = x_n + f(x_n) dt, then the trapezoid (order 2)."""
    k1 = f(t, x)
    k2 = f(t + dt, x + dt * k1)
    return x + 0.5 * dt * (k1 + k2)


def rk4(f: Rhs, t: float, x: np.ndarray, dt: float) -> np.ndarray:
    """Classical fourth-order Runge-Kutta step (order 4)."""
    k1 = f(t, x)
    k2 = f(t + 0.5 * dt, x + 0.5 * dt * k1)
    k3 = f(t + 0.5 * dt, x + 0.5 * dt * k2)
    k4 = f(t + dt, x + dt * k3)
    return x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def adaptive(f: Rhs, t: float, x: np.ndarray, dt: float) -> np.ndarray:
    """One ``solve_ivp`` (RK45, rtol 1e-10, atol 1e-12) over [t, t + dt]."""
    sol = solve_ivp(f, (t, t + dt), x, method="RK45", rtol=ADAPTIVE_RTOL, atol=ADAPTIVE_ATOL)
    return sol.y[:, -1]


def heun_frozen(f: Rhs, t: float, x: np.ndarray, dt: float) -> np.ndarray:
    """B's Newton-Euler Lisp "Heun" step for states (q_0, qd_0, q_1, qd_1, ...).

    The corrector reuses the accelerations of x_n and only takes the predicted velocities:
    q_{n+1} = q_n + qd_n dt + a_n dt^2 / 2, qd_{n+1} = qd_n + a_n dt.
    """
    k1 = f(t, x)
    k2 = k1.copy()
    k2[0::2] = (x + dt * k1)[1::2]
    return x + 0.5 * dt * (k1 + k2)


INTEGRATORS = {
    "euler": euler,
    "heun": heun,
    "rk4": rk4,
    "adaptive": adaptive,
    "heun-frozen": heun_frozen,
}

#: The order of convergence of each fixed-step method (global error ~ dt^order).
ORDERS = {"euler": 1, "heun": 2, "rk4": 4}


def get(name: str):
    """The stepper called ``name``; ScenarioError listing the valid names otherwise."""
    return INTEGRATORS[check_choice("integrator", name, INTEGRATORS)]


def integrate(f: Rhs, x0: Vector, t_end: float, dt: float, method: str = "rk4") -> np.ndarray:
    """Integrate from t = 0 to ``t_end`` with ``n = round(t_end / dt)`` fixed steps; returns the
    (n + 1, len(x0)) states."""
    step = get(method)
    n = round(t_end / dt)
    xs = np.empty((n + 1, len(x0)))
    xs[0] = x0
    for i in range(n):
        xs[i + 1] = step(f, i * dt, xs[i], dt)
    return xs
