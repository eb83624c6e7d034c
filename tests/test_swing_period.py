"""The plain swing's period compiled (:mod:`biped.control.swing_period`, issue #23: a stepping
trial's cost): against the NumPy swing of :class:`~biped.control.stepping_swing.SwingPhase` (the
code every other swing still runs, here the reference) at every swing period of stepping trials,
and in the compiled push loop against the Python loop (the swing no longer handed back).

The swing law inside it is checked against MuJoCo's inverse dynamics in
``tests/test_swing_kernel.py``; here the compiled loop's recorded swing-leg torques are checked
against that same law as the Python loop called it, row by row."""

from __future__ import annotations

import numpy as np
import pytest
from test_sim_fused import assert_same
from test_sim_fused_step import _sweep_scenario

from biped.control import capture as cp
from biped.control import swing_period
from biped.control.stepping import SteppingController
from biped.control.stepping_swing import AIRBORNE_M, SwingPhase
from biped.sim import build_scene
from biped.sim.push import controller_policy, run_closed_loop


def numpy_period(ctl, t, down, xi, omega):
    """The NumPy swing (``SwingPhase._swing_call`` and ``_single_support`` up to the controllers,
    the old code's arithmetic) on ``ctl``'s state before the period: "touchdown", or (pd, vd, ad
    after the reach check, the flags, the COM acceleration (2,), the landing point (2,), the
    lift-off time)."""
    s, i = ctl.stepping, ctl.swing
    st = 1 - i
    el = t - ctl._t_start
    lift = ctl.steps[-1]["lift_off_s"]
    if lift is None and not down:
        lift = t
    if down and el > 0.5 * ctl._T and lift is not None:
        return "touchdown"
    stance_c, cop = ctl._stance_cop(st)
    side = 1.0 if i == 1 else -1.0
    land = ctl._landing
    if land is None or el < s.retarget_until * ctl._T:
        land = ctl._step_target(xi, cop, omega, ctl._T - el, stance_c[:2], side)
    sole_off = ctl._sole[i][0]
    ankle_land = np.array([land[0] - sole_off[0], land[1] - sole_off[1], -sole_off[2]])
    p0, T = ctl._p0, ctl._T
    sc = el / T
    h, hd, hdd = cp.min_jerk(sc)
    b, bd, bdd = cp.bump(sc)
    pd = p0 + (ankle_land - p0) * h
    vd = (ankle_land - p0) * hd / T
    ad = (ankle_land - p0) * hdd / T**2
    pd[2] += s.apex_m * b
    vd[2] += s.apex_m * bd / T
    ad[2] += s.apex_m * bdd / T**2
    if sc >= 1.0:
        pd[2] = ankle_land[2] - s.descent_m_s * (el - T)
        vd[2] = -s.descent_m_s
    hip = ctl.data.xpos[ctl._hip[i]]
    r = pd - hip
    if np.linalg.norm(r) > s.reach_m:
        pd = hip + r * (s.reach_m / np.linalg.norm(r))
    flags = (i == 1, i == 0)
    if s.airborne_stance and ctl._sole_pose(st)[0][2] >= AIRBORNE_M:
        flags = (False, False)
    acc = omega**2 * (ctl.data.subtree_com[0][:2] - cop)
    return pd, vd, ad, flags, acc, np.asarray(land)[:2], lift


def _close(x, y, what):
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    np.testing.assert_allclose(
        x, y, rtol=1e-12, atol=1e-12 * max(1.0, float(np.max(np.abs(y)))), err_msg=what
    )


@pytest.mark.parametrize(
    ("speed", "direction", "trigger"), [(14, 90, "qp"), (12, 180, "qp"), (16, 0, "qp"), (10, 180, "capture")]
)
def test_every_swing_period_equals_the_numpy_swing(speed, direction, trigger, monkeypatch):
    """Sideways, from behind, from the front (both triggers, faithful physics): at each swing
    period the compiled period's path, flags, feed-forward, landing point and lift-off equal the
    NumPy swing's on the same state to rounding (1e-12), its touchdown decision exactly."""
    seen = {"go": 0, "touchdown": 0}
    real = swing_period.SwingPlan.__call__

    def checked(self, ctl, t, down, xi, omega):
        ref = numpy_period(ctl, t, down, xi, omega)
        code = real(self, ctl, t, down, xi, omega)
        if ref == "touchdown":
            assert code == swing_period.TOUCHDOWN
            seen["touchdown"] += 1
            return code
        assert code == swing_period.GO
        pd, vd, ad, flags, acc, land, lift = ref
        o = self.out
        _close(o[0:3], pd, "pd")
        _close(o[3:6], vd, "vd")
        _close(o[6:9], ad, "ad")
        _close(o[9:11], acc, "com acceleration")
        assert (bool(self.contact[0]), bool(self.contact[1])) == flags
        _close(ctl._landing, land, "landing")
        assert ctl.steps[-1]["target_m"] == [float(ctl._landing[0]), float(ctl._landing[1]), 0.0]
        assert ctl.steps[-1]["lift_off_s"] == lift
        seen["go"] += 1
        return code

    monkeypatch.setattr(swing_period.SwingPlan, "__call__", checked)
    sc = _sweep_scenario(speed, direction, trigger, physics="faithful", duration_s=1.6)
    scene = build_scene(sc)
    r = run_closed_loop(sc, scene, controller_policy(sc, scene), compiled=False)
    assert r.extra["steps"], "the push must step"
    assert seen["go"] >= 40 and seen["touchdown"] == len(r.extra["steps"]), seen


def test_the_reference_sees_a_wrong_period(monkeypatch):
    """The check above fails on a period one bit of the path off (the descent rate 1e-9 m/s off)."""
    real_load = swing_period.SwingPlan.load

    def off(self, ctl):
        real_load(self, ctl)
        self.prm[swing_period.P_APEX] += 1e-9

    monkeypatch.setattr(swing_period.SwingPlan, "load", off)
    with pytest.raises(AssertionError):
        test_every_swing_period_equals_the_numpy_swing(12, 180, "qp", monkeypatch)


@pytest.mark.parametrize(("speed", "direction"), [(14, 90), (20, 180)])
def test_compiled_loop_runs_the_swing_and_equals_the_python_loop(speed, direction, monkeypatch):
    """A sideways step and three steps from behind (faithful physics, 2.5 s): the compiled loop
    calls the Python controller only at a step's start and touchdown (the swing compiled), and the
    run is the Python loop's bit for bit; each swing row's swing-leg torques are the swing law's
    as the Python loop called it on that row."""

    sc = _sweep_scenario(speed, direction, "qp", physics="faithful", duration_s=2.5, early_stop=False)
    scene = build_scene(sc)
    calls: list = []
    real = SteppingController.__call__

    def counting(self, t, q, v, feet):
        calls.append(t)
        return real(self, t, q, v, feet)

    monkeypatch.setattr(SteppingController, "__call__", counting)
    pa = controller_policy(sc, scene)
    a = run_closed_loop(sc, scene, pa, compiled=True)
    n_compiled = len(calls)
    b = run_closed_loop(sc, scene, controller_policy(sc, scene), compiled=False)
    assert_same(a, b)
    assert a.extra["steps"] == b.extra["steps"]
    steps = a.extra["steps"]
    assert steps and all(s["touch_down_s"] is not None for s in steps)
    # the first call, each step's start and touchdown (and a few other Python periods: the
    # settling switch), never a swing's periods
    swing_rows = sum(round((s["touch_down_s"] - s["start_s"]) / 0.002) for s in steps)
    assert n_compiled <= 1 + 2 * len(steps) + 4 and swing_rows > 50 * len(steps), (n_compiled, swing_rows)
    # each swing row's leg torques in the compiled run: the swing law's (checked against
    # mj_inverse in test_swing_kernel), as the Python loop called it on that row
    law: dict = {}
    real_law = SwingPhase._swing_torques

    def recorded(self, i, pd, vd, ad):
        tau = real_law(self, i, pd, vd, ad)
        law[round(self._t_prev / 0.002)] = (i, np.array(tau))
        return tau

    monkeypatch.setattr(SwingPhase, "_swing_torques", recorded)
    run_closed_loop(sc, scene, controller_policy(sc, scene), compiled=False)
    assert len(law) >= swing_rows - 2 * len(steps)
    legs = pa._leg_tau
    for k, (i, tau) in law.items():
        if pa.limits is not None:  # (the run's torques clipped to the limits)
            tau = np.clip(tau, pa.limits.lower[legs[i]], pa.limits.upper[legs[i]])
        assert np.array_equal(a.torques[k, legs[i]], tau), k
