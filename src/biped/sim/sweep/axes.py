"""A sweep's axes: their names, W's throw as the default of each, and the values an axis takes
(a number, a list, ``{start, stop, num}`` or the command line's ``START:STOP:NUM``), checked.
Pure Python (no MuJoCo)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from biped.errors import ScenarioError

#: The swept quantities: name -> (unit, what it means).
AXES: dict[str, str] = {
    "speed_m_s": "horizontal block speed [m/s]",
    "direction_deg": "direction the block travels, from +x toward +y [deg]",
    "block_mass_kg": "block mass [kg]",
    "height_m": "height of the block's aim point above the floor [m]",
    "gain_scale": "factor s on the stiffness gains (kp * s) and sqrt(s) on the damping gains "
    "(kv * sqrt(s)), which keeps every damping ratio",
    "magnitude": "the perturbation's size in its own unit: force N (peak), platform m, release deg "
    "(the block's is speed_m_s; scenario key perturbation, docs/perturbations.md)",
}

#: W's throw (section 4) in sweep coordinates: 1.8 kg at 4.5 m/s along -x, 1.2 m high.
W_THROW = {
    "speed_m_s": 4.5,
    "direction_deg": 180.0,
    "block_mass_kg": 1.8,
    "height_m": 1.2,
    "gain_scale": 1.0,
    "magnitude": 0.0,  # unused by the block; another paradigm's default: its base scenario's size
}
#: The axes a block sweep's trial keys hash (those before the paradigms existed: its keys stay).
BLOCK_AXES = ("speed_m_s", "direction_deg", "block_mass_kg", "height_m", "gain_scale")

#: Axis values are kept to this many significant digits, so that ``1:2:11`` and the same values
#: typed as a list (1.7, not 1.7000000000000002) are the same trials; two sweeps' values are the
#: same when they agree to :data:`GRID_RTOL` (relative).
AXIS_DIGITS = 12
GRID_RTOL = 1e-9

#: The most trials one sweep may hold (a grid's product or ``samples``): a bound on the work and
#: the memory asked for by a typo such as ``num = 100000000``. Split larger studies into sweeps.
MAX_TRIALS = 1_000_000


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def _axis_values(name: str, value: Any) -> tuple[float, ...]:
    if name not in AXES:
        raise ScenarioError(f"unknown sweep axis {name!r}; valid axes: {', '.join(AXES)}")
    if isinstance(value, Mapping):
        value = linspace_spec(name, value)
    if _is_number(value):
        value = (value,)
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        raise ScenarioError(
            f"sweep axis {name} ({AXES[name]}) must be a number, a list of numbers "
            f"or {{start, stop, num}}; got {value!r}"
        )
    out = []
    for v in value:
        if not _is_number(v) or not math.isfinite(float(v)):
            raise ScenarioError(f"sweep axis {name} ({AXES[name]}) must hold finite numbers; got {v!r}")
        out.append(float(f"{float(v):.{AXIS_DIGITS}g}"))
        if len(out) > MAX_TRIALS:
            raise ScenarioError(
                f"sweep axis {name} has more than {MAX_TRIALS} values (the most a sweep may hold)"
            )
    if not out:
        raise ScenarioError(f"sweep axis {name} ({AXES[name]}) is empty; give at least one value")
    lo = min(out)
    if name == "direction_deg" and max(abs(lo), abs(max(out))) > 360:
        bad = lo if abs(lo) > 360 else max(out)
        raise ScenarioError(f"sweep axis {name} ({AXES[name]}) must be in [-360, 360] deg; got {bad:g}")
    if name in ("speed_m_s", "block_mass_kg", "height_m", "gain_scale") and lo <= 0:
        raise ScenarioError(f"sweep axis {name} ({AXES[name]}) must be > 0; got {lo:g}")
    if name == "magnitude" and lo < 0:
        raise ScenarioError(f"sweep axis {name} ({AXES[name]}) must be >= 0; got {lo:g}")
    return tuple(out)


def linspace_spec(name: str, value: Mapping) -> tuple[float, ...]:
    """``{start, stop, num}`` -> ``num`` evenly spaced values from start to stop, both included."""
    keys = {"start", "stop", "num"}
    if set(value) != keys:
        raise ScenarioError(
            f"sweep axis {name}: a range needs exactly the keys start, stop, num; "
            f"got {sorted(map(str, value))}"
        )
    num = value["num"]
    if not isinstance(num, (int, np.integer)) or isinstance(num, bool) or num < 1:
        raise ScenarioError(f"sweep axis {name}: num must be an integer >= 1; got {num!r}")
    if num > MAX_TRIALS:
        raise ScenarioError(
            f"sweep axis {name}: num = {num} is more than {MAX_TRIALS} (the most trials a sweep may hold)"
        )
    for k in ("start", "stop"):
        if not _is_number(value[k]) or not math.isfinite(float(value[k])):
            raise ScenarioError(f"sweep axis {name}: {k} must be a finite number; got {value[k]!r}")
    return tuple(float(x) for x in np.linspace(float(value["start"]), float(value["stop"]), int(num)))


def parse_axis(name: str, text: str) -> tuple[float, ...]:
    """Command-line axis syntax: ``4.5``, ``1,2,4`` or ``START:STOP:NUM`` (both ends included)."""
    text = text.strip()
    try:
        if ":" in text:
            parts = text.split(":")
            if len(parts) != 3:
                raise ValueError
            return _axis_values(
                name, {"start": float(parts[0]), "stop": float(parts[1]), "num": int(parts[2])}
            )
        return _axis_values(name, [float(p) for p in text.split(",") if p.strip()])
    except ScenarioError:  # a number that is out of range: say so (it is also a ValueError)
        raise
    except ValueError:
        raise ScenarioError(
            f"sweep axis {name} ({AXES[name]}): expected a number, a comma list "
            f"such as 1,2,4 or START:STOP:NUM such as 0:315:8; got {text!r}"
        ) from None


def _check_int(name: str, value: Any, lo: int) -> None:
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < lo:
        raise ScenarioError(f"{name} must be an integer >= {lo}; got {value!r}")


__all__ = [
    "AXES",
    "AXIS_DIGITS",
    "BLOCK_AXES",
    "GRID_RTOL",
    "MAX_TRIALS",
    "W_THROW",
    "linspace_spec",
    "parse_axis",
]
