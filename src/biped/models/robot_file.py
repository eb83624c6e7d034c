"""A robot described explicitly, when :func:`biped.models.robot.describe`'s detection cannot (or
should not) guess: a small TOML file, ``--model my_robot.toml`` (docs/robots.md)::

    mjcf = "robot.xml"                      # the robot's MJCF, relative to this file
    feet = ["left_foot", "right_foot"]      # (left, right) foot bodies
    leg_joints = ["l_hip_z", "...", "..."]  # optional: the 12 leg hinges, left leg then right,
                                            # hip to ankle (checked against the feet's chains)
    keyframe = "stand"                      # optional: the standing pose (default: the first)

Every key is checked before any work; a bad one is a one-line :class:`~biped.errors.ModelError`
naming the file, the key and what is valid.
"""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

from biped.errors import ModelError
from biped.models.robot import LEG_HINGES, RobotDescription, describe

#: The keys of a robot file (``mjcf`` and ``feet`` required).
KEYS = ("mjcf", "feet", "leg_joints", "keyframe")
#: The largest robot file read [bytes] (a description is a few lines).
MAX_BYTES = 65536


def _strings(path: Path, key: str, value: object, n: int) -> list[str]:
    if not (isinstance(value, list) and len(value) == n and all(isinstance(v, str) and v for v in value)):
        raise ModelError(f"robot file {str(path)!r}: {key} must be a list of {n} names; got {value!r}")
    return list(value)


def read_robot_file(path: str | Path) -> RobotDescription:
    """The robot the TOML file ``path`` describes (see the module), its legs checked."""
    path = Path(path)
    if not path.is_file():
        raise ModelError(f"robot file {str(path)!r} does not exist")
    raw = path.read_bytes()
    if len(raw) > MAX_BYTES:
        raise ModelError(f"robot file {str(path)!r} is {len(raw)} bytes; a robot file is at most {MAX_BYTES}")
    try:
        values = tomllib.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ModelError(f"robot file {str(path)!r} is not UTF-8 TOML: {exc}") from None
    unknown = sorted(set(values) - set(KEYS))
    if unknown:
        raise ModelError(
            f"robot file {str(path)!r}: unknown key {unknown[0]!r}; valid keys: {', '.join(KEYS)}"
        )
    for key in ("mjcf", "feet"):
        if key not in values:
            raise ModelError(f"robot file {str(path)!r}: {key!r} is missing (required: mjcf, feet)")
    mjcf = values["mjcf"]
    if not isinstance(mjcf, str) or not mjcf:
        raise ModelError(f"robot file {str(path)!r}: mjcf must be the path of the robot's MJCF; got {mjcf!r}")
    xml = (path.parent / mjcf).resolve()
    if not xml.is_file():
        raise ModelError(f"robot file {str(path)!r}: mjcf {str(xml)!r} does not exist (relative to the file)")
    left, right = _strings(path, "feet", values["feet"], 2)
    keyframe = values.get("keyframe")
    if keyframe is not None and (not isinstance(keyframe, str) or not keyframe):
        raise ModelError(f"robot file {str(path)!r}: keyframe must be a keyframe's name; got {keyframe!r}")
    try:
        desc = describe(xml, feet=(left, right), keyframe=keyframe)
    except ModelError as exc:
        raise ModelError(f"robot file {str(path)!r}: {exc}") from None
    if desc.feet != (left, right):
        raise ModelError(
            f"robot file {str(path)!r}: feet are (left, right); {left!r} is on the robot's right at the "
            f"keyframe (y in the floating body's frame): write feet = [{right!r}, {left!r}]"
        )
    if "leg_joints" in values:
        legs = _strings(path, "leg_joints", values["leg_joints"], 2 * LEG_HINGES)
        if tuple(legs) != desc.leg_joints:
            wrong = next(i for i, (a, b) in enumerate(zip(legs, desc.leg_joints, strict=True)) if a != b)
            raise ModelError(
                f"robot file {str(path)!r}: leg_joints[{wrong}] is {legs[wrong]!r}, but the hinges from the "
                f"legs' common body to the feet, left leg then right, hip to ankle, are "
                f"{list(desc.leg_joints)}"
            )
    return dataclasses.replace(desc, source=str(path.resolve()))
