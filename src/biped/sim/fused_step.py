"""The stepping controller in the compiled push loop (:mod:`biped.sim.fused`).

A stepping run (:class:`~biped.control.stepping.SteppingController`, also its
:class:`~biped.control.step_program.StepProgram`) is double support most of the time: before its
first step exactly the feet-in-place controller, after a touchdown W's controller over the new
feet. Those periods run in the compiled loop: :func:`stepping_row` does the controller's forward
pass of the state it sees (``mj_kinematics``, ``mj_comPos``, ``mj_comVel``, ``mj_subtreeVel`` on
the controller's own ``MjData``, through libmujoco's C functions: the fields it reads are those
of the controller's ``mj_forward`` and ``mj_subtreeVel``) and
:func:`biped.control.step_trigger.double_support` (capture point, trigger, contact flags); the loop
then calls W's controller, the one :class:`SteppingRows` bound for the stretch
(:func:`~biped.control.step_trigger.double_support_controller`, with the controller's set point
and gains of the moment). A step starting, the settling switch, the swing and the touchdown go
back to the Python loop, one period at a time: the swing runs ``SteppingController`` itself
(its task-space swing leg, the stance QP and the touchdown; a few hundred microseconds of Python
a period), and after the touchdown the compiled loop takes over again with the new set point.
The controller's carried state is loaded before and stored after each compiled stretch, so the
run is the Python loop's bit for bit (``tests/test_sim_fused_step.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, types

from biped._numba_cache import key_by_sources
from biped.control import step_trigger as trig
from biped.sim import contact as contact_mod
from biped.sim.contact import _LEFT_MASK, _RIGHT_MASK
from biped.sim.mjdata import STEP_SIG, mj_function

__all__ = ["STEP_TYPES", "SteppingRows", "placeholder_arguments", "stepping_row"]

#: the stepping's arguments of the compiled loop (biped.sim.fused_kernel._SIGNATURE)
STEP_TYPES = (
    *(types.FunctionType(STEP_SIG),) * 4,  # mj_kinematics, mj_comPos, mj_comVel, mj_subtreeVel
    types.uintp,  # the controller's mjModel*
    types.uintp,  # its mjData*
    types.float64[::1],  # its d.qpos
    types.float64[::1],  # d.qvel
    *(types.float64[:, ::1],) * 4,  # d.xpos, d.xmat, d.subtree_com, d.subtree_linvel
    types.float64[::1],  # the state (step_trigger.NS)
    types.float64[::1],  # the state after the period
    types.float64[::1],  # the parameters (step_trigger.NQ)
    types.int64[::1],  # the int parameters (step_trigger.NI)
)

_FUNCTIONS = ("mj_kinematics", "mj_comPos", "mj_comVel", "mj_subtreeVel")


@njit(cache=True)
def stepping_row(
    k,
    qs,
    vs,
    sbits,
    fk,
    fcp,
    fcv,
    fsv,
    sm,
    sd,
    sq,
    sv,
    sxpos,
    sxmat,
    scom,
    slin,
    st,
    pend,
    prm,
    ints,
    contact,
):  # pragma: no cover - compiled
    """Row ``k`` of a stepping run in double support up to W's controller:
    ``SteppingController.__call__(k * period, qs, vs, feet of sbits)`` but the controller call
    (:func:`~biped.control.step_trigger.double_support`); GO or HAND_BACK."""
    for j in range(qs.shape[0]):
        if not np.isfinite(qs[j]):
            return trig.HAND_BACK
        sq[j] = qs[j]
    for j in range(vs.shape[0]):
        if not np.isfinite(vs[j]):
            return trig.HAND_BACK
        sv[j] = vs[j]
    fk(sm, sd)
    fcp(sm, sd)
    fcv(sm, sd)
    fsv(sm, sd)
    t = k * prm[trig.Q_PERIOD]
    left, right = (sbits & _LEFT_MASK) != 0, (sbits & _RIGHT_MASK) != 0
    return trig.double_support(t, left, right, scom[0], slin[0], sxpos, sxmat, st, pend, prm, ints, contact)


# its cache keyed by the files whose constants and kernels it compiles in (the feet masks, the
# trigger), not only its own: a changed mask never runs stale (biped._numba_cache.key_by_sources)
key_by_sources(stepping_row, (contact_mod, trig))


def placeholder_arguments(step_fn) -> tuple:
    """:data:`STEP_TYPES` arguments of a run without stepping (never called)."""
    z1, z2 = np.zeros(1), np.zeros((1, 1))
    return (step_fn,) * 4 + (0, 0, z1, z1, z2, z2, z2, z2, z1, z1, z1, np.zeros(1, dtype=np.int64))


def is_stepping(policy) -> bool:
    from biped.control.stepping import SteppingController

    return isinstance(policy, SteppingController)


class SteppingRows:
    """A stepping policy's side of the compiled loop: its :data:`STEP_TYPES` arguments
    (``args``), and at each compiled call :meth:`enter` (None while Python must run the period,
    else the controller, set point and gains to bind) and :meth:`leave`."""

    def __init__(self, policy, period: float):
        fns = [mj_function(n, STEP_SIG) for n in _FUNCTIONS]
        if any(f is None for f in fns):
            raise LookupError("libmujoco's mj_kinematics, mj_comPos, mj_comVel or mj_subtreeVel not found")
        names = tuple(policy.ctrl.joint_names)
        if tuple(policy.joint_names) != names:
            raise LookupError("the stepping policy's joint order is not its controller's")
        self.policy = policy
        self.period = float(period)
        d = policy.data
        self.st, self.pend = np.zeros(trig.NS), np.zeros(trig.NS)
        self.prm, self.ints = np.zeros(trig.NQ), np.zeros(trig.NI, dtype=np.int64)
        self.args = (
            *fns,
            int(policy.model._address),
            int(d._address),
            d.qpos,
            d.qvel,
            d.xpos,
            d.xmat,
            d.subtree_com,
            d.subtree_linvel,
            self.st,
            self.pend,
            self.prm,
            self.ints,
        )

    def enter(self):
        """(W's controller, set point array, gains array) of the policy's next double-support
        periods, its state and parameters loaded; None if the next period is Python's (a swing,
        a weight transfer, a first call)."""
        p = self.policy
        if p.phase != "double" or p._mid0 is None:
            return None
        if p.stepping.rest_damping_compensation and p._settled:  # (its added torques: Python's)
            return None
        trig.load(p, self.st)
        trig.params(p, self.prm, self.ints, self.period)
        return trig.double_support_controller(p), p.target.array, p.gains.array

    def leave(self) -> None:
        """The state of the compiled periods back into the policy."""
        trig.store(self.policy, self.st)
