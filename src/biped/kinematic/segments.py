"""The motion primitives of :mod:`biped.kinematic.gaits`: time profiles and the segments (stand,
half step, squat, flight) that map a phase ``s`` in [0, 1] to the pelvis, torso, arm blend and
the feet's targets. The module docstring of :mod:`biped.kinematic.gaits` says how they follow
from B's stepping algorithms."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

DEG = math.pi / 180.0
SIDES = ("left", "right")

#: Height [m] the swing foot's path rises above the landing tread before it moves over it.
STAIR_CLEARANCE = 0.03


# ------------------------------------------------------------------------------------------
# time profiles
# ------------------------------------------------------------------------------------------


def _smooth(s):
    """Minimum-jerk step 10 s^3 - 15 s^4 + 6 s^5 on [0, 1] (zero velocity and acceleration at
    both ends), clipped outside."""
    s = np.clip(s, 0.0, 1.0)
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s))


def _hermite(p0, p1, m0, m1, s):
    """Cubic Hermite between points p0, p1 (3,) with tangents m0, m1 (per unit s); s (n,) -> (n, 3)."""
    s = s[:, None]
    s2, s3 = s * s, s * s * s
    return (2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * m1


def _lerp(a, b, w):
    return a + (b - a) * w


# ------------------------------------------------------------------------------------------
# segments: each maps a phase s in [0, 1] to pelvis, torso, arm blend and foot targets
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Frame:
    """What a segment prescribes at n phases (world frame, m and rad)."""

    pelvis: np.ndarray  # (n, 3) mid-hip point
    pitch: np.ndarray  # (n,) pelvis pitch, forward > 0 (about +y)
    roll: np.ndarray  # (n,) torso roll (about +x)
    lean: np.ndarray  # (n,) torso pitch (about +y)
    arm_w: np.ndarray  # (n,) 0 = B's arm swing rule, 1 = the jump's arm angles
    feet: dict  # side -> ("world", ankle (n, 3)) or ("hip", depth (n,)): foot straight below the hip
    stance: dict  # side -> (n,) bool: the foot bears weight
    swing_s: dict  # side -> (n,) phase of the swing in [0, 1], nan when not swinging


def _hip_y(dims, side):
    return dims.hip_half_width if side == "left" else -dims.hip_half_width


@dataclass(frozen=True)
class _Stand:
    duration: float
    pelvis: np.ndarray
    ankles: dict
    lean: float = 0.0
    arm_w: float = 0.0
    pitch: float = 0.0
    label: str = "stand"

    def evaluate(self, dims, params, s):
        n = s.size
        z = np.zeros(n)
        return _Frame(
            np.tile(self.pelvis, (n, 1)),
            z + self.pitch,
            z,
            z + self.lean,
            z + self.arm_w,
            {sd: ("world", np.tile(self.ankles[sd], (n, 1))) for sd in SIDES},
            {sd: np.ones(n, bool) for sd in SIDES},
            {sd: np.full(n, np.nan) for sd in SIDES},
        )


@dataclass(frozen=True)
class _HalfStep:
    """One foot in stance, the other swinging from ``lift`` to ``land`` (B IV-B-3)."""

    duration: float
    stance_side: str
    p_stance: np.ndarray
    lift: np.ndarray
    land: np.ndarray
    P0: np.ndarray
    V0: np.ndarray
    P1: np.ndarray
    V1: np.ndarray
    bump: float
    lean0: float
    lean1: float
    label: str
    roll_ramp: str = ""  # "in" from standing, "out" to standing: the roll rate is 0 there

    def evaluate(self, dims, params, s):
        n = s.size
        T = self.duration
        pelvis = _hermite(self.P0, self.P1, self.V0 * T, self.V1 * T, s)
        pelvis[:, 2] += self.bump * (1.0 - np.cos(2.0 * np.pi * s))  # eq. 4.22
        sw = "left" if self.stance_side == "right" else "right"
        hip = pelvis + np.array([0.0, _hip_y(dims, sw), 0.0])
        g = np.empty((n, 3))
        g[:, 1] = self.lift[1]
        if self.land[2] - self.lift[2] > 1e-9:
            # stairs: the point rises to STAIR_CLEARANCE above the landing tread, moves forward,
            # then sets down (the foot clears the nosing whatever the run)
            c = STAIR_CLEARANCE
            g[:, 0] = _lerp(self.lift[0], self.land[0], _smooth((s - 0.25) / 0.6))
            g[:, 2] = _lerp(self.lift[2], self.land[2] + c, _smooth(s / 0.4)) - c * _smooth((s - 0.8) / 0.2)
        else:
            w = _smooth(s)
            g[:, 0] = _lerp(self.lift[0], self.land[0], w)
            g[:, 2] = _lerp(self.lift[2], self.land[2], w)
        k = 1.0 - (1.0 - params.swing_factor) * np.sin(np.pi * s) ** 2  # eq. 4.21, continuous
        foot = hip + k[:, None] * (g - hip)
        sign = -1.0 if self.stance_side == "left" else 1.0  # roll toward the stance side
        roll = sign * params.torso_roll * DEG * np.sin(np.pi * s)
        if self.roll_ramp:
            roll = roll * _smooth(s if self.roll_ramp == "in" else 1.0 - s)
        lean = _lerp(self.lean0, self.lean1, _smooth(s))
        z = np.zeros(n)
        swinging = (s > 0.0) & (s < 1.0)
        return _Frame(
            pelvis,
            z,
            roll,
            lean,
            z,
            {self.stance_side: ("world", np.tile(self.p_stance, (n, 1))), sw: ("world", foot)},
            {self.stance_side: np.ones(n, bool), sw: ~swinging},
            {self.stance_side: np.full(n, np.nan), sw: np.where(swinging, s, np.nan)},
        )


@dataclass(frozen=True)
class _Squat:
    """Both feet planted, the pelvis moving straight from P0 to P1 (jump: crouch, up, absorb)."""

    duration: float
    ankles: dict
    P0: np.ndarray
    P1: np.ndarray
    lean0: float
    lean1: float
    w0: float
    w1: float
    label: str

    def evaluate(self, dims, params, s):
        n = s.size
        w = _smooth(s)
        z = np.zeros(n)
        return _Frame(
            self.P0 + (self.P1 - self.P0) * w[:, None],
            z,
            z,
            _lerp(self.lean0, self.lean1, w),
            _lerp(self.w0, self.w1, w),
            {sd: ("world", np.tile(self.ankles[sd], (n, 1))) for sd in SIDES},
            {sd: np.ones(n, bool) for sd in SIDES},
            {sd: np.full(n, np.nan) for sd in SIDES},
        )


@dataclass(frozen=True)
class _Flight:
    """Feet off the ground, straight below the hips at depth ``depth(s)`` in the pelvis frame.

    ``kind`` "arc": the pelvis goes along the upper semicircle from P0 to P1 (same height),
    turning by ``turn`` rad (B's somersault); "drop": straight from P0 to P1.
    """

    duration: float
    kind: str
    P0: np.ndarray
    P1: np.ndarray
    depth0: float
    depth_mid: float
    depth1: float
    turn: float
    lean: float
    label: str

    def evaluate(self, dims, params, s):
        n = s.size
        w = _smooth(s)
        if self.kind == "arc":
            c, r = 0.5 * (self.P0 + self.P1), 0.5 * np.linalg.norm(self.P1 - self.P0)
            psi = np.pi * (1.0 - w)
            pelvis = np.tile(c, (n, 1))
            pelvis[:, 0] += r * np.cos(psi)
            pelvis[:, 2] += r * np.sin(psi)
            # tuck during the first 40 %, hold, re-extend to depth1 during the last 30 %
            depth = np.where(
                s < 0.4,
                _lerp(self.depth0, self.depth_mid, _smooth(s / 0.4)),
                _lerp(self.depth_mid, self.depth1, _smooth((s - 0.7) / 0.3)),
            )
        else:
            pelvis = self.P0 + (self.P1 - self.P0) * w[:, None]
            depth = _lerp(self.depth0, self.depth1, w)
        z = np.zeros(n)
        # the feet leave the ground as the arc starts and touch it as the drop ends
        air = s > 0.0 if self.kind == "arc" else s < 1.0
        return _Frame(
            pelvis,
            self.turn * w,
            z,
            z + self.lean,
            z + 1.0,
            {sd: ("hip", depth) for sd in SIDES},
            {sd: ~air for sd in SIDES},
            {sd: np.where(air, s, np.nan) for sd in SIDES},
        )
