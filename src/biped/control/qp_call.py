"""The controller's call with the QP distribution as one compiled function: W Alg. 1-4
(:func:`biped.control.recursions.compute_kernel`), the QP's build, its solve by daqp's C function
(:func:`biped.control.daqp_c.c_solve`, with ContactQP.solve's fallbacks) and the torques
(:func:`biped.control.distribution.qp_finish`).

:meth:`biped.control.WorkspaceController.torques` with ``distribution="qp"`` otherwise makes four
calls from Python (the kernel, ``ContactQP.build``, ``solve`` through ``daqp.solve``, ``finish``),
each unboxing its arrays, and daqp's Python entry alone costs several microseconds;
:func:`qp_kernel` takes the kernel's four flat buffers and the ContactQP's two
(:mod:`biped.control.qp_buffers`), allocates nothing and gives the same numbers: the same
compiled build and finish, and daqp's own C function on the same arrays
(``tests/test_qp_call.py``).

numba caches this function with the compiled :func:`~biped.control.qp_buffers.qp_views` inside it
and checks only this file's stamp: a change of the buffers' layout there (e.g. ``PRM``, the
entries of ``QPWeights.array``, 10 since ``floor_friction``, 12 since ``edge_contact``; ``dims`` (2, 4)
since the edge contact; ``cmap`` at the end since the stance
contact map) needs an edit here too, or the cached copy reads the old layout.
"""

from __future__ import annotations

from numba import njit

from biped.control.buffers import borrowed, unpack
from biped.control.cones import map_contact_rows
from biped.control.daqp_c import c_solve
from biped.control.distribution import qp_build, qp_finish
from biped.control.qp_buffers import (
    H_FN,
    H_FRESH,
    H_GQ,
    H_LIMITED,
    H_RES,
    H_ROWS,
    S_F0,
    S_F1,
    S_MEQ,
    S_USED,
    qp_int_views,
    qp_views,
)
from biped.control.recursions import compute_kernel

__all__ = ["qp_kernel"]


@njit(cache=True)
def qp_kernel(qpos, qvel, target, gains, contact, ints, floats):  # pragma: no cover
    """One controller call with the QP distribution (the kernel's ``mode`` must be
    STOP_AFTER_ALG4); the kernel's status (nonzero: the QP is not touched). ``ints`` = the lengths
    of (mi, mf, work, out), then the kernel's ``mi`` and the ContactQP's ``qi``; ``floats`` = the
    kernel's ``mf``, ``work``, ``out`` and the ContactQP's ``qf`` (WorkspaceController's views)."""
    # the ~100 views below without reference counting (biped.control.buffers.borrowed)
    ints, floats = borrowed(ints), borrowed(floats)  # type: ignore[call-arg]
    a, b, c = ints[1], ints[1] + ints[2], ints[1] + ints[2] + ints[3]
    mi, qi = ints[4 : 4 + ints[0]], ints[4 + ints[0] :]
    mf, work, out, qf = floats[:a], floats[a:b], floats[b:c], floats[c:]
    status = compute_kernel(qpos, qvel, target, gains, contact, mi, mf, work, out)
    if status != 0:
        return status
    t, m, w, o = unpack(mi, mf, work, out)
    nj = t.n[0] - 1
    rows = qi[H_ROWS]
    soles, dims, prm, lo, hi, A, T, F, tau, col, Gq, av, Ct, b, x, wg, upper, f, xs, _, cmap = qp_views(
        qf, nj, rows
    )
    qstat, res32, sense = qp_int_views(qi, rows)
    nlim = qi[H_LIMITED] != 0
    meq, used, f0, f1 = qp_build(
        w.g, w.gl, t.parent, m.H, t.leg, t.beyond, t.feet, contact, o.Fd, soles, dims, prm, lo, hi, nlim,
        A, T, F, tau, col, Gq, av, Ct, b, m.mass, m.gravity, wg,
    )  # fmt: skip
    map_contact_rows(Ct, b, f0, f1, cmap)
    if contact[0] == 0 and contact[1] == 0:
        x[:] = 0.0
        qstat[S_MEQ], qstat[S_USED], qstat[S_F0], qstat[S_F1] = meq, used, f0, f1
    else:
        c_solve(
            qi[H_FN], qi[H_RES : H_GQ + 1], res32, meq, used, f0, f1, sense, upper, f, av, Ct, b, x, xs,
            dims, prm, qstat,
        )  # fmt: skip
    qi[H_FRESH] = 1
    qp_finish(x, contact, A, T, soles, o.tau, o.Fl_tilde, o.Fr_tilde, o.Fl, o.Fr, t.parent, m.H, t.leg,
              t.beyond, w.gl, F, nlim)  # fmt: skip
    return 0
