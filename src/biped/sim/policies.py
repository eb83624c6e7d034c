"""The loop policies of a push run: W's controller (or the joint PD) configured from a
:class:`~biped.sim.scenario.Scenario`, and an open-loop replay of recorded torques.

A policy is any callable ``policy(t, qpos_biped (19,), qvel_biped (18,), feet (left, right))
-> torques (12,)`` [N m] in ``scene.joint_names`` order; :func:`biped.sim.push.run_closed_loop`
runs any of them. (Split from :mod:`biped.sim.push`, which still offers every name.)
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from biped import models
from biped.control.distribution import QPWeights
from biped.control.limits import TorqueLimits, torque_limits
from biped.control.neuromotor import OLDER_STRENGTH_FACTOR
from biped.control.policy import PolicyConfig, make_policy, symmetric_limits
from biped.control.workspace import Gains, Target
from biped.errors import ScenarioError
from biped.models import subject
from biped.sim.scenario import Scenario
from biped.sim.scene import Scene

__all__ = ["ControllerPolicy", "RecordedTorques", "controller_policy", "policy_config", "scenario_limits"]


def scenario_limits(scenario: Scenario) -> TorqueLimits | None:
    """The scenario's ``torque_limits`` ("none", "human" for the model's mass, 1 or 12 numbers)."""
    if scenario.torque_limits == "none":
        return None
    if scenario.torque_limits in ("human", "human-older"):  # older: times OLDER_STRENGTH_FACTOR
        lim = torque_limits("human", body_mass_kg=models.total_mass_kg(scenario.model))
        if scenario.torque_limits == "human":
            return lim
        assert lim.lower is not None and lim.upper is not None
        f = OLDER_STRENGTH_FACTOR
        return TorqueLimits("human-older", lim.joint_names, lim.lower * f, lim.upper * f)
    return symmetric_limits(scenario.torque_limits)


def policy_config(
    scenario: Scenario, *, gain_scale: float = 1.0, torque_limits: TorqueLimits | None = None
) -> PolicyConfig:
    """The :class:`~biped.control.policy.PolicyConfig` of ``scenario``: its controller, W's set
    point and gains as the scenario gives them, its support mode, the joint-PD holding the initial
    joint angles, its control period, and ``torque_limits`` (default: the scenario's own)."""
    target = Target.wendlandt(
        com=scenario.target_com_m, tilt_deg=scenario.target_tilt_deg, axis=scenario.target_axis
    )
    gains = Gains(
        kp_com=scenario.kp_com, kv_com=scenario.kv_com, kp_rot=scenario.kp_rot, kv_rot=scenario.kv_rot
    )
    if torque_limits is None:
        torque_limits = scenario_limits(scenario)
    elif scenario.torque_limits != "none":
        raise ScenarioError(
            "give torque limits once: the scenario's torque_limits or the torque_limits argument, not both"
        )
    qp_weights = None
    if scenario.distribution == "qp":
        qp_weights = QPWeights(
            moment=scenario.qp_moment_weight,
            friction=scenario.friction,
            min_normal_n=scenario.qp_min_normal_n,
            cop_scale=scenario.qp_cop_scale,
            floor_friction=scenario.qp_floor_friction,  # docs/envelope.md, "Limits against the grid"
            # stepping: trigger "capture" was tuned with massless-leg cones; "qp": the feet-in-place
            # QP until the first step (SteppingConfig.qp_leg_weight for the stepping QP after it)
            leg_weight=0.0
            if scenario.stepping and scenario.step_trigger == "capture"
            else scenario.qp_leg_weight,
        )
    model_path = None if scenario.model == subject.DEFAULT else subject.resolve(scenario.model)
    return PolicyConfig(
        controller=scenario.controller,
        target=target,
        gains=gains,
        support=scenario.support,
        q_ref_deg=tuple(scenario.initial_joint_angles_deg),
        control_period_s=1.0 / scenario.control_rate_hz,
        gain_scale=gain_scale,
        torque_limits=torque_limits,
        distribution=scenario.distribution,
        qp_weights=qp_weights,
        model_path=model_path,
    )


class ControllerPolicy:
    """A :class:`biped.control.policy.Policy` as a loop policy (the time is not used).
    ``policy`` is the control-level policy, ``policy.controller`` the controller object;
    ``sensed``: whether it is given the sensed feet (None: not known, which keeps
    :func:`run_closed_loop` on its Python loop)."""

    __slots__ = ("joint_names", "policy", "sensed")

    def __init__(self, policy, *, sensed: bool | None = None):
        self.policy = policy
        self.joint_names = policy.joint_names
        self.sensed = sensed

    def __call__(self, t: float, qpos: np.ndarray, qvel: np.ndarray, feet) -> np.ndarray:
        return self.policy(qpos, qvel, feet)


def controller_policy(
    scenario: Scenario,
    scene: Scene,
    *,
    gain_scale: float = 1.0,
    torque_limits: TorqueLimits | None = None,
    tree=None,
) -> Callable[[float, np.ndarray, np.ndarray, tuple[bool, bool]], np.ndarray]:
    """The loop policy of ``scenario``'s controller (:func:`policy_config`), torques in
    ``scene.joint_names`` order. ``tree``: a cached :class:`~biped.model.TreeModel` of the biped."""
    config = policy_config(scenario, gain_scale=gain_scale, torque_limits=torque_limits)
    if scenario.stepping:  # not in W: capture-point steps around W's controller
        from biped.control.stepping import SteppingConfig, SteppingController

        stepping = SteppingConfig.for_trigger(scenario.step_trigger, max_steps=scenario.max_steps)
        if scenario.step_reach == "leg":  # the longest step the legs reach, not the fixed 0.5 m
            from dataclasses import replace

            hip, leg = standing_legs(scenario, scene)
            # the swing may reach as far as the stance legs stand long (upright stance: the knee
            # at its 12 deg), never less than the stepper's own reach; the hips sink only as far
            # as both legs at that length need to span the step, at most the stance's drop
            limit = leg_step_limit(scenario, scene, stepping.reach_m, stepping.swing_height_drop_m)
            # the stance knee kept out of the last STANCE_KNEE_MIN_DEG before straight (and no
            # straighter than the starting pose's knee, were it straighter than that)
            knee = min(abs(float(a)) for a in scenario.initial_joint_angles_deg[3::6])
            # the rear foot's friction margin after the step: the feedback stepper's (W's ideal
            # preset); the step program's young lunge lost its 10 deg rest with it (measured)
            feedback = scenario.step_program in ("feedback", "predicted")
            stepping = replace(stepping, reach_m=max(stepping.reach_m, leg), span_leg_m=leg, stand_hip_m=hip,
                               limits=replace(stepping.limits, max_step=limit),
                               stance_knee_min_deg=min(knee, STANCE_KNEE_MIN_DEG),
                               post_step_friction_scale=POST_STEP_FRICTION_SCALE if feedback else None)  # fmt: skip
        # planned steps for a delayed plant
        if scenario.step_program in ("program", "program-predicted", "program-trail"):
            from biped.control.step_program import StepProgram, StepProgramConfig
            from biped.control.swing_plan import SWING_PATHS, TIMED_PATHS, swing_jerk_m_s3

            # on the predicted present (program-predicted) the program's own delay is none
            delay = scenario.feedback_delay_s if scenario.step_program == "program" else 0.0
            path = dict(SWING_PATHS[scenario.swing_path])
            if scenario.swing_path in TIMED_PATHS:  # the swing timed by the hip flexion's rate limit
                from biped.models import JOINT_NAMES
                from biped.sim.neuro import rate_limits

                jerk = swing_jerk_m_s3(float(rate_limits(scenario)[JOINT_NAMES.index("left_hip_flexion")]))
                if math.isfinite(jerk):  # no rate limit: the path's own 0.37 s
                    path["swing_jerk_m_s3"] = jerk
            # program-trail: after the step the rear foot trails (the height capped by the front leg)
            program = StepProgramConfig(delay_s=delay, lead_s=scenario.activation_time_s,
                                        damping_n_m_s=scenario.joint_damping_n_m_s,
                                        rear_trails=scenario.step_program == "program-trail",
                                        **path)  # fmt: skip
            if scenario.step_program in ("program-predicted", "program-trail"):
                return predicted_stepper(scenario, scene, config, stepping, tree, program)
            return StepProgram(config, stepping, scene.joint_names, tree=tree, program=program)
        if scenario.step_program == "predicted":  # the feedback stepper on the predicted present
            return predicted_stepper(scenario, scene, config, stepping, tree)
        return SteppingController(config, stepping, scene.joint_names, tree=tree)
    sensed = config.support == "sensed" or config.distribution == "qp"  # as make_policy decides
    return ControllerPolicy(make_policy(config, scene.joint_names, tree=tree), sensed=sensed)


def predicted_stepper(scenario: Scenario, scene: Scene, config, stepping, tree, program=None):
    """``step_program = "predicted"`` (W's feedback stepper; ``program`` None) or
    ``"program-predicted"`` / ``"program-trail"`` (the step program ``program``) acting on the
    present state its internal forward model (:class:`~biped.control.forward_model.ForwardModel`:
    the scene's own MuJoCo model at the physics step, the loop's contact rule, a copy of the
    nervous system's filter, the lag inverted on it) predicts from the delayed one."""
    from biped.control.forward_model import ForwardModel, PredictedProgram, PredictedStepper
    from biped.control.stepping import SteppingController
    from biped.sim.contact import ContactMonitor
    from biped.sim.neuro import NeuroLoop
    from biped.sim.scene import initial_state

    m = scene.model
    monitor = ContactMonitor.of_scene(scene, scenario.fall_height_m)
    neuro = NeuroLoop(scenario, len(scene.biped_qpos_index), len(scene.biped_qvel_index), scene.joint_names)
    qpos0, qvel0 = initial_state(scene, scenario)
    forward = ForwardModel(m, qpos0, np.zeros_like(qvel0), scene.biped_qpos_index, scene.biped_qvel_index,
                           scene.actuator_index, delay_steps=scenario.delay_steps,
                           substeps=scenario.control_substeps, period=1.0 / scenario.control_rate_hz,
                           alpha=neuro.alpha, rate_step=neuro.rate_step,
                           feet_of=monitor.feet_of,
                           invert_lag=True)  # fmt: skip
    stepper: SteppingController
    if program is None:
        stepper = PredictedStepper(config, stepping, scene.joint_names, tree=tree)
    else:
        stepper = PredictedProgram(config, stepping, scene.joint_names, tree=tree, program=program)
    stepper.forward = forward
    return stepper


#: ``step_reach = "leg"``: the stance knee in single support is kept this far [deg] from straight
#: (or the starting pose's flexion if less): the band the project's tests count as near the straight
#: knee's singularity (tests/test_step_program.py); docs/validate.md, "Why the ideal stopped".
STANCE_KNEE_MIN_DEG = 8.0


#: ``step_reach = "leg"``, the feedback stepper: the double support after the step plans its friction at this share of
#: the floor's (``SteppingConfig.post_step_friction_scale``): the share the sweeps measured for a
#: forward or backward step's stance foot (docs/sweep.md; the "qp" set's 0.55 is for every
#: direction), chosen before any lean was run with it; docs/validate.md, "The rear foot's friction
#: after the step".
POST_STEP_FRICTION_SCALE = 0.35


def standing_legs(scenario: Scenario, scene: Scene) -> tuple[float, float]:
    """(the hip joints' height above the ankle joints, the hip-to-ankle distance) [m], both legs'
    mean, in the scenario's standing pose (MuJoCo's kinematics of the initial state; W's crouch:
    0.642, 0.644 m; human quiet stance, knee 12 deg: 0.819, 0.821 m)."""
    import mujoco

    from biped.sim.scene import w_initial_state

    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:] = w_initial_state(scene, scenario)[0]
    mujoco.mj_kinematics(m, d)
    hip = [d.xpos[m.body(f"{s}_thigh").id] for s in ("left", "right")]
    ank = [d.xpos[m.body(f"{s}_ankle_1").id] for s in ("left", "right")]
    h = np.mean([a[2] - b[2] for a, b in zip(hip, ank, strict=True)])
    length = np.mean([np.linalg.norm(a - b) for a, b in zip(hip, ank, strict=True)])
    return float(h), float(length)


def leg_step_limit(scenario: Scenario, scene: Scene, reach_m: float, drop_m: float = 0.0) -> float:
    """The longest step [m] between the sole centres that the legs reach
    (:func:`biped.control.capture.reach_step_limit`): both legs at ``reach_m`` or the standing
    pose's hip-to-ankle length if longer, from the hip joints ``drop_m`` below their height above
    the ankle joints in the scenario's standing pose (MuJoCo's kinematics of the initial state).
    W's crouch: hips 0.642 m up, 0.884 m with the stepper's 0.78 m reach and no drop, 1.08 m with
    the stance's 0.08 m; human quiet stance (legs 0.821 m, hips 0.819 m up): 0.716 m with it."""
    from biped.control.capture import reach_step_limit

    hip, leg = standing_legs(scenario, scene)
    return reach_step_limit(max(reach_m, leg), max(hip - drop_m, 0.0))


class RecordedTorques:
    """Open-loop policy: row ``round(t * rate_hz)`` of ``torques`` (n, 12) [N m] whatever the
    state (zeros past the last row)."""

    def __init__(self, torques: np.ndarray, rate_hz: float):
        self.torques = np.ascontiguousarray(torques, dtype=float)
        self.rate_hz = float(rate_hz)
        self._zero = np.zeros(self.torques.shape[1])

    def __call__(self, t: float, qpos: np.ndarray, qvel: np.ndarray, feet) -> np.ndarray:
        k = round(t * self.rate_hz)
        return self.torques[k] if k < len(self.torques) else self._zero
