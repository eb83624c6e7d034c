"""The stance model of the stepping controller (:mod:`biped.control.stance_dynamics`): the floor's
wrench on the stance foot predicted from the whole biped's dynamics, against MuJoCo's contact
forces during a swing (issue #23, "the swing leg in the stance model"); the contact map's rows
against the rows they replace, in closed form."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from _helpers import qp_stepping

from biped.control.cones import ROWS_PER_FOOT, cone_rows, map_contact_rows


def test_contact_map_rows_hold_the_predicted_wrench():
    """With a contact map (K, r) on foot 1, its normal-force and friction rows times x equal the
    original rows times ``K w + r`` minus their bound (w = x[6:12]); every other row, and foot 0's
    (no map), unchanged; a map with the flag off changes nothing."""
    rng = np.random.default_rng(5)
    Ct = np.zeros((2 * ROWS_PER_FOOT, 12))
    b = np.zeros(2 * ROWS_PER_FOOT)
    cone_rows(0.11, 0.045, 0.2, 10.0, 2000.0, 0, Ct, b, 0)
    cone_rows(0.11, 0.045, 0.2, 10.0, 2000.0, 6, Ct, b, ROWS_PER_FOOT)
    Ct0, b0 = Ct.copy(), b.copy()
    K, r = np.eye(6) + 0.2 * rng.normal(size=(6, 6)), rng.normal(0.0, 50.0, 6)
    cmap = np.zeros((2, 43))
    cmap[1, 1:37], cmap[1, 37:] = K.reshape(36), r
    map_contact_rows(Ct, b, 0, ROWS_PER_FOOT, cmap)  # flag off: nothing
    np.testing.assert_array_equal(Ct, Ct0)
    np.testing.assert_array_equal(b, b0)
    cmap[1, 0] = 1.0
    map_contact_rows(Ct, b, 0, ROWS_PER_FOOT, cmap)
    mapped = {ROWS_PER_FOOT + k for k in (0, 1, 2, 3, 6, 7)}
    for _ in range(5):
        x = rng.normal(0.0, 100.0, 12)
        lam = x.copy()
        lam[6:] = K @ x[6:] + r
        for row in range(2 * ROWS_PER_FOOT):
            if row in mapped:
                assert Ct[row] @ x - b[row] == pytest.approx(Ct0[row] @ lam - b0[row], rel=1e-12, abs=1e-9)
            else:
                np.testing.assert_array_equal(Ct[row], Ct0[row])
                assert b[row] == b0[row]


def _swing_trace(cfg_kw, speed, direction, duration):
    """Per control period of the first swing of a sweep-grid push (stepping, ``"qp"`` set plus
    ``cfg_kw``): MuJoCo's total floor force on the stance foot (world, the period's last physics
    step), the QP's planned stance force and the stance model's prediction ``K w + r`` (world)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from test_stance_slip import _sweep_scenario

    from biped.sim.push import run_closed_loop
    from biped.sim.scene import build_scene

    sc = _sweep_scenario(speed, direction).with_overrides(duration_s=duration)
    scene = build_scene(sc)
    ctl = qp_stepping(sc, scene, **cfg_kw)
    rows: list = []

    def policy(t, q, v, feet):
        tau = ctl(t, q, v, feet)
        row = None
        if ctl.phase == "swing" and len(ctl.steps) == 1 and ctl.steps[0]["lift_off_s"] is not None:
            st = 1 - ctl.swing
            qp = ctl._ctrl_swing.qp
            Rs = ctl.data.ximat[ctl._foot[st]].reshape(3, 3) @ qp._soles[st][:3, :3]
            w = qp.x[6 * st : 6 * st + 6].copy()
            c = qp.cmap[st]
            pred = c[1:37].reshape(6, 6) @ w + c[37:43] if c[0] else np.full(6, np.nan)
            row = [st, Rs @ w[:3], Rs @ pred[:3]]
        rows.append(row)
        return tau

    floor = scene.floor_geom
    feet = [scene.model.body(n).id for n in ("left_foot", "right_foot")]
    seen: list = []

    def on_step(m, d):
        f6, out = np.zeros(6), np.zeros((2, 3))
        for k in range(d.ncon):
            con = d.contact[k]
            if floor not in (con.geom1, con.geom2):
                continue
            other = con.geom2 if con.geom1 == floor else con.geom1
            for i in (0, 1):
                if m.geom_bodyid[other] == feet[i]:
                    mujoco.mj_contactForce(m, d, k, f6)
                    f = con.frame.reshape(3, 3).T @ f6[:3]  # geom1 on geom2
                    out[i] += f if con.geom1 == floor else -f
        seen.append(out)

    r = run_closed_loop(sc, scene, policy, on_step=on_step, compiled=False)
    trace = [
        (row[1], row[2], seen[k][row[0]]) for k, row in enumerate(rows) if row is not None and k < len(seen)
    ]
    return r, trace


@pytest.mark.slow
def test_the_stance_model_predicts_mujocos_contact_force_during_a_swing():
    """Sweep grid, 16 m/s at 135 deg, ``"qp"`` set with ``stance_contact_model``: during the first
    (backward) step's swing, MuJoCo's floor force on the stance foot against the QP's planned
    stance wrench alone (the massless legs) and against the stance model's ``K w + r`` (the
    swing leg's driven reaction, the legs' inertia and weight). The model's horizontal and normal
    errors are a fraction of the plan's: their mean (measured: plan -24, 5, 50 N; model -3, 2, 2 N)
    and, over 10 ms averages (5 periods: MuJoCo's soft contact chatters from one 1 ms physics step
    to the next), their RMS (measured: plan 32 N horizontal, 61 N normal; model 11 N, 19 N)."""
    r, trace = _swing_trace({"stance_contact_model": True}, 16, 135, 0.34)
    assert len(trace) > 100  # the swing's periods (0.28 s at 500 Hz)
    plan, pred, mj = (np.array([row[k] for row in trace]) for k in range(3))
    assert np.isfinite(pred).all()
    bias_plan, bias_pred = np.abs((mj - plan).mean(axis=0)), np.abs((mj - pred).mean(axis=0))
    assert bias_plan[2] > 30.0 and bias_plan[0] > 15.0  # the massless plan misses the legs
    assert bias_pred[2] < 0.25 * bias_plan[2] and bias_pred[0] < 0.25 * bias_plan[0]
    k = np.ones(5) / 5.0

    def rms_10ms(e, cols):
        e = np.stack([np.convolve(e[:, i], k, mode="valid") for i in cols], axis=1)
        return float(np.sqrt(np.mean(np.sum(e**2, axis=1))))

    for cols in ((0, 1), (2,)):
        assert rms_10ms(mj - pred, cols) < 0.5 * rms_10ms(mj - plan, cols), cols
