"""JSON as every run writes it: strict (no NaN / Infinity, which JSON does not have), atomic
(:mod:`biped.files`: a temporary file moved into place, never written through a link).

A non-finite float (a quantity that does not exist for this run, e.g. the centre of pressure of a
foot in the air, or an error of a run that stopped before its first row) is written as ``null``.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from biped.files import write_text

__all__ = ["finite_json", "write_json"]


def finite_json(obj):
    """``obj`` with numpy values made plain and every non-finite float replaced by None
    (recursively through dicts, lists, tuples, arrays and dataclasses)."""
    if isinstance(obj, dict):
        return {str(k): finite_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite_json(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return finite_json(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, complex):
        return [finite_json(obj.real), finite_json(obj.imag)]
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return finite_json(dataclasses.asdict(obj))
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path: str | Path, obj) -> Path:
    """Write ``obj`` (see :func:`finite_json`) to ``path`` as strict JSON, atomically (a
    temporary file moved over it, :func:`biped.files.write_text`). Raises TypeError for an object JSON cannot hold."""
    path = Path(path)
    text = json.dumps(finite_json(obj), indent=2, allow_nan=False) + "\n"
    write_text(path, text)
    return path
