"""W's push-recovery experiment (section 4) closed loop on MuJoCo.

>>> from biped.sim import Scenario, simulate, write_outputs
>>> result = simulate(Scenario())
>>> write_outputs(result, "runs/w-default")
"""

from biped.sim.push import PushResult, replay_torques, simulate, write_outputs
from biped.sim.scenario import Scenario
from biped.sim.scene import Scene, build_scene

__all__ = [
           "PushResult",
           "Scenario",
           "Scene",
           "build_scene",
           "replay_torques",
           "simulate",
           "write_outputs",
]
