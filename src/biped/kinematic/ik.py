"""Inverse kinematics of Bediz's 3-link planar leg (B eq. 4.1-4.19) and his stepping geometry.

The leg of Bediz's kinematic figure "Dynaman" is a planar manipulator of three links: thigh
(``l1``), shank (``l2``) and foot. Its base frame sits at the hip joint:

- ``x`` points down the hanging leg, ``y`` points forward (the walking direction), and planar
  angles are measured from ``x`` toward ``y``; in the world of a figure facing +x with z up this is
  a rotation about -y.
- ``theta1`` is the hip angle (positive = flexion, the thigh swings forward), ``theta2`` the knee
  angle (positive = the shank swings forward relative to the thigh, i.e. *extension*; a human knee
  bends with ``theta2 < 0``), ``theta3`` the ankle angle (positive = dorsiflexion, toes up).
- The end effector is the ankle point, frame 3 of B's Table 1; its orientation ``phi`` is the
  foot's pitch relative to the base frame: ``phi = theta1 + theta2 + theta3`` (eq. 4.8, 4.9), and a
  foot flat on level ground under an upright pelvis has ``phi = 0``.

These are the sign conventions of the project's 3D biped (``left_hip_flexion``, ``left_knee``
positive = extension, ``left_ankle_dorsiflexion``), so the figure's angles drive it unchanged.

Every function takes numpy arrays (broadcast together) or floats; lengths in m, angles in rad.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from biped.errors import ReachError, ScenarioError

__all__ = ["KNEE_BRANCHES", "LegAngles", "bar_foot", "leg_fk", "leg_ik", "stair_angle", "stair_elevation"]

#: Knee-bend branches of eq. 4.13: "human" bends the knee forward (theta2 <= 0, knee point ahead
#: of the hip-ankle line), "reverse" bends it backward (theta2 >= 0, a bird's leg, as B's code
#: ``theta2 = acos(c)`` does in his leg frame).
KNEE_BRANCHES = {"human": -1.0, "reverse": 1.0}


@dataclass(frozen=True)
class LegAngles:
    """Joint angles of the planar leg [rad], arrays of the broadcast target shape.

    Attributes:
        theta1: hip flexion (eq. 4.18).
        theta2: knee, positive = extension (eq. 4.13).
        theta3: ankle dorsiflexion (eq. 4.19).
    """

    theta1: np.ndarray
    theta2: np.ndarray
    theta3: np.ndarray


def leg_fk(
    theta1: ArrayLike, theta2: ArrayLike, theta3: ArrayLike, l1: float, l2: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Forward kinematics of the planar leg, B eq. 4.6 (= 4.8-4.11).

    Args:
        theta1, theta2, theta3: hip, knee, ankle angles [rad] (arrays broadcast together).
        l1, l2: thigh and shank lengths [m].

    Returns:
        ``(x, y, phi)``: ankle position in the hip frame (x down the leg, y forward) [m] and the
        foot pitch ``phi = theta1 + theta2 + theta3`` [rad].
    """
    t1 = np.asarray(theta1, dtype=float)
    t12 = t1 + np.asarray(theta2, dtype=float)
    x = l1 * np.cos(t1) + l2 * np.cos(t12)  # eq. 4.10
    y = l1 * np.sin(t1) + l2 * np.sin(t12)  # eq. 4.11
    return x, y, t12 + np.asarray(theta3, dtype=float)  # eq. 4.8, 4.9


def _check_lengths(l1: float, l2: float) -> None:
    if not (np.isfinite(l1) and np.isfinite(l2) and l1 > 0 and l2 > 0):
        raise ScenarioError(f"leg link lengths must be finite and positive (m), got l1={l1!r}, l2={l2!r}")


def leg_ik(
    x: ArrayLike, y: ArrayLike, phi: ArrayLike, l1: float, l2: float, knee: str = "human", tol: float = 1e-12
) -> LegAngles:
    """Inverse kinematics of the 3-link planar leg, B eq. 4.12-4.19.

    eq. 4.12-4.13: ``cos theta2 = (x^2 + y^2 - l1^2 - l2^2) / (2 l1 l2)``, with the knee-bend
    branch chosen explicitly: ``theta2 = s acos(.)`` with ``s = -1`` ("human") or ``+1``
    ("reverse"). eq. 4.16-4.18: ``k1 = l1 + l2 cos theta2``, ``k2 = l2 sin theta2``,
    ``theta1 = atan2(y, x) - atan2(k2, k1)`` (B writes ``atan(y/x)``, which is the same for the
    hanging leg, ``x > 0``, and wrong otherwise). eq. 4.19: ``theta3 = phi - theta1 - theta2``.

    Args:
        x, y: ankle position in the hip frame [m] (x down the leg, y forward).
        phi: foot pitch in the hip frame [rad] (0 = flat under an upright pelvis).
        l1, l2: thigh and shank lengths [m].
        knee: "human" or "reverse" (see :data:`KNEE_BRANCHES`).
        tol: targets out of reach by at most ``tol`` m are clamped onto the boundary (rounding).

    Returns:
        :class:`LegAngles` of the broadcast shape of ``x, y, phi``.

    Raises:
        ReachError: a target farther than ``l1 + l2`` or nearer than ``|l1 - l2|`` from the hip;
            the message gives the first such target, its distance and the reachable interval.
        ScenarioError: unknown ``knee`` branch or non-positive lengths.
    """
    _check_lengths(l1, l2)
    if knee not in KNEE_BRANCHES:
        raise ScenarioError(
            f"unknown knee branch {knee!r}; valid branches: {', '.join(map(repr, KNEE_BRANCHES))}"
        )
    x, y, phi = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, phi)))
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y)) and np.all(np.isfinite(phi))):
        raise ReachError("inverse kinematics target contains NaN or infinite entries")
    d = np.hypot(x, y)
    reach_max, reach_min = l1 + l2, abs(l1 - l2)
    bad = (d > reach_max + tol) | (d < reach_min - tol)
    if np.any(bad):
        k = np.unravel_index(int(np.argmax(bad)), bad.shape)
        where = f" (target index {tuple(int(i) for i in k)})" if bad.ndim else ""
        raise ReachError(
            f"leg target ({x[k]:.6g}, {y[k]:.6g}) m is {d[k]:.6g} m from the hip{where}; the leg "
            f"(l1={l1:.6g} m, l2={l2:.6g} m) reaches distances in [{reach_min:.6g}, {reach_max:.6g}] m"
        )
    c2 = np.clip((x * x + y * y - l1 * l1 - l2 * l2) / (2.0 * l1 * l2), -1.0, 1.0)  # eq. 4.13
    theta2 = KNEE_BRANCHES[knee] * np.arccos(c2)
    k1 = l1 + l2 * np.cos(theta2)  # eq. 4.16
    k2 = l2 * np.sin(theta2)  # eq. 4.17
    theta1 = np.arctan2(y, x) - np.arctan2(k2, k1)  # eq. 4.18
    theta3 = phi - theta1 - theta2  # eq. 4.19
    return LegAngles(theta1, theta2, theta3)


def bar_foot(alpha: ArrayLike, P1: float, k: ArrayLike = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """The ankle on B's "swinging bar" of the stepping-forward algorithm, B eq. 4.20-4.21.

    A straight leg of length ``P1 = l1 + l2`` at angle ``alpha`` from the vertical is shortened to
    ``P2 = P1 cos(alpha)`` (eq. 4.20; the knee bends more as ``|alpha|`` grows); the recovery
    (swing) leg uses ``P3 = k P2`` with ``k = 0.95`` (eq. 4.21). Returns the ankle ``(x, y)`` in
    the hip frame: ``k P1 cos(alpha) (cos alpha, sin alpha)`` [m]. For ``k = 1`` the ankle lies on
    the circle of diameter ``P1`` through the hip (Thales), at depth ``P1 cos^2(alpha)``.
    """
    a = np.asarray(alpha, dtype=float)
    p = np.asarray(k, dtype=float) * P1 * np.cos(a)
    return p * np.cos(a), p * np.sin(a)


def stair_elevation(beta: ArrayLike, l1: float, l2: float) -> np.ndarray:
    """Elevation a straight leg gains when swung forward by ``beta``, B eq. 4.23 [m].

    ``h = (l1 + l2) - (l1 + l2) cos(beta)``: the height of the stair a straight leg at angle
    ``beta`` from the vertical reaches. B's stairs rise 0.267949 = 2 (1 - cos 30 deg) units
    (``l1 = l2 = 1``): his step-up angle is 30 deg.
    """
    _check_lengths(l1, l2)
    return (l1 + l2) * (1.0 - np.cos(np.asarray(beta, dtype=float)))


def stair_angle(rise: ArrayLike, l1: float, l2: float) -> np.ndarray:
    """Inverse of :func:`stair_elevation`: the angle ``beta`` [rad] at which a straight leg of
    length ``l1 + l2`` reaches a stair ``rise`` m high (B eq. 4.23 solved for ``beta``)."""
    _check_lengths(l1, l2)
    r = np.asarray(rise, dtype=float)
    if np.any(r < 0) or np.any(r > l1 + l2):
        raise ScenarioError(f"stair rise must be in [0, l1 + l2] = [0, {l1 + l2:.6g}] m, got {rise!r}")
    return np.arccos(1.0 - r / (l1 + l2))
