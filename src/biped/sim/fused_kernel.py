"""The compiled push loop's kernel: :func:`_run_rows`, its one signature and its numba cache key.

See :mod:`biped.sim.fused` (the Python side: binding a run's MuJoCo data, controller and records,
and why the result is the Python loop's bit for bit). Stepping runs add
:func:`biped.sim.fused_step.stepping_row` before W's controller (``p[P_STEP]``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, types

from biped._numba_cache import compile_once, key_by_sources
from biped.control.buffers import unpack
from biped.control.daqp_c import C_TYPES, c_solve
from biped.control.distribution import qp_build, qp_finish
from biped.control.neuromotor import neural_filter
from biped.control.recursions import compute_kernel
from biped.control.swing_period import I_ON as I_SWING_ON
from biped.control.swing_period import I_TAU as I_SWING_TAU
from biped.control.swing_period import O_TAU as O_SWING_TAU
from biped.sim import contact as contact_mod
from biped.sim.contact import _LEFT_MASK, _LYING_BIT, _RIGHT_MASK, STANDING, contact_code
from biped.sim.fused_qp import QP_TYPES, call_solve
from biped.sim.fused_step import STEP_TYPES, stepping_row
from biped.sim.loop_measures import record_row
from biped.sim.mjdata import FORCE_SIG, STEP_SIG
from biped.sim.schedule import SCHEDULE_TYPES, apply_row

# why run_rows returned (low 3 bits of its result; the row is result >> 3)
DONE, FELL, LAST, DIVERGED, PYTHON = 0, 1, 2, 3, 4

# p (int params) entries
P_SUB, P_NCTRL, P_CB, P_F0, P_F1, P_NCON, P_CPTR, P_CBASE, P_SENSED, P_BADQACC, P_NJ, P_CLIP, P_PD = range(13)
P_QP, P_NLIM, P_SLOT = range(13, 16)  # the QP distribution: on, with torque-limit rows, its slot
P_CSOLVE = 16  # the QP solved by daqp's C function (biped.control.daqp_c), not through objmode
P_DELAY, P_NEURO = 17, 18  # feedback delay [periods], the neural filter on (biped.sim.neuro)
P_FLOOR = 19  # the floor geom (biped.sim.loop_measures)
P_SK0, P_SK1, P_SFQ = 20, 21, 22  # the driver's schedule (biped.sim.schedule): first, last row, follow_qpos
P_STEP = 23  # a stepping policy's double support (biped.sim.fused_step)
_NP = 24

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
    *STEP_TYPES,  # the stepping policy (when p[P_STEP]): biped.sim.fused_step
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
    fk, fcp, fcv, fsv, sm, sd, sq, sv, sxpos, sxmat, sscom, sslin, sst, spend, sprm, sints,
    sfwd, sjac, sfullm, sbias, spassive, sjp, sjr, smm, slawg, wprm, wints, wst, wpend, wout,
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
            qs, vs, sbits = nrq[jd], nrv[jd], nrb[jd] if k >= nd else STANDING
        if p[P_SENSED]:
            contact[0] = 1 if sbits & _LEFT_MASK else 0
            contact[1] = 1 if sbits & _RIGHT_MASK else 0
        if p[P_STEP] and stepping_row(
            k, qs, vs, sbits, fk, fcp, fcv, fsv, sm, sd, sq, sv, sxpos, sxmat, sscom, sslin, sst, spend, sprm,
            sints, contact, sfwd, sjac, sfullm, sbias, spassive, sjp, sjr, smm, slawg, wprm, wints, wst, wpend, wout,
            target,
        ):  # fmt: skip
            return k * 8 + PYTHON  # a step starts (or Python must decide): the policy's own call
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
        if p[P_STEP] and wints[I_SWING_ON]:  # a plain swing: the swing leg's own torques
            for j in range(6):
                out[wints[I_SWING_TAU + j]] = wout[O_SWING_TAU + j]
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
        if p[P_STEP]:  # the period ran: its stepping state is the policy's now
            sst[:] = spend
            if wints[I_SWING_ON]:
                wst[:] = wpend
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
    spatial, distribution, fused_qp, cones, daqp_c, contact, neuromotor, loop_measures, schedule,
    step_trigger, fused_step; the plain swing's swing_period, swing_kernel, mj_functions), so that an edit of the
    controller recompiles the loop instead of loading stale code. Uses numba's cache internals (as
    :func:`biped.sim.jit.is_cached` does); without them, numba's own key stands."""
    import biped.control.buffers
    import biped.control.cones
    import biped.control.distribution
    import biped.control.neuromotor
    import biped.control.recursions
    import biped.control.statics
    import biped.spatial
    from biped.control import daqp_c, mj_functions, step_trigger, swing_kernel, swing_period
    from biped.sim import fused_qp, fused_step, loop_measures, schedule

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
        step_trigger,
        fused_step,
        swing_period,
        swing_kernel,
        mj_functions,
    )
    key_by_sources(_run_rows, modules)


_key_cache_by_what_it_compiles_in()


def compile_kernel() -> None:
    """Compile :func:`_run_rows` for its one signature (or load it from numba's cache); a no-op once
    done, or when numba's JIT is disabled."""
    compile_once(_run_rows, _SIGNATURE)
