"""The swing's path shape (biped.control.swing_plan, scenario key ``swing_path``; docs/validate.md,
"The swing's shape"): the S-curve against its closed forms and finite differences, the key's
bad values, and, in MuJoCo, that the young preset's step lands sooner with it than with the
minimum-jerk path at the same lean while no joint torque changes faster than its rate limit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from biped.control import capture as cp
from biped.control.swing_plan import SWING_PATHS, jerk_bound, scurve
from biped.errors import ScenarioError
from biped.sim import Scenario


def _peak_jerk(f, n: int = 20000) -> float:
    """The largest |third derivative| of a unit-time path ``f(u) -> (s, s', s'')`` by finite
    differences of its second derivative."""
    u = np.linspace(0.0, 1.0, n + 1)
    acc = np.array([f(x)[2] for x in u])
    return float(np.abs(np.diff(acc)).max() * n)


@pytest.mark.parametrize("brake", [0.0, 0.5, 1.0])
def test_the_s_curve_is_a_bang_bang_jerk_move(brake):
    """s(0) = 0, s(1) = 1, zero acceleration at both ends, the rate the integral of nothing but
    the path (finite differences of s agree with s' to 1e-6), and its jerk +-jerk_bound only."""
    assert scurve(0.0, brake) == (0.0, 0.0, 0.0)
    s1, v1, a1 = scurve(1.0, brake)
    assert s1 == pytest.approx(1.0) and a1 == pytest.approx(0.0, abs=1e-12)
    u = np.linspace(0.0, 1.0, 4001)
    s = np.array([scurve(x, brake)[0] for x in u])
    v = np.array([scurve(x, brake)[1] for x in u])
    assert np.allclose(np.gradient(s, u), v, atol=2e-3)
    assert _peak_jerk(lambda x: scurve(x, brake)) == pytest.approx(jerk_bound(brake), rel=1e-3)
    if brake == 1.0:
        assert v1 == pytest.approx(0.0, abs=1e-12) and jerk_bound(1.0) == pytest.approx(32.0)
    if brake == 0.0:
        assert v1 == pytest.approx(2.0) and jerk_bound(0.0) == pytest.approx(8.0)


def test_at_the_same_peak_jerk_the_s_curve_takes_0_81_of_the_minimum_jerk_time():
    """The minimum-jerk polynomial's peak jerk is 60 d / T^3 (finite differences of capture.min_jerk),
    the rest-to-rest S-curve's 32 d / T^3: the same peak jerk in (32 / 60)^(1/3) = 0.811 of the
    time, so the minimum-jerk plan's 0.45 s becomes 0.365 s (``swing_path = "s-curve"``: 0.37 s)."""
    mj = _peak_jerk(cp.min_jerk)
    assert mj == pytest.approx(60.0, rel=1e-3)
    ratio = (jerk_bound(1.0) / mj) ** (1 / 3)
    assert ratio == pytest.approx(0.811, abs=1e-3)
    assert 0.45 * ratio == pytest.approx(SWING_PATHS["s-curve"]["swing_time_s"], abs=0.006)


def test_the_swing_path_key_and_its_bad_values():
    with pytest.raises(ScenarioError, match="swing_path must be one of 'min-jerk', 's-curve'"):
        Scenario(swing_path="fast")
    assert "swing_path" not in Scenario(stepping=True).to_dict()  # old files read the same
    assert Scenario(stepping=True, swing_path="s-curve").to_dict()["swing_path"] == "s-curve"
    from biped.control.step_program import StepProgramConfig

    assert StepProgramConfig().swing_brake is None  # the program as it was
    with pytest.raises(ScenarioError, match="swing_brake must be in"):
        StepProgramConfig(swing_brake=1.5)


def test_the_s_curve_lands_the_young_step_sooner_within_the_rate_limits():
    """Young preset, validate's one-step release from human quiet stance at 8 deg (the step program
    on the predicted state): with the S-curve the stepping foot's landing (validate's rule on
    MuJoCo's recorded feet and contacts) comes at least 0.1 s sooner than with the minimum-jerk
    path (measured 436 against 688 ms, docs/validate.md), and no joint torque the plant applied
    changed by more than its rate limit in any control period."""
    from biped.analysis.validate import EXPERIMENTS, _step_measures
    from biped.models import JOINT_NAMES
    from biped.sim.neuro import rate_limits
    from biped.sim.push import simulate

    exp = EXPERIMENTS["step_release"]
    out = {}
    for path in ("min-jerk", "s-curve"):
        keys = {**exp.base, **exp.preset_keys["young"], **exp.magnitude(8.0), "duration_s": 1.2}
        s = Scenario(neuromotor="young", **{**keys, "swing_path": path})
        r = simulate(s)
        out[path] = _step_measures(r, s)[2]
        step = np.abs(np.diff(r.torques, axis=0))
        limit = rate_limits(s)[[JOINT_NAMES.index(n) for n in r.joint_names]] / s.control_rate_hz
        assert np.all(step <= limit * (1 + 1e-9) + 1e-9), path
    assert all(math.isfinite(x) for x in out.values()), out
    assert out["s-curve"] <= out["min-jerk"] - 100.0, out
