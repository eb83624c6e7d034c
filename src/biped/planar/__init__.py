"""Bediz's planar postural models (NPS thesis, 1997): the single-link inverted pendulum, the body
on a massless leg, McGhee's 6-DOF rigid body, their integrators, linear analysis and gain design.

Modules: ``pendulum`` (eq. 2.9, 2.10, 2.27, 4.30), ``body_leg`` (eq. 3.18, 3.24, 3.42, 3.47-3.54),
``rigid_body`` (Appendix A, eq. 4.24, 4.25), ``symbolic`` (sympy.physics.mechanics derivations),
``integrators`` (eq. 4.26-4.29, RK4, adaptive), ``analysis`` (eq. 3.55-3.80, pole placement, LQR,
local gain search, stability map), ``runs`` (B's closed-loop runs). Units are B's own: lb used as
a mass, ft, s.
"""

from biped.planar.body_leg import BodyLegParams
from biped.planar.pendulum import PendulumParams
from biped.planar.rigid_body import RigidBodyParams
from biped.planar.runs import LocalFeedback, Trajectory, simulate_body_leg, simulate_pendulum

__all__ = [
    "BodyLegParams",
    "LocalFeedback",
    "PendulumParams",
    "RigidBodyParams",
    "Trajectory",
    "simulate_body_leg",
    "simulate_pendulum",
]
