"""A contact-feasible replacement for W Alg. 5: the desired wrench split by a small QP.

W's Alg. 5 splits ``F_1^bd`` between the feet by the minimum-norm solution of
``F_1^bd = G [F_l; F_r]``. Nothing keeps that split inside what a sole can carry: it asks for roll
moments a 9 cm wide sole cannot give, the feet rock on their edges and, with no torque limit, the
commanded torques grow without bound. ``distribution="qp"`` solves instead, at every call,

    minimize   (G w - F_1^bd)^T W (G w - F_1^bd) + w^T R w + s (f_z,l - f_z,r)^2
    over       w = [w_l; w_r], each foot's ground wrench [f; tau] in its SOLE frame at the sole centre
    subject to per foot in contact: the contact wrench cone of a rectangular sole (Caron, Pham &
               Nakamura, ICRA 2015: friction pyramid |f_x|, |f_y| <= mu f_z, centre of pressure
               inside the sole |tau_x| <= Y f_z, |tau_y| <= X f_z, and the eight yaw-moment rows),
               f_z >= f_min; these rows hold the ground's wrench, w_foot plus the leg's own weight
               (:mod:`biped.control.cones`: all but the far edge's CoP row and the yaw rows);
               per foot not in contact: w_foot = 0;
               with torque limits: lo <= J_leg^T F~_leg <= hi for every leg joint, linear in w
               because each leg's torques are tau_leg = J_leg^T Ad^T_{g_{sole,1}} w_foot (W Alg. 6);

``W = diag(force, force, force, moment, moment, moment)`` weighs the rows of the central-body
wrench error (by default moment rows 100 /(N m)^2, force rows 1 /N^2: when ``F_1^bd`` is out of
reach the COM force gives way before the trunk's moment; chosen by push-recovery envelopes, the
other way round survived less), ``R`` and ``s`` are small regularisations
(:class:`QPWeights`, documented in docs/controller.md). ``X``, ``Y`` (half length and half width)
and the sole frame come from the MJCF's sole geoms (:func:`biped.model.sole_rectangles`).

Solver: daqp (Arnstroem, Bemporad & Axehill, IEEE TAC 2022: a dual active-set method for small
dense QPs) called directly on preallocated matrices that a compiled function fills; quadprog
(Goldfarb-Idnani) solves the same problem (``solver="quadprog"``). docs/controller.md has the
measured comparison (daqp about 2x faster on this problem, same solution).

Failure handling (never an exception in the loop): if the QP is infeasible (the minimum normal
force together with the torque limits cannot be met), it is solved again on the massless-leg
cones with ``f_min = 0``, for which ``w = 0`` is feasible; if that fails too (numerically),
every foot wrench and torque is zero.
``ContactQP.status`` tells which happened at the last call and ``ContactQP.fallbacks`` counts them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from biped.control.cones import (
    ROWS_PER_FOOT,
    cone_rows,
    contact_rows,
    foot_rows,
    map_contact_rows,
    sole_to_body,
)
from biped.control.daqp_c import bind_c, unconstrained
from biped.control.qp_buffers import (
    H_LIMITED,
    H_ROWS,
    QPState,
    float_size,
    int_size,
    qp_int_views,
    qp_views,
    solve_flat,
)
from biped.control.recursions import alg6_torques
from biped.control.statics import sole_torque_map
from biped.errors import ScenarioError

__all__ = ["RELAXED", "SOLVED", "ZEROED", "ContactQP", "QPWeights", "cone_rows"]

#: ContactQP.status values
SOLVED, RELAXED, ZEROED = 0, 1, 2


@dataclass(frozen=True)
class QPWeights:
    """Weights and contact parameters of the QP distribution (SI units).

    force, moment: weights of the force [1/N^2] and moment [1/(N m)^2] rows of the error between
        the feet's summed wrench and ``F_1^bd`` at the central body.
    reg_force, reg_moment: regularisation of each foot's force and moment (sole frame, sole centre).
    split: regularisation of the difference of the two normal forces (f_z,l - f_z,r)^2.
    min_normal_n: minimum normal force of a foot in contact [N].
    max_normal_n: maximum normal force of a foot [N] (default 3 body weights of the 73 kg model):
        bounds the wrenches, hence the torques, that an exploding F_1^bd (a leg near its
        stretched-knee singularity, where P_1 grows without bound) can command.
    friction: Coulomb coefficient of the sole-floor contact (the scenario's ``friction``).
    friction_scale: the QP's pyramid uses ``friction * friction_scale`` (1/sqrt(2): the pyramid
        inscribed in the circular cone that the scene's elliptic MuJoCo contact has).
    cop_scale: the centre of pressure is kept inside the sole rectangle shrunk about its centre
        by this factor (1: the whole sole; < 1 keeps it off the edges the foot would tip about).
    leg_weight: share in [0, 1] of each leg's weight that the cone rows add to the leg's share
        (:func:`biped.control.cones.carry_leg_weight`; 0: the legs taken as massless).
    floor_friction: the friction pyramid on the floor's axes, not the sole's (a sole tilted on
        an edge; :func:`biped.control.cones.floor_friction_rows`; the stepping QP sets it).
    edge_contact: a foot pitched onto an end's edge (toe or heel) is a line contact along it
        (:func:`biped.control.cones.edge_contact`); opt-in (docs/controller.md, "A foot on an edge").
    edge_lift_m: (start, full) heights of the raised end [m]: the whole sole up to start, the line
        from full on, the far edge moving linearly between.
    """

    force: float = 1.0
    moment: float = 100.0
    reg_force: float = 1e-6
    reg_moment: float = 1e-5
    split: float = 1e-5
    min_normal_n: float = 10.0
    max_normal_n: float = 2150.0
    friction: float = 0.3
    friction_scale: float = 1.0 / math.sqrt(2.0)
    cop_scale: float = 1.0
    leg_weight: float = 1.0
    floor_friction: bool = False
    edge_contact: bool = False
    edge_lift_m: tuple[float, float] = (0.005, 0.015)
    array: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        for name in (
            "force",
            "moment",
            "reg_force",
            "reg_moment",
            "friction",
            "friction_scale",
            "max_normal_n",
            "cop_scale",
        ):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ScenarioError(f"QP weight {name} must be a finite number > 0; got {v!r}")
        for name in ("split", "min_normal_n"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ScenarioError(f"QP weight {name} must be a finite number >= 0; got {v!r}")
        lw = self.leg_weight
        if not (isinstance(lw, (int, float)) and 0.0 <= lw <= 1.0):
            raise ScenarioError(f"QP leg_weight must be a share of the legs' weight in [0, 1]; got {lw!r}")
        e0, e1 = self.edge_lift_m
        if not (math.isfinite(e0) and math.isfinite(e1) and 0.0 <= e0 < e1):
            raise ScenarioError(
                f"QP edge_lift_m must be (start, full) with 0 <= start < full; got {(e0, e1)!r}"
            )
        arr = np.array(
            [
                self.force,
                self.moment,
                self.reg_force,
                self.reg_moment,
                self.split,
                self.min_normal_n,
                self.friction * self.friction_scale,
                self.max_normal_n,
                self.leg_weight,
                1.0 if self.floor_friction else 0.0,
                self.edge_lift_m[0] if self.edge_contact else -1.0,
                self.edge_lift_m[1],
            ],
            dtype=float,
        )
        if self.max_normal_n <= self.min_normal_n:
            raise ScenarioError(
                f"QP max_normal_n ({self.max_normal_n} N) must exceed min_normal_n ({self.min_normal_n} N)"
            )
        object.__setattr__(self, "array", arr)


# ----------------------------------------------------------------------------- compiled parts


@njit(cache=True)
def qp_build(
    g,
    gl,
    parent,
    H,
    leg,
    beyond,
    feet,
    contact,
    Fd,
    soles,
    dims,
    prm,
    lo,
    hi,
    nlim,
    A,
    T,
    F,
    tau_tmp,
    col,
    Gq,
    av,
    Ct,
    b,
    mass,
    grav,
    wg,
):
    """Fill the QP (quadprog's form: minimize 1/2 x^T Gq x - av^T x s.t. Ct x >= b, the first
    ``meq`` rows equalities) from the kernel's poses ``g`` and joint transforms ``gl`` and the
    desired wrench ``Fd``; also the maps ``A[f] = Ad^T_{g_{sole_f,1}}`` (6, 6) and the torque
    map ``T`` (n_joints, 12): tau = T x. Returns (meq, rows used, first row of each foot's cone)."""
    nj = T.shape[0]
    for f in range(2):
        sole_to_body(g[feet[f]], soles[f], g[0], A[f])
    # torque map, needed only for the torque-limit rows (qp_finish applies Alg. 6 once
    # otherwise): Alg. 6 in closed form, the legs' Jacobians in the sole frames
    if nlim:
        sole_torque_map(g, H, leg, beyond, feet, soles, T)
    # cost: sum_r W_r (A_r x - Fd_r)^2 + reg + split
    for i in range(12):
        av[i] = 0.0
        for j in range(12):
            Gq[i, j] = 0.0
    for r in range(6):
        w = prm[0] if r < 3 else prm[1]
        for i in range(12):
            ai = A[i // 6, r, i % 6]
            if ai == 0.0:
                continue
            av[i] += w * ai * Fd[r]
            for j in range(12):
                Gq[i, j] += w * ai * A[j // 6, r, j % 6]
    for f in range(2):
        for c in range(6):
            Gq[6 * f + c, 6 * f + c] += prm[2] if c < 3 else prm[3]
    Gq[2, 2] += prm[4]
    Gq[8, 8] += prm[4]
    Gq[2, 8] -= prm[4]
    Gq[8, 2] -= prm[4]
    # constraints: equalities (feet in the air) first
    m = 0
    for f in range(2):
        if contact[f] == 0:
            for c in range(6):
                for i in range(12):
                    Ct[m, i] = 0.0
                Ct[m, 6 * f + c] = 1.0
                b[m] = 0.0
                m += 1
    meq = m
    first0 = first1 = -1
    for f in range(2):
        if contact[f] != 0:
            if f == 0:
                first0 = m
            else:
                first1 = m
            m = foot_rows(g, feet[f], soles[f], dims, f, prm, leg, mass, grav, wg, Ct, b, m)
    if nlim:
        for j in range(nj):
            side = leg[j + 1] if beyond[j + 1] == 0 else -1
            if side < 0 or contact[side] == 0:
                continue
            for i in range(12):
                Ct[m, i] = T[j, i]
                Ct[m + 1, i] = -T[j, i]
            b[m] = lo[j]
            b[m + 1] = -hi[j]
            m += 2
    used = m
    for r in range(m, Ct.shape[0]):  # padding: 0 >= -1, never active
        for i in range(12):
            Ct[r, i] = 0.0
        b[r] = -1.0
    return meq, used, first0, first1


@njit(cache=True)
def qp_finish(x, contact, A, T, soles, tau, Fl_tilde, Fr_tilde, Fl, Fr, parent, H, leg, beyond, gl, F, nlim):
    """From the foot wrenches x (12,) (sole frames): the legs' shares F~ = A_f x_f (central-body
    frame), joint torques (tau = T x with the torque map of the limit rows, else W Alg. 6 of the
    shares: the same linear map) and the feet's wrenches in their COM frames. A foot not in
    contact gets exactly zero (the solver's equality holds to rounding only)."""
    for f in range(2):
        if contact[f] == 0:
            for c in range(6):
                x[6 * f + c] = 0.0
    for f in range(2):
        out = Fl_tilde if f == 0 else Fr_tilde
        for r in range(6):
            s = 0.0
            for c in range(6):
                s += A[f, r, c] * x[6 * f + c]
            out[r] = s
    if nlim:
        for j in range(T.shape[0]):
            s = 0.0
            for i in range(12):
                s += T[j, i] * x[i]
            tau[j] = s
    else:
        alg6_torques(parent, H, leg, beyond, gl, Fl_tilde, Fr_tilde, F, tau)
    for f in range(2):
        # foot COM frame: F_foot = Ad^T_{g_{sole,foot}} w, g_{sole,foot} = (R^T, -R^T p) of g_{foot,sole}
        # = [R f; R tau + p x (R f)] with (R, p) = g_{foot,sole}
        gfs = soles[f]
        w = x[6 * f : 6 * f + 6]
        ff = Fl if f == 0 else Fr
        for i in range(3):
            ff[i] = gfs[i, 0] * w[0] + gfs[i, 1] * w[1] + gfs[i, 2] * w[2]
        for i in range(3):
            ff[3 + i] = gfs[i, 0] * w[3] + gfs[i, 1] * w[4] + gfs[i, 2] * w[5]
        p0, p1, p2 = gfs[0, 3], gfs[1, 3], gfs[2, 3]
        f0, f1, f2 = ff[0], ff[1], ff[2]
        ff[3] += p1 * f2 - p2 * f1
        ff[4] += p2 * f0 - p0 * f2
        ff[5] += p0 * f1 - p1 * f0


# ----------------------------------------------------------------------------- the object


class ContactQP(QPState):
    """Preallocated QP distribution for one :class:`~biped.control.WorkspaceController`.

    ``soles``: (left, right) :class:`~biped.model.SoleRectangle`; ``weights``: :class:`QPWeights`;
    ``lower``, ``upper``: (n_joints,) torque limits in the controller's joint order [N m] or None;
    ``solver``: "daqp" (default) or "quadprog" (the same problem; for the comparison).
    """

    @staticmethod
    def buffer_sizes(tree, limited: bool) -> tuple[int, int]:
        """Lengths of the float and int buffers (:mod:`biped.control.qp_buffers`) of a ContactQP on
        ``tree``, with torque limits or without."""
        nj = tree.n_links - 1
        n_lim = sum(1 for j in range(nj) if tree.leg[j + 1] >= 0 and not tree.beyond_foot[j + 1])
        rows = 2 * ROWS_PER_FOOT + (2 * n_lim if limited else 0)
        return float_size(nj, rows), int_size(rows)

    def __init__(
        self,
        tree,
        soles,
        weights: QPWeights | None = None,
        lower=None,
        upper=None,
        solver: str = "daqp",
        buffers: tuple[np.ndarray, np.ndarray] | None = None,
    ):
        if solver not in ("quadprog", "daqp"):
            raise ScenarioError(f"unknown QP solver {solver!r}; valid: 'quadprog', 'daqp'")
        self.weights = weights or QPWeights()
        self.solver = solver
        nj = tree.n_links - 1
        self._tree = tree
        self._beyond = tree.beyond_foot.astype(np.int64)
        self.soles = soles
        if (lower is None) != (upper is None):
            raise ScenarioError("torque limits for the QP need both lower and upper bounds, or neither")
        self.limited = lower is not None
        lo = np.zeros(nj) if lower is None else np.asarray(lower, dtype=float)
        hi = np.zeros(nj) if upper is None else np.asarray(upper, dtype=float)
        if lo.shape != (nj,) or hi.shape != (nj,):
            raise ScenarioError(
                f"QP torque limits need {nj} lower and upper bounds; got {lo.shape}, {hi.shape}"
            )
        n_lim = sum(1 for j in range(nj) if tree.leg[j + 1] >= 0 and not tree.beyond_foot[j + 1])
        rows = 2 * ROWS_PER_FOOT + (2 * n_lim if self.limited else 0)
        # every array a view of two flat buffers (biped.control.qp_buffers: one compiled call takes them)
        if buffers is None:
            self._qf = np.zeros(float_size(nj, rows))
            self._qi = np.zeros(int_size(rows), dtype=np.int64)
        else:  # the caller's (zeroed) buffers: the controller keeps them beside its own
            self._qf, self._qi = buffers
            if self._qf.shape != (float_size(nj, rows),) or self._qi.shape != (int_size(rows),):
                raise ValueError("ContactQP buffers of the wrong size; use ContactQP.buffer_sizes")
        self._qi[H_LIMITED], self._qi[H_ROWS] = self.limited, rows
        (self._soles, self._dims, self._prm, self._lo, self._hi, self.A, self.T, self._F, self._tau, self._col,
         self.Gq, self.av, self.Ct, self.b, self.x, self.wg, self._upper, self._f, self._xs, self._lam,
         self.cmap) = qp_views(
            self._qf, nj, rows
        )  # fmt: skip
        self._qstat, self._res32, self._sense = qp_int_views(self._qi, rows)
        self._soles[:] = np.stack([s.g_foot_sole for s in soles])
        self._dims[:, :2] = self.weights.cop_scale * np.array([[s.half_length, s.half_width] for s in soles])
        self._dims[:, 2] = self._dims[:, 0]  # the part of the sole in use (qp_build: cones.edge_contact)
        self._lo[:], self._hi[:] = lo, hi
        self._prm[:] = self.weights.array
        self._meq = 0
        self._rows = 0
        self._first = (-1, -1)
        self._status = SOLVED
        self._fallbacks = {RELAXED: 0, ZEROED: 0}
        self._upper[:] = 1e30  # daqp's upper bounds: none, b itself on equality rows
        self._meq_sense = 0
        self._c = None
        if solver == "quadprog":
            import quadprog

            self._quadprog = quadprog.solve_qp
        else:
            import daqp

            self._daqp = daqp.solve
            self._c = bind_c(self)  # daqp's C function for compiled calls, or None

    def build(self, g, gl, contact, Fd):
        """Fill the QP for one state (the kernel's work buffers ``g``, ``gl`` and ``F_1^bd``)."""
        t = self._tree
        meq, used, f0, f1 = qp_build(
            g,
            gl,
            t.parent,
            t.H,
            t.leg,
            self._beyond,
            t.feet,
            contact,
            Fd,
            self._soles,
            self._dims,
            self._prm,
            self._lo,
            self._hi,
            self.limited,
            self.A,
            self.T,
            self._F,
            self._tau,
            self._col,
            self.Gq,
            self.av,
            self.Ct,
            self.b,
            t.mass,
            t.gravity,
            self.wg,
        )
        map_contact_rows(self.Ct, self.b, f0, f1, self.cmap)
        self.meq, self.rows, self.first = meq, used, (f0, f1)
        self._gl = gl

    def _solve_once(self):
        if self.solver == "quadprog":
            return self._quadprog(self.Gq, self.av, self.Ct.T, self.b, self.meq)[0]
        if self.meq == 0 and unconstrained(self.Gq, self.av, self.Ct, self.b, self.rows, self._xs):
            return self._xs[:12]  # daqp's solution to rounding, as the C path (biped.control.daqp_c)
        if self.meq != self._meq_sense:
            self._sense[:] = 0
            self._sense[: self.meq] = 5  # daqp: ACTIVE + IMMUTABLE, an equality row
            self._upper[:] = 1e30
            self._meq_sense = self.meq
        self._upper[: self.meq] = self.b[: self.meq]  # an equality row is b <= C x <= b
        np.negative(self.av, out=self._f)
        x, _, flag, _ = self._daqp(self.Gq, self._f, self.Ct, self._upper, self.b, self._sense)
        if flag < 1:
            raise ValueError(f"daqp exit flag {flag}")
        return x

    def solve(self) -> np.ndarray:
        """Solve the built QP into ``self.x`` (with the documented fallbacks); returns ``self.x``."""
        x = self.x
        if self._c is not None:  # daqp's C function from compiled code: the same solve, no Python
            solve_flat(self._qf, self._qi, len(self._tau), self.meq, self.rows, *self.first)
            return x
        try:
            x[:] = self._solve_once()
            self.status = SOLVED
        except ValueError:
            # relaxed: the cones of the legs' shares alone (massless legs) without a minimum
            # normal force, for which w = 0 is feasible (the legs' weight line may leave the sole)
            saved = self.b.copy()
            p = self._prm
            for f, m in enumerate(self.first):
                if m >= 0:
                    d = self._dims[f]
                    contact_rows(d[2], d[1], d[3], p[6], 0.0, p[7], 6 * f, self.Ct, self.b, m)
            try:
                x[:] = self._solve_once()
                self.status = RELAXED
            except ValueError:
                x[:] = 0.0
                self.status = ZEROED
            self.b[:] = saved
            self.fallbacks[self.status] += 1
        if not math.isfinite(x.sum()):
            x[:] = 0.0
            self.status = ZEROED
            self.fallbacks[ZEROED] += 1
        return x

    def finish(self, contact, tau, Fl_tilde, Fr_tilde, Fl, Fr):
        """Write the torques and wrenches implied by ``self.x`` into the given buffers."""
        t = self._tree
        qp_finish(
            self.x,
            contact,
            self.A,
            self.T,
            self._soles,
            tau,
            Fl_tilde,
            Fr_tilde,
            Fl,
            Fr,
            t.parent,
            t.H,
            t.leg,
            self._beyond,
            self._gl,
            self._F,
            self.limited,
        )
