"""Footprints in the replay (stepping runs): each footprint covers the sole MuJoCo places on the
floor at touchdown, and is out of sight before it."""

from __future__ import annotations

import math
import types

import mujoco
import numpy as np
import pytest

from biped.errors import BipedError
from biped.viz import replay_from_mujoco
from biped.viz.footprints import with_footprints


def _sole_corners_xy(m, d, foot):
    """(8, 2) floor-plane corners of the bottom faces of ``foot``'s heel and toe boxes (MuJoCo)."""
    out = []
    for part in ("heel", "toe"):
        g = m.geom(f"{foot}_{part}").id
        R = d.geom_xmat[g].reshape(3, 3)
        hx, hy, hz = m.geom_size[g]
        for a in (-1, 1):
            for b in (-1, 1):
                out.append((d.geom_xpos[g] + R @ np.array([a * hx, b * hy, -hz]))[:2])
    return np.array(out)


def _yawed_qpos(m, yaw, T):
    q = np.tile(m.key_qpos[0], (T, 1))
    q[:, 3:7] = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
    q[:, 0] += np.linspace(0.0, 0.2, T)
    return q


def test_footprint_covers_the_landed_sole_and_is_hidden_before(wendlandt_mj, tmp_path):
    from biped.outputs.push import _footprints

    m = wendlandt_mj
    yaw = math.radians(25.0)
    times = np.arange(6) * 0.01
    q = _yawed_qpos(m, yaw, times.size)
    d = mujoco.MjData(m)
    d.qpos[:] = q[3]
    mujoco.mj_kinematics(m, d)
    corners = _sole_corners_xy(m, d, "left")
    # the sole rectangle's centre: the middle of the corners' extent along the foot's own axes
    c, sn = math.cos(yaw), math.sin(yaw)
    Ry = np.array([[c, -sn], [sn, c]])
    loc = corners @ Ry
    sole_c = Ry @ (0.5 * (loc.min(axis=0) + loc.max(axis=0)))
    steps = [{"foot": "left", "touch_down_s": 0.03, "position_m": [*sole_c, 0.0]}]
    result = types.SimpleNamespace(times=times, qpos=q, extra={"steps": steps})
    fps = _footprints(types.SimpleNamespace(model=m), result)
    assert len(fps) == 1 and fps[0]["yaw_rad"] == pytest.approx(yaw, abs=1e-9)
    rp = with_footprints(replay_from_mujoco(m, times, q, follow="trunk"), fps)
    g = [k for k, gg in enumerate(rp.geoms) if gg.name.startswith("footprint")]
    assert len(g) == 1 and rp.follow == "trunk"
    k = g[0]
    size = rp.geoms[k].size
    # the footprint's corners, from the replay's pose: the same rectangle MuJoCo's soles span
    for t in range(times.size):
        R = np.empty(9)
        mujoco.mju_quat2Mat(R, rp.quat[t, k])
        R = R.reshape(3, 3)
        fp = np.array(
            [
                (rp.pos[t, k] + R @ np.array([a * size[0], b * size[1], 0.0]))[:2]
                for a in (-1, 1)
                for b in (-1, 1)
            ]
        )
        if times[t] < 0.03:
            assert rp.pos[t, k, 2] < -1.0  # out of sight under the floor
            continue
        assert 0.0 <= rp.pos[t, k, 2] - size[2] < 1e-6  # lying on the floor
        # each footprint corner is a corner of MuJoCo's sole boxes (to 1 mm), and every sole
        # corner lies inside the footprint
        dist = np.linalg.norm(fp[:, None, :] - corners[None, :, :], axis=2).min(axis=1)
        assert dist.max() < 1e-3, dist
        inside = np.abs((corners - rp.pos[t, k, :2]) @ R[:2, :2]) <= np.array(size[:2]) + 1e-3
        assert inside.all()


def test_no_steps_no_footprints_and_bad_input(wendlandt_mj):
    m = wendlandt_mj
    times = np.arange(3) * 0.01
    rp = replay_from_mujoco(m, times, _yawed_qpos(m, 0.0, 3))
    assert with_footprints(rp, []) is rp
    with pytest.raises(BipedError, match="footprint 0 must be a mapping"):
        with_footprints(rp, [{"time_s": 0.0}])
    with pytest.raises(BipedError, match="finite"):
        with_footprints(
            rp, [{"time_s": math.nan, "centre_m": (0, 0), "half_length_m": 0.1, "half_width_m": 0.05}]
        )
