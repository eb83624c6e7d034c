"""Wendlandt's recursive workspace balancing controller (W, 1997) as a Python object.

>>> import mujoco, numpy as np
>>> from biped import models
>>> m = mujoco.MjModel.from_xml_path(str(models.path("wendlandt")))
>>> qpos, qvel = m.key_qpos[m.key("wendlandt_initial").id], np.zeros(m.nv)   # W's initial state
>>> from biped.control import WorkspaceController
>>> ctrl = WorkspaceController.from_mjcf(models.path("wendlandt"))
>>> out = ctrl.compute(qpos, qvel)       # MuJoCo's qpos (19,) / qvel (18,) of the biped's model
>>> out.torques.shape                     # [N m], ordered as ctrl.joint_names
(12,)

Frames and units: every 6-vector of the output is a twist ``[v; w]`` or a wrench ``[f; tau]``
expressed in the central body's COM principal-axis frame (MuJoCo's inertial frame of the root
body), SI units (N, N m, m/s^2, rad/s^2).
"""

from biped.control.workspace import (
    DISTRIBUTIONS,
    ControllerOutput,
    Gains,
    Target,
    TreeModel,
    WorkspaceController,
)

__all__ = ["DISTRIBUTIONS", "ControllerOutput", "Gains", "Target", "TreeModel", "WorkspaceController"]
