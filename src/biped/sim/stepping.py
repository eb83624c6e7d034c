"""The outcome of a stepping run (scenario key ``stepping``, :mod:`biped.control.stepping`).

Recovered, for a stepping run (docs/controller.md, "Stepping"): the run completed without a fall,
and at its end the central-body COM is within ``recovery_com_tol_m`` of the set point *moved over
the final support polygon* (the controller's ``set_point_com``: W's set point keeps its offset from
the feet's midpoint), its speed is below :data:`RECOVERY_SPEED_M_S`, and the orientation error is
within ``recovery_orientation_tol_deg``. Without a step this is W's rule plus the speed bound.
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["RECOVERY_SPEED_M_S", "stepping_outcome"]

#: Largest central-body COM speed at the end of a recovered stepping run [m/s].
RECOVERY_SPEED_M_S = 0.05


def stepping_outcome(result, policy, *, complete: bool):
    """``result`` (a :class:`biped.sim.push.PushResult`) with the stepping policy's steps in
    ``extra["steps"]``, its final set point as ``target_com``, and ``recovered`` and
    ``final_com_error_m`` by the stepping rule above."""
    steps = [dict(s) for s in policy.steps]
    target = np.asarray(policy.set_point_com, dtype=float)
    n = len(result.times)
    if n:
        com_err = float(np.linalg.norm(result.com[-1] - target))
        speed = float(np.linalg.norm(result.qvel[-1, :3])) if result.qvel is not None else np.nan
    else:
        com_err = speed = float("nan")
    s = result.scenario
    recovered = bool(
        complete
        and not result.fell
        and com_err < s.recovery_com_tol_m
        and speed < RECOVERY_SPEED_M_S
        and result.final_orientation_error_deg < s.recovery_orientation_tol_deg
    )
    extra = {**result.extra, "steps": steps, "final_com_speed_m_s": speed}
    if getattr(policy, "_mid0", None) is not None:  # the feet at the last call, in W's facing
        from biped.control.closing_step import facing_offset

        extra["final_stance_m"] = [float(x) for x in facing_offset(policy)]
    return dataclasses.replace(
        result, target_com=target, final_com_error_m=com_err, recovered=recovered, extra=extra
    )
