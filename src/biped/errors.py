"""The package's exceptions: one base class, one subclass per kind of mistake.

Every message says what is wrong and what would be valid.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any


class BipedError(Exception):
    """Base class of every error raised by biped."""


class ModelError(BipedError, ValueError):
    """A model file or tree that the algorithms cannot use (wrong joint types, unknown names...)."""


class StateError(BipedError, ValueError):
    """A state (qpos, qvel, x0...) of the wrong length or with non-finite entries."""


class SingularityError(BipedError, ArithmeticError):
    """A linear system that has no unique solution (singular 3x3 form, wrench distribution...)."""


class ReachError(BipedError, ValueError):
    """An inverse-kinematics target out of the limb's reach."""


class ScenarioError(BipedError, ValueError):
    """A scenario or command-line parameter that is unknown, of the wrong shape or out of range."""


def unknown_name(kind: str, name: object, valid: Iterable[Any]) -> str:
    """Message for an unknown name, listing the valid ones."""
    valid = sorted(valid)
    return f"unknown {kind} {name!r}; valid {kind}s: {', '.join(map(repr, valid))}"


def first_few(names: Iterable[Any], n: int = 3) -> str:
    """``"a, b, c and 7 more"``: the first ``n`` of ``names``, and how many were left out (a
    message stays one short line however many entries are bad)."""
    names = [str(x) for x in names]
    head = ", ".join(names[:n])
    return head if len(names) <= n else f"{head} and {len(names) - n} more"
