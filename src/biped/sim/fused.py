"""The push loop's hot path in one compiled call: contacts, W's controller, records and MuJoCo.

:func:`biped.sim.push.run_closed_loop` runs W's workspace controller (min-norm, printed or QP
distribution; the QP solved by daqp's C function, :mod:`biped.control.daqp_c`, or through numba's
objmode, :mod:`biped.sim.fused_qp`) and the joint-PD
baseline (without gravity compensation), clipped by torque limits or not, and a stepping
policy's double support and plain swings (:mod:`biped.sim.fused_step`: the other swings and
the touchdowns go back to Python), through
:class:`FusedRows` (the kernel: :mod:`biped.sim.fused_kernel`): one numba call runs up to one
progress interval of control periods, each doing exactly what the Python loop does, in the same
order: classify MuJoCo's contacts (the OR of
:func:`~biped.sim.contact.contact_code` over ``data.contact``), call
:func:`biped.control.recursions.compute_kernel` (or the joint PD's law) on the live qpos/qvel
views, record the row, write ``ctrl`` and call MuJoCo's C ``mj_step`` through its function pointer (``libmujoco``'s own
symbol, the library the Python bindings use). The events, fall and block-hit time are then
rebuilt from the recorded contact bits by the same :class:`~biped.sim.contact.ContactMonitor`
state machine, so a result is bit for bit the Python loop's (``tests/test_sim_fused.py``).
Anything unusual (a controller status other than 0, the contact buffer not where it was) hands
the row back to the Python loop, which reproduces the policy's own error or retry.

Reading MuJoCo's ``mjData`` from compiled code needs two numbers the bindings do not expose:
where ``ncon`` lives in the struct (right after the ``timer`` array, whose address the bindings
do give) and where the contacts are (MuJoCo puts them at the start of the arena, so their address
is fixed for an ``MjData``; the loop checks the struct's ``contact`` pointer every period).
:func:`mjdata_layout` derives both and checks them against ``data.ncon`` / ``data.contact``; when
a check fails (another MuJoCo layout) it returns None and the Python loop runs instead.

Limits: a MuJoCo *error* (not a warning) inside ``mj_step`` cannot unwind through compiled code
and would abort the process; for this scene MuJoCo raises none (contact and constraint overflow
are warnings, which reach ``biped.sim.mjlog`` as before; a Python warning handler that raises
aborts the Python loop too). Ctrl-C is seen between calls (every 0.05 s of simulated time, 0.5 s
when the run reports no progress).
"""

from __future__ import annotations

import mujoco
import numpy as np

from biped.control.daqp_c import c_arguments, sync_status
from biped.control.joint_pd import JointPDController
from biped.control.workspace import WorkspaceController
from biped.sim import fused_step, mjdata
from biped.sim.fused_kernel import (  # noqa: F401 - the kernel's names, offered here as before
    _LEFT_MASK,
    _LYING_BIT,
    _NP,
    _RIGHT_MASK,
    _SIGNATURE,
    DIVERGED,
    DONE,
    FELL,
    LAST,
    P_BADQACC,
    P_CB,
    P_CBASE,
    P_CLIP,
    P_CPTR,
    P_CSOLVE,
    P_DELAY,
    P_F0,
    P_F1,
    P_FLOOR,
    P_NCON,
    P_NCTRL,
    P_NEURO,
    P_NJ,
    P_NLIM,
    P_PD,
    P_QP,
    P_SENSED,
    P_SFQ,
    P_SK0,
    P_SK1,
    P_SLOT,
    P_STEP,
    P_SUB,
    PYTHON,
    _run_rows,
    compile_kernel,
)
from biped.sim.fused_qp import qp_arguments, register_qp
from biped.sim.loop_measures import row_spec
from biped.sim.mjdata import FORCE_SIG, STEP_SIG, contact_frames, mj_function, mj_step_function, mjdata_layout
from biped.sim.schedule import Schedule, kernel_arguments

#: Why the compiled loop was last refused for a run (for :func:`refusal`), or None.
last_failure: str | None = None


def fused_controller(policy):
    """(the controller behind a loop ``policy``: a
    :class:`~biped.control.workspace.WorkspaceController` or a
    :class:`~biped.control.joint_pd.JointPDController`; whether it takes the sensed feet; its
    torque limits or None) if the compiled loop can run it (not the joint PD's gravity
    compensation); else None. A stepping policy (:mod:`biped.sim.fused_step`): its controller
    before the first step, its own sensed-feet rule (False here), its limits."""
    if fused_step.is_stepping(policy):
        if getattr(policy, "forward", None) is not None:
            return None  # step_program "predicted": its forward model records every period in Python
        if policy.stepping.span_leg_m is not None:
            return None  # step_reach = "leg": the double support's set point is leg-capped in Python
        ctrl = policy._ctrl_before
        if not isinstance(ctrl, WorkspaceController) or tuple(policy.joint_names) != tuple(ctrl.joint_names):
            return None
        return ctrl, False, policy.limits
    sensed = getattr(policy, "sensed", None)
    inner = getattr(policy, "policy", None)
    ctrl = getattr(inner, "controller", None)
    if sensed is None or inner is None:
        return None
    if not isinstance(ctrl, (WorkspaceController, JointPDController)) or getattr(
        ctrl, "gravity_compensation", False
    ):
        return None
    if tuple(inner.joint_names) != tuple(ctrl.joint_names):
        return None
    limits = inner.limits  # in joint_names order (make_policy reorders them)
    if limits is not None and tuple(limits.joint_names) != tuple(ctrl.joint_names):
        return None
    return ctrl, bool(sensed), limits


__all__ = [
    "DIVERGED",
    "DONE",
    "FELL",
    "LAST",
    "PYTHON",
    "FusedRows",
    "compile_kernel",
    "diverged_message",
    "fused_controller",
    "fused_rows",
    "refusal",
    "mjdata_layout",
    "sync_monitor",
]


class FusedRows:
    """The compiled loop bound to one run's MuJoCo data, controller and record arrays
    (see :func:`biped.sim.push.run_closed_loop`). ``run(k0, k1)`` -> (row, why). ``stepping``: a
    stepping policy's :class:`~biped.sim.fused_step.SteppingRows` (the controller it calls is
    bound again whenever the policy's double support changes controller, set point or gains)."""

    def __init__(
        self,
        *,
        model,
        data,
        scene,
        scenario,
        controller,
        sensed,
        limits,
        codes,
        seams,
        records,
        stepping=None,
    ):
        step = mj_step_function()
        subtree_vel, contact_force = (
            mj_function("mj_subtreeVel", STEP_SIG),
            mj_function("mj_contactForce", FORCE_SIG),
        )
        found = step is not None and subtree_vel is not None and contact_force is not None
        lay = mjdata_layout(model, data) if found else None
        if lay is None:
            why = (
                mjdata.last_failure
                if found
                else "libmujoco's mj_step, mj_subtreeVel or mj_contactForce not found"
            )
            raise LookupError(f"the compiled loop cannot read this MuJoCo's data: {why}")
        s32, s64, cptr_i, cbase, geom, cpos = lay
        frames = contact_frames(model, data, cbase)
        spec = row_spec(scene)
        ncon_i = mjdata._OFFSETS[0][0]
        compile_kernel()
        iq, iv = scene.biped_qpos_index, scene.biped_qvel_index
        nj = len(controller.joint_names)
        p = np.zeros(_NP, dtype=np.int64)
        p[P_SUB] = scenario.control_substeps
        p[P_NCTRL] = scenario.control_steps
        p[P_CB] = scene.central_body
        p[P_F0], p[P_F1] = records["feet_bodies"]
        p[P_NCON], p[P_CPTR], p[P_CBASE] = ncon_i, cptr_i, np.int64(np.uint64(cbase).view(np.int64))
        p[P_SENSED] = 1 if sensed else 0
        p[P_BADQACC] = int(mujoco.mjtWarning.mjWARN_BADQACC)
        p[P_FLOOR] = spec.floor
        p[P_NJ] = nj
        p[P_CLIP] = 0 if limits is None else 1
        lower = np.full(nj, -np.inf) if limits is None else np.ascontiguousarray(limits.lower, dtype=float)
        upper = np.full(nj, np.inf) if limits is None else np.ascontiguousarray(limits.upper, dtype=float)
        pd_q, pd_v, pd = np.zeros(nj, dtype=np.int64), np.zeros(nj, dtype=np.int64), np.zeros((4, nj))
        if isinstance(controller, WorkspaceController):
            ws = controller
        else:  # the joint PD: its own arrays; the workspace controller's are placeholders
            p[P_PD] = 1
            pd_q[:], pd_v[:] = controller._qadr, controller._vadr
            pd[:] = controller._qoff, controller.q_ref, controller.gains.kp, controller.gains.kd
            ws = WorkspaceController(controller.tree)
        self._p = p
        self._contact = ws._both.copy() if not sensed else np.ones(2, dtype=np.int64)
        self._bound: dict = {}  # each controller's QP arguments, once a run
        self._keep = (lay, data)  # the views point into data's memory
        self._head = (step, int(model._address), int(data._address))
        self._pre = (
            p,
            float(scenario.fall_height_m),
            s32,
            s64,
            geom,
            cpos,
            codes,
            seams,
            data.qpos,
            data.qvel,
            data.qpos[int(iq[0]) : int(iq[0]) + len(iq)],
            data.qvel[int(iv[0]) : int(iv[0]) + len(iv)],
            data.xipos,
            data.xpos,
            data.xquat,
            data.geom_xpos,
            data.geom_xmat,
            data.ctrl,
            np.ascontiguousarray(scene.actuator_index[:nj], dtype=np.int64),
            data.warning.number,
        )
        self._post = (lower, upper, pd_q, pd_v, pd)
        neuro = records.get("neuro")
        if neuro is None:  # placeholders: W's ideal controller reads the live state
            ring = (np.zeros((1, len(iq))), np.zeros((1, len(iv))), np.zeros(1, dtype=np.int64))
            filt: tuple = (np.zeros(nj), 1.0, np.full(nj, np.inf))
        else:
            p[P_DELAY], p[P_NEURO] = neuro.delay, 1
            ring = (neuro.ring_q, neuro.ring_v, neuro.ring_bits)
            filt = (neuro.act, float(neuro.alpha), neuro.rate_step)
            if not neuro.filtered:  # the delay alone: the filter's constants make it a no-op
                filt = (neuro.act, 1.0, np.full(nj, np.inf))
        measures = (
            records["measures"],
            subtree_vel,
            contact_force,
            frames,
            np.empty((geom.shape[0], 6)),  # each floor contact's row is written before it is read
            spec.foot_of_geom,
            spec.limbs,
            data.xmat,
            data.subtree_com,
            data.subtree_linvel,
        )
        self._records = (
            tuple(records[k] for k in ("qpos", "qvel", "com", "torques", "bits", "feet_pos", "feet_quat"))
            + measures
            + ring
            + filt
        )
        self._stepping = stepping
        if stepping is not None:
            p[P_STEP] = 1
            self._steps = stepping.args
        else:
            self._steps = fused_step.placeholder_arguments(step)
        # one call through the dispatcher checks every argument against the signature (no rows
        # run); later calls go straight to the compiled entry point, without numba's typing of
        # the arguments (~10 us a call instead of ~27 us)
        p[P_SK0], p[P_SK1], p[P_SFQ] = 1, 0, -1  # no schedule (set_schedule)
        self._sched = kernel_arguments(None)
        self._bind(ws, ws.target.array, ws.gains.array)
        _run_rows(*self._head, 0, 0, *self._args)
        self._call = _run_rows.overloads[_run_rows.signatures[0]].entry_point  # type: ignore[attr-defined]

    def _bind(self, ws, target, gains) -> None:
        """Call ``ws`` (W's controller) with the set point and gains arrays ``target``, ``gains``."""
        got = self._bound.get(id(ws))
        if got is None:
            keep: list = []
            csolve, c_args = c_arguments(ws.qp, keep)
            slot = register_qp(self, ws.qp) if ws.qp is not None else 0
            got = self._bound[id(ws)] = (ws, qp_arguments(ws.qp), csolve, c_args, slot, keep)
        _, qp_args, csolve, c_args, slot, _ = got
        p = self._p
        p[P_QP], p[P_NLIM], p[P_SLOT], p[P_CSOLVE] = 0, 0, 0, 0
        if ws.qp is not None:
            p[P_QP], p[P_NLIM] = 1, 1 if ws.qp.limited else 0
            p[P_SLOT] = slot
            p[P_CSOLVE] = 1 if csolve else 0
        self._qp = ws.qp if csolve else None
        self._qstat: np.ndarray = c_args[-1]
        self._now = (ws, target, gains)
        arrays = (np.ascontiguousarray(target, dtype=float), np.ascontiguousarray(gains, dtype=float))
        ctrl = (*arrays, self._contact, ws._mi, ws._mf, ws._work, ws._out)
        self._args = (
            self._pre + ctrl + self._post + self._records + qp_args + c_args + self._sched + self._steps
        )

    def set_schedule(self, s: Schedule) -> None:
        """Apply the driver's schedule at the top of each of its rows (:mod:`biped.sim.schedule`)."""
        self._sched = kernel_arguments(s)
        p = self._p
        p[P_SK0], p[P_SK1], p[P_SFQ] = s.first, s.last, s.follow_qpos
        self._bind(*self._now)

    def run(self, k0: int, k1: int) -> tuple[int, int]:
        stepping = self._stepping
        if stepping is not None:
            now = stepping.enter()
            if now is None:  # the policy's own period (a swing, a touchdown): the Python loop
                return k0, PYTHON
            if any(a is not b for a, b in zip(now, self._now, strict=True)):
                self._bind(*now)
        code = self._call(*self._head, k0, k1, *self._args)
        if stepping is not None:
            stepping.leave()
        if self._qp is not None:  # the C solve's status and fallback counts onto the ContactQP
            sync_status(self._qp, self._qstat)
        return code >> 3, code & 7


def sync_monitor(monitor, bits, com, period: float, a: int, b: int, data) -> None:
    """Feed rows [a, b) of a compiled run's contact ``bits`` to ``monitor`` (its
    :meth:`~biped.sim.contact.ContactMonitor.record`) where they can change its state: the first
    row, a change of bits, the last row (a fall; ``data`` then holds that row's state)."""
    if b <= a:
        return
    seg = bits[a:b]
    prev = np.empty_like(seg)
    prev[0] = monitor.bits
    prev[1:] = seg[:-1]
    rows = set((np.flatnonzero(seg != prev) + a).tolist())
    rows.add(b - 1)
    if a == 0:
        rows.add(0)
    for k in sorted(rows):
        monitor.record(k * period, int(bits[k]), com[k, 2], data)


def fused_rows(scene, scenario, policy, model, data, monitor, records) -> FusedRows | None:
    """The :class:`FusedRows` of one run of ``policy`` (see
    :func:`biped.sim.push.run_closed_loop`), or None if it cannot have one."""
    found = fused_controller(policy)
    if found is None or not hasattr(_run_rows, "compile"):  # (NUMBA_DISABLE_JIT=1: Python loop)
        return None
    try:
        stepping = None
        if fused_step.is_stepping(policy):
            stepping = fused_step.SteppingRows(policy, 1.0 / scenario.control_rate_hz)
        return FusedRows(
            stepping=stepping,
            model=model,
            data=data,
            scene=scene,
            scenario=scenario,
            controller=found[0],
            sensed=found[1],
            limits=found[2],
            codes=monitor.pair_codes,
            seams=monitor.seams,
            records=records,
        )
    except LookupError as exc:
        global last_failure
        last_failure = str(exc)
        return None


def refusal() -> str:
    """The error of ``run_closed_loop(..., compiled=True)`` when the run cannot have the loop."""
    why = f" ({last_failure})" if last_failure else ""
    return f"this policy or run cannot use the compiled loop (compiled=True){why}"


def diverged_message(t: float, period: float) -> str:
    """``PushResult.diverged`` for a divergence in the control period starting at ``t`` [s]."""
    return (
        f"MuJoCo's integration diverged (non-finite accelerations) between "
        f"t = {t:.4f} s and {t + period:.4f} s"
    )
