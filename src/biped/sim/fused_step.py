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
and gains of the moment). A plain swing (:func:`biped.control.swing_period.compiled_swing`) runs
compiled too: the controller's ``mj_forward`` and ``mj_subtreeVel``, the capture point,
:func:`biped.control.swing_period.period` (the landing target, the ankle's path, the stance's
flags, the COM acceleration written into the bound set point, :class:`SteppingRows`'s
``target``) and W's swing law (:func:`biped.control.swing_kernel.law`), then the loop calls the
swing's controller (the single-sole QP) and puts the swing leg's torques in its place. A step
starting, the settling switch, the touchdown and the other swings (crossovers, closing steps, the
step program's, the opt-in stance models) go back to the Python loop, one period at a time.
The controller's carried state is loaded before and stored after each compiled stretch, so the
run is the Python loop's bit for bit (``tests/test_sim_fused_step.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, types

from biped._numba_cache import key_by_sources
from biped.control import mj_functions, swing_kernel
from biped.control import step_trigger as trig
from biped.control import swing_period as sp
from biped.control.mj_functions import mj_address
from biped.control.swing_kernel import law
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
    # the plain swing compiled (biped.control.swing_period, biped.control.swing_kernel)
    types.FunctionType(STEP_SIG),  # mj_forward
    types.uintp,  # mj_jacBody's address
    types.uintp,  # mj_fullM's address
    types.float64[::1],  # d.qfrc_bias
    types.float64[::1],  # d.qfrc_passive
    *(types.float64[:, ::1],) * 3,  # the swing law's scratch: jacp, jacr (3, nv), mass matrix (nv, nv)
    types.float64[::1],  # the swing law's gains (swing_kernel.NG)
    types.float64[::1],  # the swing's parameters (swing_period.NP)
    types.int64[::1],  # its int parameters (swing_period.NW; I_ON: a swing runs compiled)
    types.float64[::1],  # its state (swing_period.NS)
    types.float64[::1],  # its state after the period
    types.float64[::1],  # its outputs (swing_period.NO: path, COM acceleration, swing torques)
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
    ffwd,
    jac,
    fullm,
    bias,
    passive,
    jp,
    jr,
    mm,
    lawg,
    wprm,
    wints,
    wst,
    wpend,
    wout,
    target,
):  # pragma: no cover - compiled
    """Row ``k`` of a stepping run up to W's controller: in double support
    ``SteppingController.__call__(k * period, qs, vs, feet of sbits)`` but the controller call
    (:func:`~biped.control.step_trigger.double_support`); in a plain swing (``wints[I_ON]``) its
    forward pass, capture point, :func:`biped.control.swing_period.period` and the swing law (the
    torques into ``wout``, the COM acceleration into ``target``); GO or HAND_BACK."""
    for j in range(qs.shape[0]):
        if not np.isfinite(qs[j]):
            return trig.HAND_BACK
        sq[j] = qs[j]
    for j in range(vs.shape[0]):
        if not np.isfinite(vs[j]):
            return trig.HAND_BACK
        sv[j] = vs[j]
    t = k * prm[trig.Q_PERIOD]
    left, right = (sbits & _LEFT_MASK) != 0, (sbits & _RIGHT_MASK) != 0
    if wints[sp.I_ON] == 0:
        fk(sm, sd)
        fcp(sm, sd)
        fcv(sm, sd)
        fsv(sm, sd)
        return trig.double_support(
            t, left, right, scom[0], slin[0], sxpos, sxmat, st, pend, prm, ints, contact
        )
    ffwd(sm, sd)  # SteppingController.__call__: mj_forward, mj_subtreeVel
    fsv(sm, sd)
    omega, xi0, xi1 = trig.capture(t, scom[0], slin[0], st, pend, prm)
    i = wints[sp.I_SW]
    down = left if i == 0 else right
    if sp.period(t, down, xi0, xi1, omega, scom[0, 0], scom[0, 1], sxpos, sxmat, wprm, wints, wst, wpend, wout,
                 contact) != sp.GO:  # fmt: skip
        return trig.HAND_BACK  # the touchdown: Python's
    if not (np.isfinite(wout[sp.O_ACC]) and np.isfinite(wout[sp.O_ACC + 1])):
        return trig.HAND_BACK  # (Python's set point raises its error)
    target[6] = wout[sp.O_ACC]
    target[7] = wout[sp.O_ACC + 1]
    target[8] = 0.0
    law(
        jac, fullm, sm, sd, wints[sp.I_FOOT + i], wints[sp.I_SHANK], wprm[sp.P_INV],
        wints[sp.I_DOFS : sp.I_DOFS + 6], wints[sp.I_QADR : sp.I_QADR + 6], sq, sv, sxpos, sxmat, bias, passive,
        jp, jr, mm, lawg, wout[sp.O_PD : sp.O_PD + 3], wout[sp.O_VD : sp.O_VD + 3], wout[sp.O_AD : sp.O_AD + 3],
        wout[sp.O_TAU : sp.O_TAU + 6],
    )  # fmt: skip
    return trig.GO


# its cache keyed by the files whose constants and kernels it compiles in (the feet masks, the
# trigger), not only its own: a changed mask never runs stale (biped._numba_cache.key_by_sources)
key_by_sources(stepping_row, (contact_mod, trig, sp, swing_kernel, mj_functions))


def placeholder_arguments(step_fn) -> tuple:
    """:data:`STEP_TYPES` arguments of a run without stepping (never called)."""
    z1, z2, i1 = np.zeros(1), np.zeros((1, 1)), np.zeros(sp.NW, dtype=np.int64)
    return (step_fn,) * 4 + (0, 0, z1, z1, z2, z2, z2, z2, z1, z1, z1, i1[:1]) + (
        step_fn, 0, 0, z1, z1, z2, z2, z2, z1, z1, i1, z1, z1, z1,
    )  # fmt: skip


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
        m, s = policy.model, policy.stepping
        ffwd = mj_function("mj_forward", STEP_SIG)
        if ffwd is None:
            raise LookupError("libmujoco's mj_forward not found")
        self.plan = sp.SwingPlan()  # the plain swing's arrays (its own: the policy's are Python's)
        self.target = np.zeros(19)  # the swing's set point, its COM acceleration written each row
        law_g = [s.kp_pos, s.kv_pos, s.kp_rot, s.kv_rot, s.ankle_kp, s.ankle_kv, s.swing_torque_max_n_m]
        pl = self.plan
        self.args += (
            ffwd,
            mj_address("mj_jacBody"),
            mj_address("mj_fullM"),
            d.qfrc_bias,
            d.qfrc_passive,
            np.zeros((3, m.nv)),
            np.zeros((3, m.nv)),
            np.zeros((m.nv, m.nv)),
            np.array(law_g, dtype=float),
            pl.prm,
            pl.ints,
            pl.st,
            pl.pend,
            pl.out,
        )

    def enter(self):
        """(W's controller, set point array, gains array) of the policy's next compiled periods
        (double support, or a plain swing: :func:`biped.control.swing_period.compiled_swing`), its
        state and parameters loaded; None if the next period is Python's (another swing, a weight
        transfer, a first call)."""
        p = self.policy
        pl = self.plan
        pl.ints[sp.I_ON] = 0
        if p.phase == "swing" and p._mid0 is not None and sp.compiled_swing(p):
            i = p.swing
            trig.load(p, self.st)
            trig.params(p, self.prm, self.ints, self.period)
            pl.load(p)
            pl.ints[sp.I_ON] = 1
            self.target[:] = p._swing_set_point(p._swing_com(i)).array
            return p._ctrl_swing, self.target, p._swing_gains.array
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
        if self.plan.ints[sp.I_ON]:
            self.plan.store(self.policy, self.plan.st)
