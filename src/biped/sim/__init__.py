"""W's push-recovery experiment (section 4) closed loop on MuJoCo.

>>> from biped.sim import Scenario, simulate
>>> result = simulate(Scenario())
>>> from biped.outputs.push import write_outputs     # files are written a layer above
>>> write_outputs(result, "runs/w-default")
"""

from biped.sim.push import PushResult, replay_torques, run_closed_loop, simulate
from biped.sim.scenario import Scenario
from biped.sim.scene import Scene, build_scene

__all__ = [
    "PushResult",
    "Scenario",
    "Scene",
    "build_scene",
    "replay_torques",
    "run_closed_loop",
    "simulate",
]
