"""``trajectory.csv`` of a push run and its column dictionary (``columns.json``): one row per
control period, SI units, world frame; floats in their shortest round-trip form, so equal runs
give byte-identical files."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from biped import files
from biped.sim.contact import SOLE_GEOMS
from biped.sim.measure import FEET, RowMeasurements, measure_rows
from biped.sim.push import PushResult
from biped.sim.scene import Scene, build_scene

__all__ = ["column_dictionary", "trajectory_columns", "write_trajectory_csv"]


def _fmt(x: float) -> str:
    x = float(x)
    return repr(x) if math.isfinite(x) else ""  # empty: the quantity does not exist at this row


def column_dictionary(joint_names) -> dict[str, dict[str, str]]:
    """``{column: {"unit": ..., "meaning": ...}}`` of trajectory.csv, in column order (world
    frame: z up, the biped faces -x at the start; every row at exactly its ``time``)."""
    cols: list[tuple[str, str, str]] = [("time", "s", "time of the row (one row per control period)")]
    xyz = "xyz"
    cols += [
        (
            f"central_body_com_{a}",
            "m",
            (f"central body's COM (head, arms and trunk: W's body 1, the controlled body), world {a}"),
        )
        for a in xyz
    ]
    cols += [(f"central_body_vel_{a}", "m/s", f"central body's COM velocity, world {a}") for a in xyz]
    cols += [
        (f"central_body_angvel_{a}", "rad/s", f"central body's angular velocity, world {a}") for a in xyz
    ]
    cols += [(f"quat_{a}", "1", f"central body's orientation quaternion (w, x, y, z), {a}") for a in "wxyz"]
    cols += [
        (f"whole_body_com_{a}", "m", f"the biped's whole-body COM (block excluded), world {a}") for a in xyz
    ]
    cols += [(f"whole_body_com_vel_{a}", "m/s", f"whole-body COM velocity, world {a}") for a in xyz]
    cols += [(f"q_{n}", "rad", f"joint angle {n}") for n in joint_names]
    cols += [(f"tau_{n}", "N m", f"torque at {n}, held from this row to the next") for n in joint_names]
    for foot in FEET:
        cols += [(f"{foot}_foot_{a}", "m", f"{foot} foot frame origin (the ankle), world {a}") for a in xyz]
        cols += [
            (f"{foot}_foot_quat_{a}", "1", f"{foot} foot orientation quaternion (w, x, y, z), {a}")
            for a in "wxyz"
        ]
    for foot in FEET:
        cols += [
            (
                f"{foot}_grf_{a}",
                "N",
                (
                    f"force of the floor on the {foot} foot (sum of MuJoCo's "
                    f"contact forces, mj_contactForce), world {a}"
                ),
            )
            for a in xyz
        ]
        cols += [
            (
                f"{foot}_cop_{a}",
                "m",
                (
                    f"{foot} foot's centre of pressure on the floor plane, "
                    f"world {a} (empty when the foot carries no load)"
                ),
            )
            for a in "xy"
        ]
    cols += [(f"block_{a}", "m", f"block centre, world {a}") for a in xyz]
    cols += [(f"block_vel_{a}", "m/s", f"block velocity, world {a}") for a in xyz]
    cols += [("block_contact", "0/1", "the block touches the biped")]
    cols += [
        ("left_contact", "0/1", "the left heel or toe touches the floor"),
        ("right_contact", "0/1", "the right heel or toe touches the floor"),
    ]
    cols += [
        (f"{foot}_{part}_contact", "0/1", f"the {foot} {part} box touches the floor")
        for foot, part in SOLE_GEOMS
    ]
    return {name: {"unit": unit, "meaning": meaning} for name, unit, meaning in cols}


def trajectory_columns(joint_names) -> list[str]:
    """The column names of trajectory.csv (see :func:`column_dictionary`)."""
    return list(column_dictionary(joint_names))


def write_trajectory_csv(
    result: PushResult, path: str | Path, *, rows: RowMeasurements | None = None, scene: Scene | None = None
) -> Path:
    """``trajectory.csv``: one row per control period, the columns of :func:`column_dictionary`
    (SI units, world frame). The per-row whole-body and contact quantities come from
    :func:`biped.sim.measure.measure_rows` (``rows``; computed on ``scene`` when not given).
    Floats are written with ``repr`` (shortest round-trip form), so equal runs give
    byte-identical files; a quantity that does not exist at a row (a CoP without load) is empty."""
    path = Path(path)
    if rows is None:
        rows = measure_rows(scene or build_scene(result.scenario), result)
    lines = [",".join(trajectory_columns(result.joint_names))]
    lc, rc = result.left_contact, result.right_contact
    n = len(result.times)
    feet_pos = result.feet_pos if result.feet_pos is not None else np.full((n, 2, 3), np.nan)
    feet_quat = result.feet_quat if result.feet_quat is not None else np.full((n, 2, 4), np.nan)
    bvel = result.block_velocity if result.block_velocity is not None else np.full((n, 3), np.nan)
    for k in range(n):
        vals = [
            _fmt(result.times[k]),
            *map(_fmt, rows.central_body_com[k]),
            *map(_fmt, rows.central_body_com_vel[k]),
            *map(_fmt, rows.central_body_angvel[k]),
            *map(_fmt, result.quat[k]),
            *map(_fmt, rows.whole_body_com[k]),
            *map(_fmt, rows.whole_body_com_vel[k]),
            *map(_fmt, result.joint_angles[k]),
            *map(_fmt, result.torques[k]),
        ]
        for i in range(2):
            vals += [*map(_fmt, feet_pos[k, i]), *map(_fmt, feet_quat[k, i])]
        for i in range(2):
            vals += [*map(_fmt, rows.grf[k, i]), *map(_fmt, rows.cop[k, i])]
        vals += [
            *map(_fmt, result.block[k]),
            *map(_fmt, bvel[k]),
            str(int(rows.block_touches_biped[k])),
            str(int(lc[k])),
            str(int(rc[k])),
            *(str(int(c)) for c in result.contacts[k]),
        ]
        lines.append(",".join(vals))
    files.write_text(path, "\n".join(lines) + "\n")
    return path
