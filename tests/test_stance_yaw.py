"""The stance foot's yaw in single support (issue #23, stance slip <= 2 cm): the floor holds the
stance sole's yaw moment only up to its torsional friction, and the swing leg's reaction adds yaw
moment the massless-leg plan does not see. With the stance model's prediction on the cone's yaw
rows too (``stance_contact_rows`` 2) the QP bounds the floor's predicted yaw moment, not the
planned one. Measured on MuJoCo's recorded foot poses (docs/sweep.md, "The stance foot's yaw")."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from test_crossover_path import C_PRIME
from test_stance_slip import _stance_slips
from test_stepping_trigger import _sweep_scenario


def _stance_yaw_turn(sc, r, k: int, window_s: float) -> float:
    """How far [deg] step ``k``'s stance foot turns about the vertical (MuJoCo kinematics of the
    recorded states: the foot body's heading) between lift-off and ``window_s`` after it."""
    from biped.sim.scene import build_scene

    m = build_scene(sc).model
    d = mujoco.MjData(m)
    st = r.extra["steps"][k]
    side = ("right", "left")[("left", "right").index(st["foot"])]
    body = m.geom_bodyid[m.geom(f"{side}_heel").id]
    k0 = int(np.searchsorted(r.times, st["lift_off_s"] - 1e-9))
    k1 = int(np.searchsorted(r.times, st["lift_off_s"] + window_s - 1e-9))
    yaw = []
    for q in r.qpos[k0 : k1 + 1]:
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        R = d.xmat[body].reshape(3, 3)
        yaw.append(math.atan2(R[1, 0], R[0, 0]))
    yaw = np.unwrap(np.array(yaw))
    return float(np.degrees(np.abs(yaw - yaw[0]).max()))


@pytest.mark.slow
def test_the_predicted_yaw_rows_hold_the_second_forward_steps_stance_foot():
    """Sweep grid, 22 m/s from behind, fast physics, friction 0.3, set C' with the timed crossover
    (docs/sweep.md): a backward step, then a forward one. With the stance model on the normal-force
    and friction rows only, the second step's stance foot turns > 8 deg about the vertical in the
    swing's first 0.15 s (measured 10.6 deg; the tangential force 0.1-0.2 of the normal one: not
    linear friction) and its sole centre slides > 2 cm (2.2). With the yaw rows on the predicted
    wrench too it turns < 3 deg there (measured 1.5) and slides <= 2 cm (1.5)."""
    from _helpers import run_qp_stepping

    sc = _sweep_scenario(22, 180)
    assert sc.friction == 0.3 and sc.physics == "fast"
    out = {}
    for rows in (1, 2):
        r = run_qp_stepping(sc, **C_PRIME, crossover_path="timed", stance_contact_rows=rows)
        steps = r.extra["steps"]
        assert len(steps) >= 2 and not steps[1]["sideways"], steps
        assert r.recovered
        out[rows] = (_stance_yaw_turn(sc, r, 1, 0.15), _stance_slips(sc, r)[1])
    assert out[1][0] > 8.0 and out[1][1] > 0.02, out
    assert out[2][0] < 3.0 and out[2][1] <= 0.02, out
