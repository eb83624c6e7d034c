"""Footprints for the 3D replay: a flat box on the floor where each step landed, shown from its
touchdown on (stepping runs, :mod:`biped.control.stepping`)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

import numpy as np

from biped.errors import BipedError
from biped.viz.replay import Replay, ReplayGeom

__all__ = ["with_footprints"]

#: Footprint boxes are 1 mm thick, lying on the floor; before their touchdown they are kept this
#: far below it (out of sight) [m].
_HALF_THICKNESS_M = 0.0005
_HIDDEN_Z_M = -5.0
_KEYS = ("time_s", "centre_m", "half_length_m", "half_width_m")


def with_footprints(replay: Replay, footprints: Iterable[Mapping]) -> Replay:
    """``replay`` plus one flat orange box on the floor per footprint, shown from its touchdown on.

    Each footprint is a mapping with ``time_s`` (touchdown), ``centre_m`` (x, y[, z]: the sole
    centre; z is ignored, the box lies on the floor z = 0), ``half_length_m``, ``half_width_m``
    (the sole rectangle), optional ``yaw_rad`` (0) and ``name`` (``footprint <k>``). Before
    ``time_s`` the box is 5 m below the floor; from the first frame at or after it, on the floor.
    """
    fps = list(footprints or ())
    if not fps:
        return replay
    geoms, pos, quat = list(replay.geoms), [replay.pos], [replay.quat]
    T = replay.times.size
    for k, fp in enumerate(fps):
        if not isinstance(fp, Mapping) or not set(_KEYS) <= set(fp):
            raise BipedError(f"footprint {k} must be a mapping with keys {', '.join(_KEYS)}; got {fp!r}")
        try:
            t = float(fp["time_s"])
            c = np.asarray(fp["centre_m"], dtype=float).ravel()
            yaw = float(fp.get("yaw_rad", 0.0))
            size = (float(fp["half_length_m"]), float(fp["half_width_m"]), _HALF_THICKNESS_M)
        except (TypeError, ValueError):
            raise BipedError(
                f"footprint {k}: time_s, centre_m, sizes and yaw_rad must be numbers; got {fp!r}"
            ) from None
        if not (math.isfinite(t) and math.isfinite(yaw) and c.size in (2, 3) and np.all(np.isfinite(c))):
            raise BipedError(f"footprint {k}: time_s, centre_m (x, y) and yaw_rad must be finite; got {fp!r}")
        geoms.append(
            ReplayGeom(
                name=str(fp.get("name", f"footprint {k}")), kind="box", size=size, rgba=(1.0, 0.55, 0.1, 1.0)
            )
        )
        p = np.zeros((T, 1, 3))
        p[:, 0, 0], p[:, 0, 1] = c[0], c[1]
        p[:, 0, 2] = np.where(replay.times >= t - 1e-9, _HALF_THICKNESS_M, _HIDDEN_Z_M)
        q = np.zeros((T, 1, 4))
        q[:, 0, 0], q[:, 0, 3] = math.cos(yaw / 2), math.sin(yaw / 2)
        pos.append(p)
        quat.append(q)
    follow = replay.follow_index()
    return Replay(
        geoms=tuple(geoms),
        times=replay.times,
        pos=np.concatenate(pos, axis=1),
        quat=np.concatenate(quat, axis=1),
        title=replay.title,
        info=replay.info,
        markers=replay.markers,
        follow=replay.geoms[follow].name if follow >= 0 else None,
        arrow=replay.arrow,
    )
