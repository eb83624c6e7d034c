"""Bediz's kinematic human figure "Dynaman" (B chapter IV-B, V-D, Appendix B).

>>> from biped.kinematic import demo, walk_metrics
>>> plan = demo()                     # 6 steps forward, 5 up the stairs, a jump, 4 forward
>>> motion = plan.sample(200.0)       # leg IK (B eq. 4.12-4.19) at 200 Hz
>>> walk_metrics(motion).max_stance_slip_m < 1e-3
True

- :mod:`~biped.kinematic.ik`: the 3-link planar leg, eq. 4.12-4.19, and the stepping geometry
  eq. 4.20, 4.21, 4.23.
- :mod:`~biped.kinematic.figure`: the 15-part frame hierarchy (B Fig. 13, 15), its forward
  kinematics, shapes and an MJCF of it.
- :mod:`~biped.kinematic.gaits`: stepping forward, upstairs, the jump and B's demo, and the
  ground checks B's code lacks (penetration, stance slip, swing clearance).
- :mod:`~biped.kinematic.dynamics`: inverse dynamics of the motion on the 3D biped (MuJoCo).
"""

from biped.kinematic.figure import (
    JOINT_NAMES,
    PARTS,
    FigureDims,
    FigurePoses,
    figure_mjcf,
    part_poses,
)
from biped.kinematic.gaits import (
    GAITS,
    GaitParams,
    Motion,
    Plan,
    WalkMetrics,
    chain,
    demo,
    jump,
    stair_geometry,
    step_forward,
    step_upward,
    walk_metrics,
)
from biped.kinematic.ik import LegAngles, bar_foot, leg_fk, leg_ik, stair_angle, stair_elevation
from biped.kinematic.terrain import FLAT, Terrain

__all__ = [
    "FLAT",
    "GAITS",
    "JOINT_NAMES",
    "PARTS",
    "FigureDims",
    "FigurePoses",
    "GaitParams",
    "LegAngles",
    "Motion",
    "Plan",
    "Terrain",
    "WalkMetrics",
    "bar_foot",
    "chain",
    "demo",
    "figure_mjcf",
    "jump",
    "leg_fk",
    "leg_ik",
    "part_poses",
    "stair_angle",
    "stair_elevation",
    "stair_geometry",
    "step_forward",
    "step_upward",
    "walk_metrics",
]
