"""Input checks shared by the planar models: finite states, positive parameters, 3x3 solves."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from biped.errors import ScenarioError, SingularityError, StateError, unknown_name

#: a state, input or parameter vector: an array or a sequence of floats
Vector = np.ndarray | Sequence[float]


def check_state(x: ArrayLike, n: int, what: str = "state") -> np.ndarray:
    """Return ``x`` as a float array of shape (n,), or raise StateError naming the problem."""
    arr = np.asarray(x, dtype=float)
    if arr.shape != (n,):
        raise StateError(f"{what} must have shape ({n},), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise StateError(f"{what} must be finite, got {arr.tolist()}")
    return arr


def check_finite(name: str, value: float) -> float:
    """A finite float, or StateError."""
    value = float(value)
    if not math.isfinite(value):
        raise StateError(f"{name} must be finite, got {value!r}")
    return value


def check_positive(name: str, value: float, *, allow_zero: bool = False) -> float:
    """A finite float > 0 (>= 0 if allow_zero), or ScenarioError naming the parameter."""
    value = float(value)
    ok = math.isfinite(value) and (value >= 0.0 if allow_zero else value > 0.0)
    if not ok:
        bound = ">= 0" if allow_zero else "> 0"
        raise ScenarioError(f"parameter {name} must be finite and {bound}, got {value!r}")
    return value


def check_choice(kind: str, name: str, valid: Iterable[str]) -> str:
    """``name`` if it is one of ``valid``, else ScenarioError listing the valid names."""
    if name not in valid:
        raise ScenarioError(unknown_name(kind, name, valid))
    return name


def solve3(a: np.ndarray, b: np.ndarray, what: str, rtol: float = 1e-12) -> np.ndarray:
    """Solve the 3x3 (or NxN) system ``a y = b``; SingularityError if ``a`` is singular.

    Singular means |det a| below ``rtol`` times Hadamard's bound (the product of the row norms),
    a scale-free test.
    """
    det = np.linalg.det(a)
    bound = float(np.prod(np.linalg.norm(a, axis=1)))
    if not abs(det) > rtol * bound:
        raise SingularityError(
            f"the {what} matrix is singular here (det = {det:.3g}, Hadamard bound {bound:.3g}); "
            "no unique accelerations and constraint forces exist for this configuration "
            "and these parameters"
        )
    return np.linalg.solve(a, b)
