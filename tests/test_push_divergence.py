"""Why W's controller's block pushes diverge on the hold task (MuJoCo's "QACC unstable"): W's
min-norm split asks a sole for more roll moment than its edge carries, the feet roll onto their
edges and W's fixed-feet torques, unbounded, then spin them; bounded torques (human limits) or the
QP distribution (the centre of pressure kept inside each sole) make the same push a fall with every
state finite (docs/sweep.md, "the lateral instability")."""

from __future__ import annotations

import numpy as np
import pytest


def _side_push(**extra):
    from biped.sim import Scenario, simulate
    from biped.sim.scene import build_scene
    from biped.sim.sweep.aim import aim_block, hold_scenario

    base = hold_scenario(Scenario(duration_s=4.0, **extra))
    p0, v0 = aim_block(base.initial_com_m[:2], 13.0, 90.0, 1.2)  # 13 m/s from the biped's right
    s = base.with_overrides(block_position_m=p0, block_velocity_m_s=v0)
    r = simulate(s, scene=build_scene(s))
    rows = int(np.flatnonzero(np.any(r.qpos != 0.0, axis=1))[-1]) + 1
    return r, rows


def _feet_roll_deg(r, rows: int) -> np.ndarray:
    """Each row's larger |roll| of the two feet (about the forward axis), from MuJoCo's poses [deg]."""
    q = r.feet_quat[:rows]
    w, x, y, z = (q[..., i] for i in range(4))
    return np.degrees(np.abs(np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)))).max(axis=1)


@pytest.mark.slow
def test_w_split_side_push_diverges_after_the_feet_roll_and_bounded_torques_make_it_a_fall():
    """13 m/s from the side, hold task, W's ideal controller with its min-norm split: MuJoCo's
    integration diverges within 0.1 s; a sole rolls 2 deg onto its edge while the torques are still
    those of the push (under 200 N m), and past 5 deg before they pass 1 kN (MuJoCo's foot poses
    and the commanded torques: 2.1, 4.5, 10.6, 29.9 deg at 129, 301, 823, 34161 N m at 0.026-0.032 s). The same push
    with human torque limits, or with the QP distribution, keeps every state finite and ends in a
    fall, not a divergence."""
    r, rows = _side_push()
    assert r.diverged is not None and not r.fell and rows < 50
    tau = np.abs(r.torques[:rows]).max(axis=1)
    k = int(np.argmax(tau > 1e3))
    assert tau[k] > 1e3 and k > 0
    roll = _feet_roll_deg(r, rows)
    j = int(np.argmax(roll > 2.0))  # the first row a sole stands 2 deg on its edge
    assert 0 < j < k and roll[j] > 2.0
    assert tau[j] < 200.0, tau[j]  # ... with torques of the push, not yet of the blow-up
    assert roll[:k].max() > 5.0, roll[:k]

    for extra in ({"torque_limits": "human"}, {"distribution": "qp"}):
        r, rows = _side_push(**extra)
        assert r.diverged is None and r.controller_error is None and r.fell, extra
        assert np.isfinite(r.qpos).all() and np.isfinite(r.qvel).all() and np.isfinite(r.torques).all()
