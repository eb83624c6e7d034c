"""The 6-DOF rigid body of B's Appendix A (McGhee's Lisp ``rigid-body`` class, after Frank and
McGhee 1969), B IV-C-1, eq. 4.24, 4.25.

Earth frame: x, y horizontal, z *down* (gravity +g along earth z). Posture (x, y, z, phi, theta,
psi): position of the centre of mass in the earth frame [ft] and Euler angles roll, pitch, yaw
[rad] with R = Rz(psi) Ry(theta) Rx(phi) taking body to earth coordinates (``rotation-matrix`` of
Appendix A). Velocity (u, v, w, p, q, r): linear and angular velocity in body principal axes
[ft/s, rad/s]. Forces (f_x, f_y, f_z) [poundal] and torques (L, M, N) [lb ft^2/s^2] act at the
centre of mass, in body axes. The Euler-rate matrix is singular at theta = +-90 deg; this module
raises SingularityError within ``GIMBAL_TOLERANCE`` of it rather than switching to quaternions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from biped.errors import SingularityError
from biped.planar._checks import Vector, check_positive, check_state

#: Distance [rad] from theta = +-pi/2 inside which the Euler-angle posture is refused.
GIMBAL_TOLERANCE = 1e-3


@dataclass(frozen=True)
class RigidBodyParams:
    """mass [lb], principal moments (I_xx, I_yy, I_zz) [lb ft^2], g [ft/s^2]; defaults are the Lisp
    class's (mass 100, inertia (1, 900, 1)) and B's g = 32.2185."""

    mass: float = 100.0
    inertia: tuple[float, float, float] = (1.0, 900.0, 1.0)
    g: float = 32.2185

    def __post_init__(self):
        check_positive("mass", self.mass)
        if len(self.inertia) != 3:
            raise ValueError("inertia must be (I_xx, I_yy, I_zz)")
        for name, v in zip(("I_xx", "I_yy", "I_zz"), self.inertia, strict=True):
            check_positive(name, v)
        check_positive("g", self.g, allow_zero=True)


def rotation_matrix(phi: float, theta: float, psi: float) -> np.ndarray:
    """Body-to-earth rotation R = Rz(psi) Ry(theta) Rx(phi), (3, 3) (Appendix A)."""
    sps, cps = math.sin(psi), math.cos(psi)
    sth, cth = math.sin(theta), math.cos(theta)
    sph, cph = math.sin(phi), math.cos(phi)
    return np.array(
        [
            [cps * cth, cps * sth * sph - sps * cph, cps * sth * cph + sps * sph],
            [sps * cth, cps * cph + sps * sth * sph, sps * sth * cph - cps * sph],
            [-sth, cth * sph, cth * cph],
        ]
    )


def euler_angles(R: np.ndarray) -> tuple[float, float, float]:
    """(phi, theta, psi) of a rotation matrix, inverse of ``rotation_matrix`` (theta in
    [-pi/2, pi/2])."""
    theta = -math.asin(max(-1.0, min(1.0, R[2, 0])))
    phi = math.atan2(R[2, 1], R[2, 2])
    psi = math.atan2(R[1, 0], R[0, 0])
    return phi, theta, psi


def body_rate_to_euler_rate_matrix(phi: float, theta: float) -> np.ndarray:
    """T (3, 3) with (phi_dot, theta_dot, psi_dot) = T (p, q, r) (Appendix A).

    [[1, tan th sin ph, tan th cos ph], [0, cos ph, -sin ph], [0, sin ph / cos th, cos ph / cos th]]
    SingularityError within GIMBAL_TOLERANCE of theta = +-90 deg (gimbal lock).
    """
    if abs(abs(theta) - math.pi / 2) < GIMBAL_TOLERANCE or abs(math.cos(theta)) < math.sin(GIMBAL_TOLERANCE):
        raise SingularityError(
            f"Euler pitch theta = {math.degrees(theta):.4f} deg is within "
            f"{math.degrees(GIMBAL_TOLERANCE):.3f} deg of +-90 deg, where the body-rate to "
            "Euler-rate matrix of Appendix A is singular (gimbal lock); keep |theta| away from "
            "90 deg or use a quaternion attitude (biped.spatial)"
        )
    sph, cph = math.sin(phi), math.cos(phi)
    tth, cth = math.tan(theta), math.cos(theta)
    return np.array([[1.0, tth * sph, tth * cph], [0.0, cph, -sph], [0.0, sph / cth, cph / cth]])


def velocity_growth_rate(
    p: RigidBodyParams, posture: Vector, velocity: Vector, force: Vector, torque: Vector
) -> np.ndarray:
    """(u_dot, v_dot, w_dot, p_dot, q_dot, r_dot), eq. 4.24 and 4.25 (Frank and McGhee).

    u_dot = r v - q w + f_x / m - g sin theta
    v_dot = p w - r u + f_y / m + g cos theta sin phi    (B's print lacks this g)
    w_dot = q u - p v + f_z / m + g cos theta cos phi
    p_dot = ((I_yy - I_zz) q r + L) / I_xx, and cyclically.
    """
    _, _, _, phi, theta, _ = posture
    u, v, w, pp, q, r = velocity
    fx, fy, fz = force
    L, M, N = torque
    m, g = p.mass, p.g
    Ix, Iy, Iz = p.inertia
    sth, cth = math.sin(theta), math.cos(theta)
    return np.array(
        [
            r * v - q * w + fx / m - g * sth,
            pp * w - r * u + fy / m + g * cth * math.sin(phi),
            q * u - pp * v + fz / m + g * cth * math.cos(phi),
            ((Iy - Iz) * q * r + L) / Ix,
            ((Iz - Ix) * r * pp + M) / Iy,
            ((Ix - Iy) * pp * q + N) / Iz,
        ]
    )


def earth_velocity(posture: Vector, velocity: Vector) -> np.ndarray:
    """Posture rate (x_dot, y_dot, z_dot, phi_dot, theta_dot, psi_dot) = (R v_b, T w_b)."""
    _, _, _, phi, theta, psi = posture
    R = rotation_matrix(phi, theta, psi)
    T = body_rate_to_euler_rate_matrix(phi, theta)
    return np.concatenate([R @ np.asarray(velocity[:3]), T @ np.asarray(velocity[3:])])


def state_derivative(p: RigidBodyParams, state: Vector, wrench: Vector) -> np.ndarray:
    """d/dt of the 12-state (posture, velocity) under a body-frame wrench (f_x, f_y, f_z, L, M, N)
    (biped.spatial's [f; tau] order)."""
    s = check_state(state, 12, "rigid-body state (x, y, z, phi, theta, psi, u, v, w, p, q, r)")
    w = check_state(wrench, 6, "body wrench (f_x, f_y, f_z, L, M, N)")
    return np.concatenate([earth_velocity(s[:6], s[6:]), velocity_growth_rate(p, s[:6], s[6:], w[:3], w[3:])])


def update_rigid_body(p: RigidBodyParams, state: Vector, wrench: Vector, dt: float) -> np.ndarray:
    """One step of the Lisp ``update-rigid-body`` (Euler): posture with the old velocity, then
    velocity with the growth rate (here evaluated at the start of the step). Returns the new
    12-state."""
    d = state_derivative(p, state, wrench)
    return np.asarray(state, dtype=float) + dt * d


def kinetic_energy(p: RigidBodyParams, state: Vector) -> float:
    """1/2 m |v|^2 + 1/2 w' I w [lb ft^2/s^2]."""
    v, w = np.asarray(state[6:9]), np.asarray(state[9:12])
    return 0.5 * p.mass * float(v @ v) + 0.5 * float(w @ (np.asarray(p.inertia) * w))


def angular_momentum_earth(p: RigidBodyParams, state: Vector) -> np.ndarray:
    """Angular momentum about the centre of mass in earth axes, R I w, (3,) [lb ft^2/s]."""
    R = rotation_matrix(*state[3:6])
    return R @ (np.asarray(p.inertia) * np.asarray(state[9:12]))
