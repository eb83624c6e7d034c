"""Model files shipped with biped, and the constants of W's biped that every layer shares.

>>> from biped import models
>>> models.path("wendlandt").name   # W's 13-body, 18-DOF biped (de Leva 1996 anthropometry)
'wendlandt.xml'
>>> models.JOINT_NAMES[:2]          # its 12 hinges in W's order theta_2..theta_13
('left_hip_abduction', 'left_hip_flexion')
>>> round(models.total_mass_kg(), 2)  # [kg], read from the MJCF
73.06

The joint names and W's initial state are defined here once: :mod:`biped.models.anthropometry`
writes them into ``wendlandt.xml`` (hinge names, keyframe ``wendlandt_initial``), and the
controllers, the scenario and the figures import them from here. Quantities the MJCF defines
(gravity, masses) are read from the compiled model, never restated.
"""

from __future__ import annotations

import functools
from pathlib import Path

import mujoco
import numpy as np

from biped.errors import ModelError, unknown_name

_HERE = Path(__file__).resolve().parent

#: W's joint order within a leg (theta_2..theta_7 left, theta_8..theta_13 right): the shipped
#: model's hinge names without the side prefix.
LEG_JOINTS = ("hip_abduction", "hip_flexion", "hip_rotation", "knee", "ankle_inversion", "ankle_dorsiflexion")
#: The 12 hinges of W's biped in W's order theta_2..theta_13: left leg, then right leg.
JOINT_NAMES = tuple(f"{side}_{j}" for side in ("left", "right") for j in LEG_JOINTS)

#: W section 4: initial joint angles theta_2..theta_13 [deg], :data:`JOINT_NAMES` order
#: (40 - 77.4595 + 42.4595 = 5 deg: the feet flat under the 5 deg body tilt).
W_INITIAL_ANGLES_DEG = (0.0, 40.0, 0.0, -77.4595, 0.0, 42.4595) * 2
#: W section 4: initial position of the central body's COM [m] and its tilt about -y [deg].
W_INITIAL_COM_M = (0.0, 0.0, 1.035)
W_INITIAL_TILT_DEG = 5.0


def names() -> list[str]:
    """Names of the shipped model files."""
    return sorted(p.stem for p in _HERE.glob("*.xml"))


def path(name: str) -> Path:
    """Path of the shipped MJCF file ``name`` (e.g. ``"wendlandt"``)."""
    p = _HERE / f"{name}.xml"
    if not p.is_file():
        raise ModelError(unknown_name("model", name, names()))
    return p


@functools.cache
def _compiled(name: str) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(path(name)))


def compiled_sha256(model_file: str | Path) -> str:
    """SHA-256 of the model as MuJoCo compiles it (``mj_saveModel``'s binary: every included
    file, mesh, default and compiler setting folded in), not of the top-level file's bytes. The
    same file gives the same hash with the same MuJoCo version."""
    import hashlib

    m = mujoco.MjModel.from_xml_path(str(model_file))
    buf = np.zeros(mujoco.mj_sizeModel(m), dtype=np.uint8)
    mujoco.mj_saveModel(m, None, buf)
    return hashlib.sha256(buf.tobytes()).hexdigest()


def gravity(name: str = "wendlandt") -> np.ndarray:
    """(3,) gravity [m/s^2], world frame, of the shipped model ``name`` (its ``<option>``)."""
    return _compiled(name).opt.gravity.copy()


def total_mass_kg(name: str | Path = "wendlandt") -> float:
    """Total mass [kg] of the biped ``name``, a shipped model's name or a checked MJCF path (a
    scenario's ``model``): the sum of its bodies' masses as MuJoCo compiles them."""
    if isinstance(name, str) and name in names():
        return float(np.sum(_compiled(name).body_mass))
    from biped.models.subject import resolve

    return float(np.sum(mujoco.MjModel.from_xml_path(str(resolve(name))).body_mass))


__all__ = [
    "compiled_sha256",
    "JOINT_NAMES",
    "LEG_JOINTS",
    "W_INITIAL_ANGLES_DEG",
    "W_INITIAL_COM_M",
    "W_INITIAL_TILT_DEG",
    "gravity",
    "names",
    "path",
    "total_mass_kg",
]
