"""The valid values of a :class:`~biped.sim.scenario.Scenario`'s string keys: the controllers, the
wrench distributions, the stepping's programs, swing paths, reaches and triggers, and the physics
presets (with the values they fill in), one table of them, :data:`STRING_KEYS`.

Re-exported from :mod:`biped.sim.scenario`; the other rules (vector lengths, ranges) live in
:mod:`biped.sim.scenario_checks`. The controllers', supports' and distributions' names are the
control layer's own (:mod:`biped.control.policy`, :mod:`biped.control.workspace`).
"""

from __future__ import annotations

from biped.control.neuromotor import NEUROMOTOR
from biped.control.policy import CONTROLLERS, SUPPORTS
from biped.control.swing_plan import SWING_PATHS
from biped.control.workspace import DISTRIBUTIONS, TARGET_AXES
from biped.sim import perturbations
from biped.sim.perturbations.force import SHAPES as FORCE_SHAPES

__all__ = [
    "CONTROLLERS",
    "DISTRIBUTIONS",
    "PHYSICS",
    "PHYSICS_PRESETS",
    "STEP_PROGRAMS",
    "STEP_REACHES",
    "STEP_SWING_PATHS",
    "STEP_TRIGGERS",
    "STRING_KEYS",
    "SUPPORTS",
]

# CONTROLLERS: "workspace" (W's) or "joint-pd". SUPPORTS: which feet the workspace controller takes
# as fixed: "fixed" = both, always (W); "sensed" = the feet whose soles touch the floor at each
# control step (see WorkspaceController.compute). DISTRIBUTIONS: the workspace controller's wrench
# distribution (W Alg. 5): W's min-norm split ("statics", its print's subscripts "printed") or the
# contact-feasible QP ("qp", biped.control.distribution).

#: How a stepping run makes a step (key ``step_program``): the task-space feedback swing of
#: biped.control.stepping, biped.control.step_program's weight transfer and planned swing, or the
#: feedback swing on the present state predicted over the delay (biped.control.forward_model);
#: "program-trail": "program-predicted" with the rear foot trailing after the step (the height
#: set point capped by the front leg alone: StepProgramConfig.rear_trails).
STEP_PROGRAMS = ("feedback", "program", "predicted", "program-predicted", "program-trail")
#: The step program's swing path (key ``swing_path``, with ``step_program`` "program",
#: "program-predicted" or "program-trail"): biped.control.swing_plan.SWING_PATHS.
STEP_SWING_PATHS = tuple(SWING_PATHS)
#: The longest step a stepping run may land (key ``step_reach``): "fixed" = StepLimits' 0.5 m
#: between sole centres (the sweeps' design limit); "leg" = what the legs reach from the hips'
#: standing height, both legs at the swing's reach (biped.control.capture.reach_step_limit), with
#: the stance knee kept off straight in single support (biped.sim.policies.STANCE_KNEE_MIN_DEG).
STEP_REACHES = ("fixed", "leg")
STEP_TRIGGERS = ("capture", "qp")

#: Physics presets (key ``physics``): the values they give ``physics_timestep_s`` and
#: ``contact_timeconst_s`` when those keys are not set, whether MuJoCo's sleep flag is on, and
#: whether each foot collides as one box (``sole_box``: the union of its flush heel and toe
#: boxes, 4 corner contacts instead of 8, two pairs of which sit on the same points of the seam;
#: see :func:`biped.sim.scene.scene_spec`). "faithful" is the reference (0.5 ms step, 5 ms contact
#: time constant, the MJCF's heel and toe boxes); "fast" costs about 2.5x less per simulated
#: second and is checked against it in docs/sweep.md ("Physics presets"). The one box is used
#: only where it was checked, W's shipped biped with its feet in place (:attr:`Scenario.sole_box`):
#: it lets a stance foot slide twice as far during a sideways step, and W's min-norm split on a
#: 55 kg subject diverges with it where the two boxes held.
PHYSICS_PRESETS = {
    "faithful": {
        "physics_timestep_s": 0.0005,
        "contact_timeconst_s": 0.005,
        "sleep": False,
        "sole_box": False,
    },
    "fast": {"physics_timestep_s": 0.001, "contact_timeconst_s": 0.0075, "sleep": True, "sole_box": True},
}
PHYSICS = tuple(PHYSICS_PRESETS)

#: The string keys and their valid values (the rest of the rules: biped.sim.scenario_checks).
STRING_KEYS = {
    "target_axis": TARGET_AXES,
    "controller": CONTROLLERS,
    "support": SUPPORTS,
    "physics": PHYSICS,
    "distribution": DISTRIBUTIONS,
    "neuromotor": NEUROMOTOR,
    "perturbation": perturbations.NAMES,
    "force_shape": FORCE_SHAPES,
    "step_program": STEP_PROGRAMS,
    "step_reach": STEP_REACHES,
    "swing_path": STEP_SWING_PATHS,
    "step_trigger": STEP_TRIGGERS,
}
