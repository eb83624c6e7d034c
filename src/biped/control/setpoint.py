"""W's set point and gains (W Alg. 4 inputs): :class:`Target` and :class:`Gains`, with W section 4's
values. World frame, SI units; the orientation is a unit quaternion (w, x, y, z)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from biped.errors import ScenarioError
from biped.spatial import axis_angle_quat

__all__ = [
    "TARGET_AXES",
    "W_TARGET_AXIS",
    "W_TARGET_COM_M",
    "W_TARGET_TILT_DEG",
    "Gains",
    "Target",
    "replaced",
]

_AXES = {"-y": (0.0, -1.0, 0.0), "-x": (-1.0, 0.0, 0.0)}
#: Axes of the desired tilt: "-y" is W's text, "-x" the quaternion W prints (docs/controller.md).
TARGET_AXES = tuple(_AXES)
#: W section 4's set point: central-body COM [m], tilt [deg] about W_TARGET_AXIS.
W_TARGET_COM_M = (-0.01, 0.0, 1.14)
W_TARGET_TILT_DEG = 15.0
W_TARGET_AXIS = "-y"


def checked_vector(name: str, value, n: int) -> np.ndarray:
    """``value`` as a float array of ``n`` finite entries, else a one-line ScenarioError naming ``name``."""
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.shape != (n,):
        raise ScenarioError(f"{name} must have {n} entries, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise ScenarioError(f"{name} must be finite, got {arr.tolist()}")
    return arr


@dataclass(frozen=True)
class Target:
    """Desired motion of the central body's COM frame (W Alg. 4 inputs), world frame, SI units.

    com, com_vel, com_acc: (3,) position [m], velocity [m/s], acceleration [m/s^2] of the COM.
    quat: (4,) desired orientation ``q_{0,d}`` (w, x, y, z) of the COM principal frame.
    ang_vel, ang_acc: (3,) desired angular velocity / acceleration in the space frame.
    """

    com: tuple = W_TARGET_COM_M
    com_vel: tuple = (0.0, 0.0, 0.0)
    com_acc: tuple = (0.0, 0.0, 0.0)
    quat: tuple = tuple(axis_angle_quat(_AXES[W_TARGET_AXIS], np.radians(W_TARGET_TILT_DEG)))
    ang_vel: tuple = (0.0, 0.0, 0.0)
    ang_acc: tuple = (0.0, 0.0, 0.0)
    array: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        q = checked_vector("target quat", self.quat, 4)
        norm = math.hypot(*q)  # scaled: no overflow warning for 1e308 entries (inf beyond)
        if abs(norm - 1.0) > 1e-6:
            raise ScenarioError(f"target quat must be a unit quaternion (w, x, y, z); its norm is {norm:.9g}")
        arr = np.concatenate(
            [
                checked_vector("target com", self.com, 3),
                checked_vector("target com_vel", self.com_vel, 3),
                checked_vector("target com_acc", self.com_acc, 3),
                q,
                checked_vector("target ang_vel", self.ang_vel, 3),
                checked_vector("target ang_acc", self.ang_acc, 3),
            ]
        )
        object.__setattr__(self, "array", arr)

    @classmethod
    def wendlandt(
        cls, com=W_TARGET_COM_M, tilt_deg: float = W_TARGET_TILT_DEG, axis: str = W_TARGET_AXIS
    ) -> Target:
        """W's set point: COM (-1, 0, 114) cm, 15 deg about -y (text) or -x (the printed quaternion
        (0.99144486, -0.13052619, 0, 0)); see docs/controller.md."""
        if axis not in _AXES:
            raise ScenarioError(f"unknown target axis {axis!r}; valid: {sorted(_AXES)}")
        return cls(com=tuple(com), quat=tuple(axis_angle_quat(_AXES[axis], np.radians(tilt_deg))))


#: Each vector field of :class:`Target` but the quaternion, and its slice of ``Target.array``.
_TARGET_SLICES = {
    "com": (0, 3),
    "com_vel": (3, 6),
    "com_acc": (6, 9),
    "ang_vel": (13, 16),
    "ang_acc": (16, 19),
}


def replaced(target: Target, **changes) -> Target:
    """``dataclasses.replace(target, **changes)`` for a hot path (the stepping controller's swing
    builds a set point every control period): the same Target, its ``array`` equal bit for bit,
    without the dataclass's re-validation of the fields not changed. Each changed field must be
    one of :data:`_TARGET_SLICES` (not the quaternion), a tuple or list of 3 finite numbers, else
    the dataclass's own ``replace`` does it (and raises its one-line error)."""
    vals = {}
    for name, value in changes.items():
        if (
            name not in _TARGET_SLICES
            or not isinstance(value, (tuple, list))
            or len(value) != 3
            or not all(isinstance(x, (float, int)) and math.isfinite(x) for x in value)
        ):
            return replace(target, **changes)
        vals[name] = value
    out = object.__new__(Target)
    out.__dict__.update(target.__dict__)
    arr = target.array.copy()
    for name, value in vals.items():
        a, b = _TARGET_SLICES[name]
        arr[a:b] = value
        out.__dict__[name] = value
    out.__dict__["array"] = arr
    return out


@dataclass(frozen=True)
class Gains:
    """Diagonals of W's gain matrices K_c^p, K_c^v (COM) and K_R^p, K_R^v (orientation) [1/s^2, 1/s]."""

    kp_com: tuple = (50.0, 50.0, 200.0)
    kv_com: tuple = (7.07, 7.07, 14.142)
    kp_rot: tuple = (50.0, 50.0, 50.0)
    kv_rot: tuple = (7.07, 7.07, 7.07)
    array: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        arr = np.concatenate(
            [
                checked_vector(f"gains {n}", getattr(self, n), 3)
                for n in ("kp_com", "kv_com", "kp_rot", "kv_rot")
            ]
        )
        object.__setattr__(self, "array", arr)

    @classmethod
    def wendlandt(cls) -> Gains:
        """W section 4's gains."""
        return cls()
