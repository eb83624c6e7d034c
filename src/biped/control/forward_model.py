"""An internal forward model over the feedback delay (scenario key ``step_program = "predicted"``;
docs/validate.md, "The predicted step").

A controller that acts on the state of ``feedback_delay_s`` ago can still act on the present if it
predicts it: from the delayed state, run a model of the body forward over the delay with the
torques it has itself sent since (their efference copy, through its own copy of the muscles'
activation lag and rate limit). That is a Smith predictor (Smith 1957), and the cerebellum's
forward model in the account of Miall, Weir, Wolpert & Stein 1993 (J Motor Behav 25:203-216,
"Is the cerebellum a Smith predictor?") and Wolpert, Miall & Kawato 1998 (Trends Cogn Sci
2:338-347, "Internal models in the cerebellum"); van der Kooij et al. 1999 (Biol Cybern
80:299-308) model human stance with such an internal model.

:class:`ForwardModel` is the body's own MuJoCo scene (floor and contacts; no external forces: a
perturbation is not known to it) integrated at the plant's physics step: an *exact* internal
model, the most prediction can give (no model error, no sensory noise). What it cannot undo:
an unannounced event (the lean's release) is seen only ``feedback_delay_s`` late, and the
activation lag and rate limit still shape every torque the joints get.

:class:`Predicting` puts it in front of a stepping controller: once the controller is armed (the
lean release: when the release is seen), each call predicts the present state and feet from the
delayed ones and runs the controller on them; every command is recorded (the efference copy).
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from biped.control.limits import clip_torques
from biped.control.neuromotor import neural_filter
from biped.control.step_program import StepProgram
from biped.control.stepping import SteppingController

__all__ = ["ForwardModel", "PredictedProgram", "PredictedStepper", "Predicting"]


class ForwardModel:
    """The body's scene ``model`` run forward over ``delay_steps`` control periods.

    ``qpos0``, ``qvel0``: a full scene state (the parts the biped does not own, e.g. a parked
    block, are taken from it); ``iq``, ``iv``: the biped's qpos/qvel in the scene; ``actuators``:
    the scene actuator of each command entry; ``substeps``: physics steps per control period;
    ``alpha``, ``rate_step``: the activation lag's step and the most a torque changes per period
    (:func:`~biped.control.neuromotor.neural_filter`, in the commands' order); ``feet_of(data)``:
    (left, right) soles on the floor in a scene state (the loop's contact rule)."""

    def __init__(self, model: mujoco.MjModel, qpos0, qvel0, iq, iv, actuators, *, delay_steps: int,
                 substeps: int, period: float, alpha: float, rate_step,
                 feet_of: Callable[[mujoco.MjData], tuple[bool, bool]], invert_lag: bool = False):  # fmt: skip
        self.model = model
        self.data = mujoco.MjData(model)
        self.qpos0 = np.array(qpos0, dtype=float)
        self.qvel0 = np.array(qvel0, dtype=float)
        self.iq, self.iv = np.asarray(iq), np.asarray(iv)
        self.actuators = np.asarray(actuators)
        self.delay = int(delay_steps)
        self.substeps = int(substeps)
        self.period = float(period)
        self.alpha = float(alpha)
        self.rate_step = np.ascontiguousarray(rate_step, dtype=float)
        self.feet_of = feet_of
        self.invert_lag = invert_lag
        self.reset()

    def reset(self) -> None:
        n = max(self.delay, 1)
        self.sent = np.zeros((n, len(self.actuators)))  # the joints' torques of the last rows
        self.act = np.zeros(len(self.actuators))  # the copy of the muscles' filter state

    def inverse(self, tau) -> np.ndarray:
        """The command whose lagged torque is ``tau`` next period (the lag inverted on the copy of
        its state): ``act + (tau - act) / alpha``."""
        return self.act + (np.asarray(tau, dtype=float) - self.act) / self.alpha

    def row(self, t: float) -> int:
        return round(t / self.period)

    def record(self, k: int, command) -> None:
        """The command of row ``k`` (efference copy): through the copy of the filter, kept as the
        torque the joints get in row ``k``."""
        tau = np.array(command, dtype=float)
        neural_filter(tau, self.act, self.alpha, self.rate_step, k == 0)
        self.sent[k % len(self.sent)] = tau

    def predict(self, k: int, qpos, qvel) -> tuple[np.ndarray, np.ndarray, tuple[bool, bool]]:
        """(qpos, qvel, feet) of row ``k`` predicted from row ``k - delay_steps``'s ``qpos``,
        ``qvel`` and the torques recorded for the rows between."""
        m, d = self.model, self.data
        d.qpos[:] = self.qpos0
        d.qvel[:] = self.qvel0
        d.qpos[self.iq] = qpos
        d.qvel[self.iv] = qvel
        d.qacc_warmstart[:] = 0.0
        d.time = 0.0
        for r in range(max(k - self.delay, 0), k):
            d.ctrl[self.actuators] = self.sent[r % len(self.sent)]
            mujoco.mj_step(m, d, self.substeps)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        return d.qpos[self.iq].copy(), d.qvel[self.iv].copy(), self.feet_of(d)


class Predicting:
    """A mixin in front of a stepping controller (``SteppingController`` or a subclass): set
    ``self.forward`` (a :class:`ForwardModel`) after its ``__init__``. Once armed
    (``arm_time_s``), the controller runs on the predicted present state."""

    forward: ForwardModel

    def __call__(self, t: float, qpos, qvel, feet):
        fm = self.forward
        k = fm.row(t)
        if t >= self.arm_time_s and fm.delay > 0:  # type: ignore[attr-defined]
            qpos, qvel, feet = fm.predict(k, qpos, qvel)
        tau = super().__call__(t, qpos, qvel, feet)  # type: ignore[misc]
        if fm.invert_lag and k > 0 and fm.alpha < 1.0:
            tau = fm.inverse(tau)
            if self.limits is not None:  # type: ignore[attr-defined]
                tau = clip_torques(tau, self.limits)  # type: ignore[attr-defined]
        fm.record(k, tau)
        return tau

    def reset(self) -> None:
        super().reset()  # type: ignore[misc]
        if hasattr(self, "forward"):
            self.forward.reset()


class PredictedStepper(Predicting, SteppingController):
    """W's feedback stepper on the forward model's prediction of the present state
    (``step_program = "predicted"``)."""


class PredictedProgram(Predicting, StepProgram):
    """The step program on the forward model's prediction of the present state
    (``step_program = "program-predicted"``)."""
