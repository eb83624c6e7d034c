"""Model files shipped with biped.

>>> from biped import models
>>> models.path("wendlandt")        # W's 13-body, 18-DOF biped (de Leva 1996 anthropometry)
"""

from __future__ import annotations

from pathlib import Path

from biped.errors import ModelError, unknown_name

_HERE = Path(__file__).resolve().parent


def names() -> list[str]:
    """Names of the shipped model files."""
    return sorted(p.stem for p in _HERE.glob("*.xml"))


def path(name: str) -> Path:
    """Path of the shipped MJCF file ``name`` (e.g. ``"wendlandt"``)."""
    p = _HERE / f"{name}.xml"
    if not p.is_file():
        raise ModelError(unknown_name("model", name, names()))
    return p
