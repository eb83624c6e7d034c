"""Bediz's single-link inverted pendulum (B ch. II-C, IV-C-3a, V-B-1) in four forms.

Conventions (one for every form, so they can be compared):

* ``theta`` is the pendulum's tilt from the upward vertical [rad], counter-clockwise positive in a
  plane with x horizontal and y up. The centre of mass sits at (-l sin theta, l cos theta) from the
  pivot, so upright is theta = 0 and B's run starts at theta = 1 rad.
* ``M`` is the control torque at the pivot acting on the pendulum, counter-clockwise positive.
* The reaction force (F_x, F_y) is the force of the ground on the pendulum at the pivot, x
  horizontal, y up.

Units are B's own: m in lb (used as a mass), lengths in ft, t in s, so forces are in poundals
(lb ft/s^2) and torques in lb ft^2/s^2. B's eq. 2.5-2.10 measure the angle from the horizontal
(theta_h = theta + pi/2); eq. 4.30 (the Lisp code) measures the Euler pitch with z down, which is
the same number as ``theta`` here (see docs/posture.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from biped.planar._checks import check_finite, check_positive, solve3


@dataclass(frozen=True)
class PendulumParams:
    """Parameters of the single-link pendulum; defaults are B's run (V-B-1, Fig. 25).

    m: mass [lb]; I: rotary inertia about the centre of mass [lb ft^2]; l: pivot to centre of
    mass [ft]; g: gravity [ft/s^2].
    """

    m: float = 100.0
    I: float = 900.0
    l: float = 3.0
    g: float = 32.2185

    def __post_init__(self):
        check_positive("m", self.m)
        check_positive("I", self.I, allow_zero=True)
        check_positive("l", self.l)
        check_positive("g", self.g, allow_zero=True)


class PendulumAccel(NamedTuple):
    """Result of one pendulum form: angular acceleration [rad/s^2] and, where the form gives it,
    the ground reaction (F_x, F_y) on the pendulum [poundal]; None for the Lagrangian forms."""

    theta_ddot: float
    fx: float | None = None
    fy: float | None = None


def _inputs(theta, theta_dot, M):
    return (
        check_finite("theta", theta),
        check_finite("theta_dot", theta_dot),
        check_finite("torque M", M),
    )


def newton_euler_5x5(p: PendulumParams, theta: float, theta_dot: float, M: float) -> PendulumAccel:
    """Newton-Euler with constraint forces as B's 5x5 linear system (eq. 2.1-2.9).

    Unknowns (x_dd, y_dd, theta_dd, F_x, F_y); B's angle from the horizontal is theta + pi/2, so
    sin -> cos theta and cos -> -sin theta here.
    """
    theta, theta_dot, M = _inputs(theta, theta_dot, M)
    m, I, l, g = p.m, p.I, p.l, p.g
    s_h, c_h = math.cos(theta), -math.sin(theta)  # sin, cos of B's horizontal angle
    a = np.array(
        [
            [m, 0.0, 0.0, -1.0, 0.0],
            [0.0, m, 0.0, 0.0, -1.0],
            [0.0, 0.0, I, -l * s_h, l * c_h],
            [1.0, 0.0, l * s_h, 0.0, 0.0],
            [0.0, 1.0, -l * c_h, 0.0, 0.0],
        ]
    )
    b = np.array([0.0, -m * g, M, -(theta_dot**2) * l * c_h, -(theta_dot**2) * l * s_h])
    y = solve3(a, b, "pendulum 5x5 (eq. 2.9)")
    return PendulumAccel(float(y[2]), float(y[3]), float(y[4]))


def newton_euler_3x3(p: PendulumParams, theta: float, theta_dot: float, M: float) -> PendulumAccel:
    """Newton-Euler 3x3 form in (theta_dd, F_x, F_y) after eliminating x_dd, y_dd (eq. 2.10)."""
    theta, theta_dot, M = _inputs(theta, theta_dot, M)
    m, I, l, g = p.m, p.I, p.l, p.g
    s_h, c_h = math.cos(theta), -math.sin(theta)
    a = np.array([[I, -l * s_h, l * c_h], [m * l * s_h, 1.0, 0.0], [-m * l * c_h, 0.0, 1.0]])
    b = np.array([M, -m * theta_dot**2 * l * c_h, -m * theta_dot**2 * l * s_h + m * g])
    y = solve3(a, b, "pendulum 3x3 (eq. 2.10)")
    return PendulumAccel(float(y[0]), float(y[1]), float(y[2]))


def newton_euler_pitch(p: PendulumParams, theta: float, theta_dot: float, M: float) -> PendulumAccel:
    """B's Lisp form: the 3x3 system of eq. 4.30 in the Euler pitch angle (earth z down).

    Unknowns (theta_dd, E_Fx, E_Fz) with E_Fz the vertical force positive *down*; returned as
    (F_x, F_y) = (E_Fx, -E_Fz) in this module's y-up convention.
    """
    theta, theta_dot, M = _inputs(theta, theta_dot, M)
    m, I, l, g = p.m, p.I, p.l, p.g
    s, c = math.sin(theta), math.cos(theta)
    a = np.array([[I, -l * c, l * s], [m * l * c, 1.0, 0.0], [m * l * s, 0.0, -1.0]])
    b = np.array([M, theta_dot**2 * m * l * s, m * g - theta_dot**2 * m * l * c])
    y = solve3(a, b, "pendulum 3x3 (eq. 4.30)")
    return PendulumAccel(float(y[0]), float(y[1]), -float(y[2]))


def lagrange(p: PendulumParams, theta: float, theta_dot: float, M: float) -> PendulumAccel:
    """Lagrangian closed form, eq. 2.27: theta_dd = (M - m g l cos theta_h) / (I + m l^2).

    With theta_h = theta + pi/2: theta_dd = (M + m g l sin theta) / (I + m l^2).
    """
    theta, theta_dot, M = _inputs(theta, theta_dot, M)
    return PendulumAccel((M + p.m * p.g * p.l * math.sin(theta)) / (p.I + p.m * p.l**2))


def lagrange_linear(p: PendulumParams, theta: float, theta_dot: float, M: float) -> PendulumAccel:
    """Eq. 2.27 linearized about upright (sin theta -> theta)."""
    theta, theta_dot, M = _inputs(theta, theta_dot, M)
    return PendulumAccel((M + p.m * p.g * p.l * theta) / (p.I + p.m * p.l**2))


#: The pendulum forms by command-line name; ``newton-euler`` is B's run (eq. 4.30).
PENDULUM_METHODS = {
    "newton-euler": newton_euler_pitch,
    "newton-euler-2.10": newton_euler_3x3,
    "newton-euler-5x5": newton_euler_5x5,
    "lagrange": lagrange,
    "lagrange-linear": lagrange_linear,
}


def pivot_to_com(p: PendulumParams, theta: float) -> np.ndarray:
    """Centre of mass relative to the pivot, (2,) [ft], x horizontal, y up."""
    return np.array([-p.l * math.sin(theta), p.l * math.cos(theta)])


def energy(p: PendulumParams, theta: float, theta_dot: float) -> float:
    """Kinetic plus potential energy (eq. 2.24, 2.25 with the upright angle) [lb ft^2/s^2]."""
    return 0.5 * (p.I + p.m * p.l**2) * theta_dot**2 + p.m * p.g * p.l * math.cos(theta)
