"""W's push-recovery experiment (section 4) closed loop on MuJoCo.

>>> from biped.sim import Scenario, simulate
>>> result = simulate(Scenario(duration_s=0.2))     # W's push, cut short (default 3 s)
>>> result.block_contact_time_s, result.fell
(0.082, False)

Files are written a layer above, by :func:`biped.outputs.push.write_outputs`.
"""

from biped.sim import mjlog as _mjlog
from biped.sim.push import PushResult, replay_torques, run_closed_loop, simulate
from biped.sim.scenario import Scenario
from biped.sim.scene import Scene, build_scene

_mjlog.configure_from_env()  # never MUJOCO_LOG.TXT in the current directory

__all__ = [
    "PushResult",
    "Scenario",
    "Scene",
    "build_scene",
    "replay_torques",
    "run_closed_loop",
    "simulate",
]
