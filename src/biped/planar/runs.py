"""Closed-loop runs of Bediz's planar models with local linear state feedback (B V-B).

A run is a function of (params, method, gains, x0, dt, duration, integrator) returning a frozen
``Trajectory``; nothing is plotted or written here (see ``biped.viz.posture`` and the CLI).

By default the torques are held over each step (computed once from x_n, as B's Lisp code does,
a sampled-data controller); ``hold=False`` re-evaluates them inside every stage of the integrator
(the continuous closed loop).
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from biped.errors import BipedError, ScenarioError, StateError
from biped.planar import body_leg as bl
from biped.planar import integrators
from biped.planar import pendulum as pd
from biped.planar._checks import check_choice, check_positive, check_state

#: B's gains: eq. 5.1, 5.2 (pendulum) and eq. 5.5-5.8 (body-leg); eq. 3.83 has K_theta2 = 4000.
PENDULUM_GAINS = (10000.0, 2000.0)
BODY_LEG_GAINS = (25000.0, 2500.0, 40000.0, 400.0)
BODY_LEG_GAINS_EQ_3_83 = (25000.0, 2500.0, 4000.0, 400.0)


@dataclass(frozen=True)
class LocalFeedback:
    """Local linear state feedback, eq. 3.6, 3.7 with the signs of eq. 3.60 (and eq. 4.32):

    M_1 = -K_theta1 (theta_1 - alpha_1) - K_theta1dot theta_1_dot
    M_2 = -K_theta2 (theta_2 - alpha_2) - K_theta2dot theta_2_dot

    Gains positive [lb ft^2/s^2 per rad, per rad/s]; set points alpha [rad]. For the pendulum only
    the first pair is used (eq. 4.32: M = -K_theta theta - K_thetadot theta_dot). B prints eq. 3.6,
    3.7 with + signs, which would need negative gains; its eq. 3.60 and Lisp code use these signs.
    """

    k_theta1: float
    k_theta1_dot: float
    k_theta2: float = 0.0
    k_theta2_dot: float = 0.0
    alpha1: float = 0.0
    alpha2: float = 0.0

    def __post_init__(self):
        for name in ("k_theta1", "k_theta1_dot", "k_theta2", "k_theta2_dot", "alpha1", "alpha2"):
            if not math.isfinite(float(getattr(self, name))):
                raise ScenarioError(f"{name} must be finite, got {getattr(self, name)!r}")

    @property
    def gains(self) -> tuple[float, float, float, float]:
        return (self.k_theta1, self.k_theta1_dot, self.k_theta2, self.k_theta2_dot)

    def pendulum_torque(self, x: np.ndarray) -> np.ndarray:
        """(1,) torque M of eq. 4.32 for the pendulum state (theta, theta_dot)."""
        return np.array([-self.k_theta1 * (x[0] - self.alpha1) - self.k_theta1_dot * x[1]])

    def body_leg_torques(self, x: np.ndarray) -> np.ndarray:
        """(2,) torques (M_1, M_2) of eq. 3.6, 3.7 for the body-leg state (eq. 3.1)."""
        return np.array(
            [
                -self.k_theta1 * (x[0] - self.alpha1) - self.k_theta1_dot * x[1],
                -self.k_theta2 * (x[2] - self.alpha2) - self.k_theta2_dot * x[3],
            ]
        )


@dataclass(frozen=True)
class Trajectory:
    """A closed-loop run, sampled at every step.

    time (n,) [s]; states (n, k) (pendulum k = 2: theta, theta_dot; body-leg k = 4, eq. 3.1)
    [rad, rad/s]; torques (n, n_u) [lb ft^2/s^2]; forces: name -> (n,) reaction forces [poundal]
    where the method gives them (pendulum newton-euler: fx, fy; body-leg newton-euler: F, F_r);
    wall_time [s] of the integration loop.
    """

    model: str
    method: str
    integrator: str
    dt: float
    hold: bool
    params: object
    feedback: LocalFeedback
    time: np.ndarray
    states: np.ndarray
    torques: np.ndarray
    forces: dict = field(default_factory=dict)
    wall_time: float = 0.0

    @property
    def state_names(self) -> tuple[str, ...]:
        if self.model == "pendulum":
            return ("theta", "theta_dot")
        return ("theta1", "theta1_dot", "theta2", "theta2_dot")


def _interleave(nq):
    def rhs_from(acc_fn):
        def rhs(t, x, u):
            a = acc_fn(x, u)
            out = np.empty(2 * nq)
            out[0::2] = x[1::2]
            out[1::2] = a[:nq]
            return out

        return rhs

    return rhs_from


def _run(model, method, acc_fn, nq, torque_fn, x0, dt, duration, integrator, hold, progress):
    step = integrators.get(integrator)
    if integrator == "heun-frozen" and not hold:
        raise ScenarioError("integrator 'heun-frozen' (B's Lisp step) needs hold=True")
    dt = check_positive("dt", dt)
    duration = check_positive("duration", duration, allow_zero=True)
    n = round(duration / dt)
    rhs = _interleave(nq)(acc_fn)
    xs = np.empty((n + 1, 2 * nq))
    xs[0] = x0
    us = np.empty((n + 1, len(torque_fn(x0))))
    iterator = range(n)
    if progress and n > 2000:
        from biped._progress import track  # a bar on a terminal, whole lines otherwise

        iterator = track(iterator, n, desc=f"{model} {method}", unit="step")
    t0 = _time.perf_counter()
    for i in iterator:
        x = xs[i]
        u = torque_fn(x)
        us[i] = u
        f: Callable[[float, np.ndarray], np.ndarray]
        if hold:
            f = lambda t, y, u=u: rhs(t, y, u)  # type: ignore[misc]
        else:
            f = lambda t, y: rhs(t, y, torque_fn(y))
        cause: Exception | None
        try:
            with np.errstate(over="ignore", invalid="ignore"):
                x_next = step(f, i * dt, x, dt)
            cause = None
        except (OverflowError, StateError) as exc:  # a stage left the finite numbers
            x_next, cause = None, exc
        except ValueError as exc:  # math domain error on inf; other BipedErrors propagate
            if isinstance(exc, BipedError):
                raise
            x_next, cause = None, exc
        if x_next is None or not np.all(np.isfinite(x_next)):
            raise StateError(
                f"the {model} state became non-finite at t = {(i + 1) * dt:.4g} s "
                f"({method}, {integrator}, dt = {dt}): the closed loop diverged; "
                "try a smaller dt, another integrator or other gains"
            ) from cause
        xs[i + 1] = x_next
    wall = _time.perf_counter() - t0
    us[n] = torque_fn(xs[n])
    return xs, us, wall


def simulate_pendulum(
    params: pd.PendulumParams | None = None,
    method: str = "newton-euler",
    gains: ArrayLike = PENDULUM_GAINS,
    x0: ArrayLike = (1.0, 0.0),
    dt: float = 0.02,
    duration: float = 20.0,
    integrator: str = "euler",
    *,
    alpha: float = 0.0,
    hold: bool = True,
    progress: bool = False,
) -> Trajectory:
    """Single-link pendulum under eq. 4.32; defaults are B's run of Fig. 25 (Euler, dt 0.02 s).

    method: one of ``pendulum.PENDULUM_METHODS``; gains (K_theta, K_thetadot); x0 (theta,
    theta_dot) [rad, rad/s]; alpha the set point [rad].
    """
    params = params or pd.PendulumParams()
    fn = pd.PENDULUM_METHODS[check_choice("pendulum method", method, pd.PENDULUM_METHODS)]
    gains = tuple(check_state(gains, 2, "pendulum gains (K_theta, K_thetadot)"))
    x0 = check_state(x0, 2, "pendulum x0 (theta, theta_dot)")
    fb = LocalFeedback(gains[0], gains[1], alpha1=alpha)
    integrators.get(integrator)

    def acc(x, u):
        return fn(params, x[0], x[1], u[0])

    xs, us, wall = _run(
        "pendulum", method, acc, 1, fb.pendulum_torque, x0, dt, duration, integrator, hold, progress
    )
    forces = {}
    if method.startswith("newton-euler"):
        sol = [fn(params, x[0], x[1], u[0]) for x, u in zip(xs, us, strict=True)]
        forces = {"fx": np.array([s.fx for s in sol]), "fy": np.array([s.fy for s in sol])}
    return Trajectory(
        "pendulum", method, integrator, dt, hold, params, fb,
        np.arange(len(xs)) * dt, xs, us, forces, wall,
    )  # fmt: skip


def simulate_body_leg(
    params: bl.BodyLegParams | None = None,
    method: str = "lagrange-linear",
    gains: ArrayLike = BODY_LEG_GAINS,
    x0: ArrayLike = (0.5, 0.0, 1.0, 0.0),
    dt: float = 0.01,
    duration: float = 5.0,
    integrator: str = "heun",
    *,
    alpha=(0.0, 0.0),
    hold: bool = True,
    progress: bool = False,
) -> Trajectory:
    """Body + massless leg under eq. 3.6, 3.7; defaults are B's "Lagrangian" run (Figs. 30, 31:
    the linearized eq. 3.51, 3.54, Heun, dt 0.01 s). B's Newton-Euler run (Figs. 36, 37) is
    ``method="newton-euler-printed", integrator="heun-frozen"``.

    gains (K_theta1, K_theta1dot, K_theta2, K_theta2dot); x0 eq. 3.1 [rad, rad/s]; alpha the set
    points (alpha_1, alpha_2) [rad].
    """
    params = params or bl.BodyLegParams()
    fn = bl.BODY_LEG_METHODS[check_choice("body-leg method", method, bl.BODY_LEG_METHODS)]
    k1, k1d, k2, k2d = check_state(gains, 4, "body-leg gains (K1, K1D, K2, K2D)")
    gains = (k1, k1d, k2, k2d)
    alpha = tuple(check_state(alpha, 2, "set points (alpha_1, alpha_2)"))
    x0 = check_state(x0, 4, "body-leg x0 (theta1, theta1_dot, theta2, theta2_dot)")
    fb = LocalFeedback(k1, k1d, k2, k2d, alpha1=alpha[0], alpha2=alpha[1])
    integrators.get(integrator)

    def acc(x, u):
        return fn(params, x, u)

    xs, us, wall = _run(
        "body-leg", method, acc, 2, fb.body_leg_torques, x0, dt, duration, integrator, hold,
        progress,
    )  # fmt: skip
    forces = {}
    if method.startswith("newton-euler"):
        sol = [fn(params, x, u) for x, u in zip(xs, us, strict=True)]
        forces = {"F": np.array([s.F for s in sol]), "F_r": np.array([s.F_r for s in sol])}
    return Trajectory(
        "body-leg", method, integrator, dt, hold, params, fb,
        np.arange(len(xs)) * dt, xs, us, forces, wall,
    )  # fmt: skip


def simulate_pendulum_as_lisp(
    params: pd.PendulumParams | None = None, gains: ArrayLike = PENDULUM_GAINS, x0: ArrayLike = (1.0, 0.0),
    dt: float = 0.02, steps: int = 1001,
) -> Trajectory:  # fmt: skip
    """B's Fig. 25 run exactly as its Lisp rigid-body class steps it (Appendix A).

    ``update-rigid-body`` moves the posture with the old rate, then the rate with the growth rate
    stored at the end of the *previous* call (zero on the first step), so the angular acceleration
    reaches the rate one step late: theta_{n+1} = theta_n + dt q_n, q_{n+1} = q_n + dt a_{n-1}.
    The 3x3 of eq. 4.30 gives a_n. Returns ``steps + 1`` samples (B loops i = 0..1000).
    """
    params = params or pd.PendulumParams()
    fb = LocalFeedback(*check_state(gains, 2, "pendulum gains"))
    x = check_state(x0, 2, "pendulum x0").copy()
    xs, us = [x.copy()], []
    a_prev = 0.0
    for _ in range(steps):
        u = fb.pendulum_torque(x)
        us.append(u)
        a_now = pd.newton_euler_pitch(params, x[0], x[1], u[0]).theta_ddot
        x = np.array([x[0] + dt * x[1], x[1] + dt * a_prev])
        a_prev = a_now
        xs.append(x.copy())
    us.append(fb.pendulum_torque(x))
    states = np.array(xs)
    return Trajectory(
        "pendulum", "newton-euler", "lisp-delayed-euler", dt, True, params, fb,
        np.arange(len(states)) * dt, states, np.array(us), {}, 0.0,
    )  # fmt: skip
