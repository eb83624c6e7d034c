"""The push loops' nervous system: the delayed state the controller sees and the filtered torque.

One :class:`NeuroLoop` per run (None for W's ideal controller, whose loop is untouched): a ring
buffer of the last ``delay_steps + 1`` rows of (the biped's qpos, qvel, the contact bits), the
activation/rate filter's state and its constants (:mod:`biped.control.neuromotor`). The Python
loop calls :meth:`NeuroLoop.command`; the compiled loop (:mod:`biped.sim.fused`) gets the same
arrays and does the same in the same order, so both give the same torques bit for bit.

Row k: store row k's (qpos, qvel, bits) at ``k % n``; the controller sees row ``max(k - d, 0)``
(the history before t = 0 is the initial state, standing on both feet); its torque, clipped by the torque limits, goes
through :func:`~biped.control.neuromotor.neural_filter`.
"""

from __future__ import annotations

import math

import numpy as np

from biped import models
from biped.control.neuromotor import OLDER_RATE_FACTOR, human_rate_limits, neural_filter
from biped.models import JOINT_NAMES
from biped.sim.contact import STANDING, feet_of_bits

__all__ = ["NeuroLoop", "neuro_loop", "rate_limits"]


def rate_limits(scenario) -> np.ndarray:
    """``scenario.torque_rate_limit_n_m_s`` as (12,) [N m/s] in :data:`JOINT_NAMES` order (inf: none)."""
    rl = scenario.torque_rate_limit_n_m_s
    if rl == "none":
        return np.full(12, math.inf)
    if rl in ("human", "human-older"):
        factor = OLDER_RATE_FACTOR if rl == "human-older" else 1.0
        return np.array(human_rate_limits(models.total_mass_kg(scenario.model), factor))
    return np.broadcast_to(np.asarray(rl, dtype=float), (12,)).copy()


class NeuroLoop:
    """See the module docstring. ``joint_names``: the order of the loop's torques."""

    def __init__(self, scenario, nq: int, nv: int, joint_names):
        period = 1.0 / scenario.control_rate_hz
        self.delay = scenario.delay_steps
        n = self.delay + 1
        self.ring_q = np.zeros((n, nq))
        self.ring_v = np.zeros((n, nv))
        self.ring_bits = np.zeros(n, dtype=np.int64)
        self.act = np.zeros(len(joint_names))
        tau_a = scenario.activation_time_s
        self.alpha = 1.0 if tau_a == 0 else -math.expm1(-period / tau_a)
        rate = rate_limits(scenario)
        order = [JOINT_NAMES.index(j) for j in joint_names]
        self.rate_step = np.ascontiguousarray(rate[order] * period)
        self.filtered = not (self.alpha == 1.0 and np.all(np.isinf(self.rate_step)))

    def command(self, k: int, t: float, q, v, bits: int, policy, out: np.ndarray) -> None:
        """Row ``k``: store the state, call ``policy(t, q, v, feet)`` on the delayed one, filter its
        torques into ``out`` (12,)."""
        n = len(self.ring_bits)
        i = k % n
        self.ring_q[i] = q
        self.ring_v[i] = v
        self.ring_bits[i] = bits
        j = max(k - self.delay, 0) % n
        # before t = 0 + feedback_delay_s the controller sees both soles down (the subject stood
        # before the run; W's biped starts 5 mm above the floor and lands in a few ms)
        b = int(self.ring_bits[j]) if k >= self.delay else STANDING
        out[:] = policy(t, self.ring_q[j], self.ring_v[j], feet_of_bits(b))
        if self.filtered:
            neural_filter(out, self.act, self.alpha, self.rate_step, k == 0)


def neuro_loop(scenario, scene) -> NeuroLoop | None:
    """The run's :class:`NeuroLoop`, or None for W's ideal controller (``scenario.neuro_ideal``)."""
    if scenario.neuro_ideal:
        return None
    return NeuroLoop(scenario, len(scene.biped_qpos_index), len(scene.biped_qvel_index), scene.joint_names)
