"""The push loop's hot path in one compiled call: contacts, W's controller, records and MuJoCo.

:func:`biped.sim.push.run_closed_loop` runs W's workspace controller (min-norm, printed or QP
distribution; the QP solved by daqp's C function, :mod:`biped.control.daqp_c`, or through numba's
objmode, :mod:`biped.sim.fused_qp`) and the joint-PD
baseline (without gravity compensation), clipped by torque limits or not (not stepping),
through :class:`FusedRows`: one numba call runs up to one progress interval of control
periods, each doing exactly what the Python loop does, in the same order: classify MuJoCo's contacts (the OR of
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

import os
import threading

import mujoco
import numpy as np
from numba import njit, types

from biped.control.buffers import unpack
from biped.control.daqp_c import C_TYPES, c_arguments, c_solve, sync_status
from biped.control.distribution import qp_build, qp_finish
from biped.control.joint_pd import JointPDController
from biped.control.neuromotor import neural_filter
from biped.control.recursions import compute_kernel
from biped.control.workspace import WorkspaceController
from biped.sim import contact as contact_mod
from biped.sim import mjdata
from biped.sim.contact import contact_code
from biped.sim.fused_qp import QP_TYPES, call_solve, qp_arguments, register_qp
from biped.sim.loop_measures import record_row, row_spec
from biped.sim.mjdata import FORCE_SIG, STEP_SIG, contact_frames, mj_function, mj_step_function, mjdata_layout
from biped.sim.schedule import SCHEDULE_TYPES, Schedule, apply_row, kernel_arguments

# why run_rows returned (low 3 bits of its result; the row is result >> 3)
DONE, FELL, LAST, DIVERGED, PYTHON = 0, 1, 2, 3, 4

# bits of a contact pair's code: biped.sim.contact's table (repeated to keep this kernel's
# globals plain ints; tests/test_sim_fused.py checks they agree)
_LYING_BIT = 1 << 5
_LEFT_MASK = 0b0011
_RIGHT_MASK = 0b1100
_STANDING = 0b1111  # biped.sim.neuro.STANDING

# p (int params) entries
P_SUB, P_NCTRL, P_CB, P_F0, P_F1, P_NCON, P_CPTR, P_CBASE, P_SENSED, P_BADQACC, P_NJ, P_CLIP, P_PD = range(13)
P_QP, P_NLIM, P_SLOT = range(13, 16)  # the QP distribution: on, with torque-limit rows, its slot
P_CSOLVE = 16  # the QP solved by daqp's C function (biped.control.daqp_c), not through objmode
P_DELAY, P_NEURO = 17, 18  # feedback delay [periods], the neural filter on (biped.sim.neuro)
P_FLOOR = 19  # the floor geom (biped.sim.loop_measures)
P_SK0, P_SK1, P_SFQ = 20, 21, 22  # the driver's schedule (biped.sim.schedule): first, last row, follow_qpos
_NP = 23

_SIGNATURE = types.int64(
    types.FunctionType(STEP_SIG),  # mj_step
    types.uintp,  # mjModel*
    types.uintp,  # mjData*
    types.int64,  # first row
    types.int64,  # end row (exclusive)
    types.int64[::1],  # p: int params (P_*)
    types.float64,  # fall height [m]
    types.int32[::1],  # the mjData struct as int32 (ncon)
    types.uint64[::1],  # the same as uint64 (the contact pointer)
    types.int32[:, :],  # the contacts' geom pairs (capacity, 2), a strided view of the arena
    types.float64[:, :],  # their positions (capacity, 3), the same
    types.int64[:, ::1],  # pair codes (ngeom, ngeom)
    types.float64[:, ::1],  # seams (ngeom, 2) of the feet's one collision boxes
    types.float64[::1],  # d.qpos
    types.float64[::1],  # d.qvel
    types.float64[::1],  # the biped's qpos (a view of d.qpos)
    types.float64[::1],  # the biped's qvel (a view of d.qvel)
    types.float64[:, ::1],  # d.xipos
    types.float64[:, ::1],  # d.xpos
    types.float64[:, ::1],  # d.xquat
    types.float64[:, ::1],  # d.geom_xpos
    types.float64[:, ::1],  # d.geom_xmat
    types.float64[::1],  # d.ctrl
    types.int64[::1],  # actuator index of each joint
    types.int32[:],  # d.warning.number
    types.float64[::1],  # controller target
    types.float64[::1],  # controller gains
    types.int64[::1],  # controller contact flags (2,)
    types.int64[::1],  # controller ints
    types.float64[::1],  # controller model
    types.float64[::1],  # controller work
    types.float64[::1],  # controller out
    types.float64[::1],  # torque lower bounds (used when p[P_CLIP])
    types.float64[::1],  # torque upper bounds
    types.int64[::1],  # joint PD (when p[P_PD]): qpos address of each joint in the biped's qpos
    types.int64[::1],  # its qvel address
    types.float64[:, ::1],  # (4, nj): qpos offset, q_ref, kp, kd
    types.float64[:, ::1],  # records: qpos
    types.float64[:, ::1],  # qvel
    types.float64[:, ::1],  # com
    types.float64[:, ::1],  # torques
    types.int64[::1],  # contact bits
    types.float64[:, :, ::1],  # feet positions
    types.float64[:, :, ::1],  # feet quaternions
    types.float64[:, ::1],  # the response's row records (biped.sim.loop_measures)
    types.FunctionType(STEP_SIG),  # mj_subtreeVel (the same C signature as mj_step)
    types.FunctionType(FORCE_SIG),  # mj_contactForce
    types.float64[:, :],  # the contacts' frames (capacity, 9), a strided view of the arena
    types.float64[:, ::1],  # scratch for their forces (capacity, 6)
    types.int64[::1],  # each geom's foot (0, 1; -1 none)
    types.int64[::1],  # the limb bodies of loop_measures.LIMB_BODIES
    types.float64[:, ::1],  # d.xmat
    types.float64[:, ::1],  # d.subtree_com
    types.float64[:, ::1],  # d.subtree_linvel
    types.float64[:, ::1],  # neuro (biped.sim.neuro.NeuroLoop): ring of the biped's qpos
    types.float64[:, ::1],  # ring of its qvel
    types.int64[::1],  # ring of the contact bits
    types.float64[::1],  # the neural filter's state (nj,)
    types.float64,  # its lag step alpha
    types.float64[::1],  # its rate step per joint [N m]
    *QP_TYPES,  # the QP distribution (when p[P_QP]): biped.sim.fused_qp
    *C_TYPES,  # its solve in C (when p[P_CSOLVE]): biped.control.daqp_c
    *SCHEDULE_TYPES,  # the driver's schedule (rows p[P_SK0] to p[P_SK1]): biped.sim.schedule
)


# fmt: off
@njit(cache=True, nogil=False)
def _run_rows(  # pragma: no cover - compiled (NUMBA_DISABLE_JIT=1 runs it)
    step, m, d, k0, k1, p, fall_h, s32, s64, geom, cpos, codes, seams, dq, dv, q, v, xipos, xpos, xquat,
    gxpos, gxmat, ctrl, act, warn, target, gains, contact, mi, mf, work, out, lower, upper, pd_q, pd_v, pd,
    rq, rv, rcom, rtau, rbits, rfpos, rfquat, rmeas, subv, cforce, cframe, f6s, footg, limbs, xmat, scom, slin,
    nrq, nrv, nrb, nact, nalpha, nrate, soles, dims, prm, qlo, qhi,
    qa, qt, qf, qtau, qcol, qg, qav, qct, qb, qx, qwg, dqfn, dqaddr, dqres, dqsense, dqupper, dqf, dqx, dqstat,
    sact, sval, sfol, saxis, sbase, starget,
):  # the arguments of _SIGNATURE, in its order
    # fmt: on
    sub, n_ctrl, cb, f0, f1 = p[P_SUB], p[P_NCTRL], p[P_CB], p[P_F0], p[P_F1]
    nj = p[P_NJ]
    nd = p[P_DELAY]
    nring = nrb.shape[0]
    for k in range(k0, k1):  # the driver's inputs of row k first, as its Python apply does
        apply_row(k, p[P_SK0], p[P_SK1], sact, sval, p[P_SFQ], saxis, sbase, sfol, dq, ctrl, starget)
        ncon = s32[p[P_NCON]]
        if ncon and s64[p[P_CPTR]] != np.uint64(p[P_CBASE]):
            return k * 8 + PYTHON  # the contacts moved: the Python loop takes over
        bits = 0
        for i in range(ncon):
            bits |= contact_code(codes, geom[i, 0], geom[i, 1], cpos[i], seams, gxpos, gxmat)
        rbits[k] = bits
        qs, vs, sbits = q, v, bits  # the state the controller sees: now, or feedback_delay_s ago
        if p[P_NEURO]:  # biped.sim.neuro.NeuroLoop.command
            nrq[k % nring, :] = q
            nrv[k % nring, :] = v
            nrb[k % nring] = bits
            jd = max(k - nd, 0) % nring
            qs, vs, sbits = nrq[jd], nrv[jd], nrb[jd] if k >= nd else _STANDING
        if p[P_SENSED]:
            contact[0] = 1 if sbits & _LEFT_MASK else 0
            contact[1] = 1 if sbits & _RIGHT_MASK else 0
        if p[P_PD]:  # JointPDController.compute: kp (q_ref - q) - kd qd, q and qd finite
            finite = True
            for j in range(nj):
                qj = qs[pd_q[j]] - pd[0, j]
                qdj = vs[pd_v[j]]
                finite = finite and np.isfinite(qj) and np.isfinite(qdj)
                out[j] = pd[2, j] * (pd[1, j] - qj) - pd[3, j] * qdj
            if not finite:
                return k * 8 + PYTHON  # the policy's own error comes from Python
        elif compute_kernel(qs, vs, target, gains, contact, mi, mf, work, out) != 0:
            return k * 8 + PYTHON  # the policy's own error (or its retry) comes from Python
        elif p[P_QP]:  # WorkspaceController._run's QP step: build, solve (Python), finish
            ti, tm, tw, to = unpack(mi, mf, work, out)
            meq, used, ff0, ff1 = qp_build(
                tw.g, tw.gl, ti.parent, tm.H, ti.leg, ti.beyond, ti.feet, contact, to.Fd, soles, dims,
                prm, qlo, qhi, p[P_NLIM], qa, qt, qf, qtau, qcol, qg, qav, qct, qb, tm.mass, tm.gravity, qwg,
            )  # fmt: skip
            if contact[0] == 0 and contact[1] == 0:
                qx[:] = 0.0
            elif p[P_CSOLVE]:
                c_solve(
                    dqfn, dqaddr, dqres, meq, used, ff0, ff1, dqsense, dqupper, dqf, qav, qct, qb, qx, dqx, dims,
                    prm, dqstat,
                )  # fmt: skip
            else:
                call_solve(p[P_SLOT], meq, used, ff0, ff1)
            qp_finish(
                qx, contact, qa, qt, soles, to.tau, to.Fl_tilde, to.Fr_tilde, to.Fl, to.Fr, ti.parent, tm.H,
                ti.leg, ti.beyond, tw.gl, qf, p[P_NLIM],
            )  # fmt: skip
        rq[k, :] = dq
        rv[k, :] = dv
        rcom[k, :] = xipos[cb]
        if p[P_CLIP]:  # clip_torques: np.minimum(np.maximum(tau, lower), upper)
            for j in range(nj):
                rtau[k, j] = min(max(out[j], lower[j]), upper[j])
        else:
            for j in range(nj):
                rtau[k, j] = out[j]
        if p[P_NEURO]:
            neural_filter(rtau[k], nact, nalpha, nrate, k == 0)
        if bits & _LYING_BIT or xipos[cb, 2] < fall_h:
            return k * 8 + FELL
        if k == n_ctrl:
            return k * 8 + LAST
        for j in range(nj):
            ctrl[act[j]] = rtau[k, j]
        step(m, d)  # its forward pass computed the kinematics of row k's qpos
        rfpos[k, 0, :] = xpos[f0]
        rfpos[k, 1, :] = xpos[f1]
        rfquat[k, 0, :] = xquat[f0]
        rfquat[k, 1, :] = xquat[f1]
        if s32[p[P_NCON]] and s64[p[P_CPTR]] != np.uint64(p[P_CBASE]):
            rmeas[k, 0] = np.nan  # the contacts moved: run_closed_loop redoes the row (fill_rows)
        else:  # the response's row: this step's forward pass at row k's state
            record_row(
                subv, cforce, m, d, s32[p[P_NCON]], geom, cpos, cframe, f6s, footg, p[P_FLOOR], cb, limbs, xpos,
                xmat, scom, slin, rmeas[k],
            )  # fmt: skip
        for _ in range(sub - 1):
            step(m, d)
        if warn[p[P_BADQACC]] != 0:
            return k * 8 + DIVERGED
    return k1 * 8 + DONE


def _key_cache_by_what_it_compiles_in() -> None:
    """numba keys a cached kernel by its own source file only, but :func:`_run_rows` compiles the
    controller's kernel into itself: key it by those files too (recursions, statics, buffers,
    spatial, distribution, fused_qp, cones, daqp_c, contact, neuromotor), so that an edit of the
    controller recompiles the loop instead of loading stale code. Uses numba's cache internals (as
    :func:`biped.sim.jit.is_cached` does); without them, numba's own key stands."""
    import biped.control.buffers
    import biped.control.cones
    import biped.control.distribution
    import biped.control.neuromotor
    import biped.control.recursions
    import biped.control.statics
    import biped.spatial
    from biped.control import daqp_c
    from biped.sim import fused_qp, loop_measures, schedule

    modules = (
        biped.control.recursions,
        biped.control.statics,
        biped.control.buffers,
        biped.spatial,
        biped.control.distribution,
        fused_qp,
        biped.control.cones,
        daqp_c,
        contact_mod,
        biped.control.neuromotor,
        loop_measures,
        schedule,
    )
    try:
        cache_file = _run_rows._cache._cache_file  # type: ignore[attr-defined]
        stats = [os.stat(str(m.__file__)) for m in modules]
        extra = tuple((st.st_mtime, st.st_size) for st in stats)
        cache_file._source_stamp = (cache_file._source_stamp, extra)
    except (AttributeError, OSError, TypeError):  # pragma: no cover - another numba, or no cache
        pass


_key_cache_by_what_it_compiles_in()


#: Why the compiled loop was last refused for a run (for :func:`refusal`), or None.
last_failure: str | None = None


_COMPILE_LOCK = threading.Lock()


def compile_kernel() -> None:
    """Compile :func:`_run_rows` for its one signature (or load it from numba's cache); a no-op once
    done, or when numba's JIT is disabled."""
    # a lock: two threads of one process (a Dask worker's) would race between the check and
    # disable_compile(), and the second one's compile() then raises "compilation disabled"
    with _COMPILE_LOCK:
        if not hasattr(_run_rows, "compile") or _run_rows.signatures:
            return
        _run_rows.compile(_SIGNATURE)
        _run_rows.disable_compile()


def fused_controller(policy):
    """(the controller behind a loop ``policy``: a
    :class:`~biped.control.workspace.WorkspaceController` or a
    :class:`~biped.control.joint_pd.JointPDController`; whether it takes the sensed feet; its
    torque limits or None) if the compiled loop can run it (not the joint PD's gravity
    compensation); else None."""
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
    (see :func:`biped.sim.push.run_closed_loop`). ``run(k0, k1)`` -> (row, why)."""

    def __init__(self, *, model, data, scene, scenario, controller, sensed, limits, codes, seams, records):
        step = mj_step_function()
        subtree_vel, contact_force = mj_function("mj_subtreeVel", STEP_SIG), mj_function("mj_contactForce", FORCE_SIG)
        found = step is not None and subtree_vel is not None and contact_force is not None
        lay = mjdata_layout(model, data) if found else None
        if lay is None:
            why = mjdata.last_failure if found else "libmujoco's mj_step, mj_subtreeVel or mj_contactForce not found"
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
        contact = ws._both.copy() if not sensed else np.ones(2, dtype=np.int64)
        qp_args = qp_arguments(ws.qp)
        keep: list = []
        csolve, c_args = c_arguments(ws.qp, keep)
        self._qp = ws.qp if csolve else None
        self._qstat: np.ndarray = c_args[-1]
        if ws.qp is not None:
            p[P_QP], p[P_NLIM] = 1, 1 if ws.qp.limited else 0
            p[P_SLOT] = register_qp(self, ws.qp)
            p[P_CSOLVE] = 1 if csolve else 0
        self._keep = (lay, data, keep)  # the views point into data's memory, the addresses into keep
        self._args = (
            step,
            int(model._address),
            int(data._address),
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
            np.ascontiguousarray(ws.target.array, dtype=float),
            np.ascontiguousarray(ws.gains.array, dtype=float),
            contact,
            ws._mi,
            ws._mf,
            ws._work,
            ws._out,
            lower,
            upper,
            pd_q,
            pd_v,
            pd,
        )
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
            + qp_args
            + c_args
        )
        # one call through the dispatcher checks every argument against the signature (no rows
        # run); later calls go straight to the compiled entry point, without numba's typing of
        # the arguments (~10 us a call instead of ~27 us)
        p[P_SK0], p[P_SK1], p[P_SFQ] = 1, 0, -1  # no schedule (set_schedule)
        self._sched = kernel_arguments(None)
        a = self._args
        _run_rows(a[0], a[1], a[2], 0, 0, *a[3:], *self._records, *self._sched)
        self._call = _run_rows.overloads[_run_rows.signatures[0]].entry_point  # type: ignore[attr-defined]

    def set_schedule(self, s: Schedule) -> None:
        """Apply the driver's schedule at the top of each of its rows (:mod:`biped.sim.schedule`)."""
        self._sched = kernel_arguments(s)
        p = self._args[3]
        p[P_SK0], p[P_SK1], p[P_SFQ] = s.first, s.last, s.follow_qpos

    def run(self, k0: int, k1: int) -> tuple[int, int]:
        a = self._args
        code = self._call(a[0], a[1], a[2], k0, k1, *a[3:], *self._records, *self._sched)
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
        return FusedRows(
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
