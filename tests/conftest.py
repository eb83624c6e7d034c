"""Shared fixtures: the shipped biped model, loaded once per session.

Kept generic on purpose (other test modules may use them); oracles specific to one subject live
in that subject's test module.
"""

from __future__ import annotations

import mujoco
import pytest

from biped import models


@pytest.fixture(scope="session")
def wendlandt_path():
    """Path of the shipped MJCF of W's biped."""
    return models.path("wendlandt")


@pytest.fixture(scope="session")
def wendlandt_mj(wendlandt_path):
    """``mujoco.MjModel`` of W's biped (do not mutate: shared by the session)."""
    return mujoco.MjModel.from_xml_path(str(wendlandt_path))
