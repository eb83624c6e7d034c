"""Bediz's body on a constant-length massless leg (B ch. III, IV-C-3b/c, V-B-2/3).

State x = (theta_1, theta_1_dot, theta_2, theta_2_dot) (eq. 3.1): theta_1 is the leg angle, theta_2
the body attitude, both from the upward vertical [rad], positive toward +y (B's Fig. 9: the hip is
at (r sin theta_1, r cos theta_1) from the ankle, the body's centre of mass a further
(l sin theta_2, l cos theta_2), y horizontal, z up). Inputs u = (M_1, M_2) (eq. 3.2-3.4): M_1 the
ankle torque on the leg, M_2 the hip torque on the body (and -M_2 on the leg), positive in the sense
of increasing angle. Generalized forces are Q_1 = M_1 - M_2, Q_2 = M_2 (eq. 3.13, 3.19).

Reaction forces of the Newton-Euler form (the leg's force on the body at the hip): F along the leg
(from ankle to hip, positive pushing the body up the leg) and F_r perpendicular to it, along
(cos theta_1, -sin theta_1) (eq. 3.28-3.31, with the sign of eq. 3.37-3.42).

Units are B's own: m in lb (used as a mass), ft, s; forces in poundals (lb ft/s^2), torques in
lb ft^2/s^2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from biped.errors import SingularityError
from biped.planar._checks import Vector, check_positive, check_state, solve3


@dataclass(frozen=True)
class BodyLegParams:
    """Parameters of the body + massless leg; defaults are B's runs (V-B-2, V-B-3).

    m: body mass [lb]; I: body rotary inertia about its centre of mass [lb ft^2]; r: leg length
    [ft]; l: hip to body centre of mass [ft]; g: gravity [ft/s^2].
    """

    m: float = 100.0
    I: float = 100.0
    r: float = 3.0
    l: float = 0.5
    g: float = 32.2

    def __post_init__(self):
        check_positive("m", self.m)
        check_positive("I", self.I, allow_zero=True)
        check_positive("r", self.r)
        check_positive("l", self.l, allow_zero=True)
        check_positive("g", self.g, allow_zero=True)


class BodyLegAccel(NamedTuple):
    """One form's result: (theta_1_dd, theta_2_dd) [rad/s^2] and, for the Newton-Euler form, the
    leg force F and the leg reaction F_r on the body [poundal] (None where the form has none)."""

    theta1_ddot: float
    theta2_ddot: float
    F: float | None = None
    F_r: float | None = None


def _unpack(x, u):
    x = check_state(x, 4, "body-leg state (theta_1, theta_1_dot, theta_2, theta_2_dot)")
    u = check_state(u, 2, "torques (M_1, M_2)")
    return float(x[0]), float(x[1]), float(x[2]), float(x[3]), float(u[0]), float(u[1])


def mass_matrix(p: BodyLegParams, theta1: float, theta2: float) -> np.ndarray:
    """The Lagrangian mass matrix of eq. 3.18/3.24, (2, 2) [lb ft^2]."""
    c = math.cos(theta1 - theta2)
    mrl = p.m * p.r * p.l
    return np.array([[p.m * p.r**2, mrl * c], [mrl * c, p.I + p.m * p.l**2]])


def lagrange(p: BodyLegParams, x: Vector, u: Vector) -> BodyLegAccel:
    """Nonlinear Lagrangian equations, eq. 3.18 and 3.24, solved for the accelerations.

    m r^2 t1dd + m l r cos(t2 - t1) t2dd + m l r t2d^2 sin(t1 - t2) - m g r sin t1 = M_1 - M_2
    m l r cos(t1 - t2) t1dd + (I + m l^2) t2dd + m l r t1d^2 sin(t2 - t1) - m g l sin t2 = M_2

    The 2x2 system is solved in closed form (Cramer's rule); SingularityError when its
    determinant m r^2 (I + m l^2 sin^2(t1 - t2)) vanishes (I = 0 with the leg and body aligned).
    """
    t1, t1d, t2, t2d, M1, M2 = _unpack(x, u)
    m, I, r, l, g = p.m, p.I, p.r, p.l, p.g
    d = t1 - t2
    c, s = math.cos(d), math.sin(d)
    a11, a12, a22 = m * r * r, m * l * r * c, I + m * l * l
    b1 = M1 - M2 - m * l * r * t2d * t2d * s + m * g * r * math.sin(t1)
    b2 = M2 + m * l * r * t1d * t1d * s + m * g * l * math.sin(t2)
    det = a11 * a22 - a12 * a12
    if not abs(det) > 1e-12 * a11 * max(a22, m * l * l, 1e-300):
        raise SingularityError(
            f"the Lagrangian mass matrix of eq. 3.18/3.24 is singular at theta_1 = {t1:.6g}, "
            f"theta_2 = {t2:.6g} (det = m r^2 (I + m l^2 sin^2(theta_1 - theta_2)) = {det:.3g}); "
            "use I > 0 or a configuration with theta_1 != theta_2"
        )
    return BodyLegAccel((a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det)


def lagrange_linear(p: BodyLegParams, x: Vector, u: Vector) -> BodyLegAccel:
    """Linearized equations 3.47, 3.48 as B's Lisp code integrates them (eq. 3.51, 3.54).

    t1dd = (l^2 m^2 r g t2 - m g r (I + m l^2) t1 - (I + m l^2) M_1 + (l m r + I + m l^2) M_2)
           / (-I m r^2)
    t2dd = (m g l r t2 - l m g r t1 - l M_1 + (r + l) M_2) / (r I)
    """
    t1, _t1d, t2, _t2d, M1, M2 = _unpack(x, u)
    m, I, r, l, g = p.m, p.I, p.r, p.l, p.g
    if I <= 0.0:
        raise SingularityError(
            "the linearized equations 3.51/3.54 divide by the body inertia I, which is 0; "
            "use I > 0 or the nonlinear method"
        )
    J = I + m * l * l
    t1dd = (l * l * m * m * r * g * t2 - m * g * r * J * t1 - J * M1 + (l * m * r + J) * M2) / (
        -I * m * r * r
    )
    t2dd = (m * g * l * r * t2 - l * m * g * r * t1 - l * M1 + (r + l) * M2) / (r * I)
    return BodyLegAccel(t1dd, t2dd)


def leg_reaction(p: BodyLegParams, M1: float, M2: float) -> float:
    """F_r = (M_1 - M_2) / r, eq. 3.28: static balance of the massless leg [poundal]."""
    return (M1 - M2) / p.r


def newton_euler_system(
    p: BodyLegParams, x: Vector, u: Vector, *, as_printed: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """The 3x3 matrix and right-hand side of eq. 3.42 in the unknowns (t1dd, t2dd, F).

    Rows: body rotation (eq. 3.31 with F_r of eq. 3.28), body y and z translation (eq. 3.40,
    3.41). B prints the first right-hand side as (M_2 (l + r) - l M_1) cos(t2 - t1) / r, and its
    Lisp code integrates that; the derivation (eq. 3.31) gives M_2 - l (M_1 - M_2) cos(t2 - t1) / r.
    ``as_printed=True`` selects B's print; the default is the derivation. Returns (a (3, 3),
    b (3,)).
    """
    t1, t1d, t2, t2d, M1, M2 = _unpack(x, u)
    m, I, r, l, g = p.m, p.I, p.r, p.l, p.g
    s1, c1, s2, c2 = math.sin(t1), math.cos(t1), math.sin(t2), math.cos(t2)
    s21, c21 = math.sin(t2 - t1), math.cos(t2 - t1)
    Fr = (M1 - M2) / r
    a = np.array([[0.0, I, -l * s21], [m * r * c1, m * l * c2, -s1], [m * r * s1, m * l * s2, c1]])
    if as_printed:
        b0 = (M2 * (l + r) - l * M1) * c21 / r
    else:
        b0 = M2 - l * Fr * c21
    b = np.array(
        [
            b0,
            m * r * t1d * t1d * s1 + m * l * t2d * t2d * s2 + Fr * c1,
            -m * r * t1d * t1d * c1 - m * l * t2d * t2d * c2 + m * g + Fr * s1,
        ]
    )
    return a, b


def newton_euler(p: BodyLegParams, x: Vector, u: Vector, *, as_printed: bool = False) -> BodyLegAccel:
    """Newton-Euler 3x3 form, eq. 3.42, with the leg reaction F_r of eq. 3.28.

    Solves for (t1dd, t2dd, F); the matrix has determinant -m r (I + m l^2 sin^2(t2 - t1)), so it is
    singular only when I = 0 and the leg and body are aligned: SingularityError then.
    """
    a, b = newton_euler_system(p, x, u, as_printed=as_printed)
    y = solve3(a, b, "body-leg Newton-Euler 3x3 (eq. 3.42)")
    return BodyLegAccel(float(y[0]), float(y[1]), float(y[2]), (float(u[0]) - float(u[1])) / p.r)


def newton_euler_printed(p: BodyLegParams, x: Vector, u: Vector) -> BodyLegAccel:
    """Eq. 3.42 exactly as B prints it and as B's Lisp code integrates it (see newton_euler)."""
    return newton_euler(p, x, u, as_printed=True)


#: The body-leg forms by command-line name.
BODY_LEG_METHODS = {
    "lagrange": lagrange,
    "lagrange-linear": lagrange_linear,
    "newton-euler": newton_euler,
    "newton-euler-printed": newton_euler_printed,
}


def points(p: BodyLegParams, x: Vector) -> dict[str, np.ndarray]:
    """Ankle, hip, body centre of mass and the body's top (2 l above the hip), each (2,) (y, z)
    [ft], for drawing (eq. 3.32, 3.33)."""
    t1, t2 = float(x[0]), float(x[2])
    hip = np.array([p.r * math.sin(t1), p.r * math.cos(t1)])
    b = np.array([math.sin(t2), math.cos(t2)])
    return {"ankle": np.zeros(2), "hip": hip, "com": hip + p.l * b, "top": hip + 2 * p.l * b}


def energy(p: BodyLegParams, x: Vector) -> float:
    """Kinetic plus potential energy (eq. 3.10, 3.11) [lb ft^2/s^2]."""
    t1, t1d, t2, t2d = (float(v) for v in x)
    m, I, r, l, g = p.m, p.I, p.r, p.l, p.g
    T = 0.5 * m * (r * r * t1d * t1d + l * l * t2d * t2d + 2 * r * l * t1d * t2d * math.cos(t1 - t2))
    return T + 0.5 * I * t2d * t2d + m * g * (r * math.cos(t1) + l * math.cos(t2))
