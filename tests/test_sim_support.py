"""The push scene's ``support`` key: W's fixed feet (default) or feet sensed from the sole
contacts at every control step."""

from __future__ import annotations

import pytest

from biped.errors import ScenarioError
from biped.sim.push import simulate
from biped.sim.scenario import Scenario


def test_support_key_is_validated():
    with pytest.raises(ScenarioError, match="support must be one of 'fixed', 'sensed'"):
        Scenario(support="both")
    assert Scenario().support == "fixed"


@pytest.mark.slow
def test_sensed_support_recovers_from_ws_push_and_only_flags_feet_on_the_floor():
    """W's experiment with sensed support: the soles start 5 mm up, so the first control steps
    see no foot and command no torque; the run still recovers within the issue's tolerances."""
    r = simulate(Scenario(support="sensed"))
    assert r.recovered and not r.fell
    assert r.final_com_error_m < 0.02 and r.final_orientation_error_deg < 2.0
    first = r.contacts[0]
    assert not first.any()  # in the air at t = 0 ...
    assert not r.torques[0].any()  # ... so no wrench is distributed
    assert r.contacts[-1].all()  # both feet flat at the end
