"""The timed swing's aim (``StepProgramConfig.aim_offset_m``): the landing point a fixed offset
from the capture point the linear inverted pendulum predicts for the touchdown, at the swing time
its own step length asks for (docs/validate.md, "Aiming the timed step")."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from biped.control.capture import StepLimits
from biped.control.step_program import StepProgram, StepProgramConfig
from biped.sim.scenario import ScenarioError


def _program(aim: float | None, jerk: float = 120.0):
    """A stand-in holding only what :meth:`StepProgram._feasible_time` reads: the swing sole
    starting at the origin (the sole's offset from the ankle zero), its stance beside it."""
    ns = SimpleNamespace(
        program=StepProgramConfig(swing_brake=1.0, swing_time_s=0.37, swing_jerk_m_s3=jerk, aim_offset_m=aim),
        _p0=np.zeros(3), _sole=[(np.zeros(3),), (np.zeros(3),)], _T=0.37, _u=0.0, _offset=0.03,
        _limits=StepLimits(max_step=5.0, min_width=0.0, max_width=1.0, max_back=5.0),
    )  # fmt: skip
    ns._aim_offset = lambda: StepProgram._aim_offset(ns)
    return ns


@pytest.mark.parametrize("aim", [None, 0.0, -0.1])
def test_the_timed_aim_is_the_fixed_point_of_the_pendulum_and_the_jerk_limited_swing(aim):
    """Forward only (y 0): the returned (T, landing) satisfy, to 1e-4, both closed forms at once:
    the landing is ``cop + (xi - cop) e^(omega T) + a`` (the LIPM capture point at the touchdown
    plus the aim offset a, the stepper's 0.03 m when None) and ``T = max(0.37, (32 d / J)^(1/3))``
    (the bang-bang jerk path's time for the step d); a more negative offset gives a shorter step
    in a shorter time."""
    ns = _program(aim)
    xi, cop, omega = np.array([-0.18, 0.0]), np.array([-0.1, 0.0]), math.sqrt(9.81 / 0.9)
    T, land = StepProgram._feasible_time(ns, xi, cop, omega, np.zeros(3), 1.0, 0)
    a = 0.03 if aim is None else aim
    xi_td = cop[0] + (xi[0] - cop[0]) * math.exp(omega * T)
    assert land[0] == pytest.approx(xi_td - a, abs=1e-4)  # the biped faces -x: "beyond" is -x
    d = abs(float(land[0]))
    assert T == pytest.approx(max(0.37, (32.0 * d / 120.0) ** (1.0 / 3.0)), abs=1e-4)
    assert T > 0.37  # the fixed point, not the floor
    if aim == -0.1:
        T0, land0 = StepProgram._feasible_time(_program(0.0), xi, cop, omega, np.zeros(3), 1.0, 0)
        assert abs(land[0]) < abs(land0[0]) and T < T0


@pytest.mark.parametrize("bad", [0.5, -0.31, float("nan"), "x"])
def test_aim_offset_is_checked(bad):
    with pytest.raises(ScenarioError, match="aim_offset_m must be None or a number in"):
        StepProgramConfig(aim_offset_m=bad)
