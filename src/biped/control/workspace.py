"""W's recursive workspace balancing controller (W, 1997): the object around the compiled kernel.

Frames and units: every 6-vector of the output is a twist ``[v; w]`` or a wrench ``[f; tau]``
expressed in the central body's COM principal-axis frame (MuJoCo's inertial frame of the root
body), SI units (N, N m, m/s^2, rad/s^2).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, fields
from os import PathLike
from typing import TYPE_CHECKING

import numpy as np

from biped._numba_cache import say_if_cold
from biped.control.qp_call import qp_kernel
from biped.control.recursions import (
    NONFINITE_RESULT,
    NONFINITE_STATE,
    SINGULAR_DISTRIBUTION,
    STOP_AFTER_ALG4,
    ZERO_QUATERNION,
    alg6_torques,
    compute_kernel,
    kinematics,
    layout,
    unpack,
)
from biped.control.setpoint import (
    TARGET_AXES,
    W_TARGET_AXIS,
    W_TARGET_COM_M,
    W_TARGET_TILT_DEG,
    Gains,
    Target,
    checked_vector,
)
from biped.errors import BipedError, ModelError, ScenarioError, SingularityError, StateError, first_few
from biped.model import DEFAULT_FEET, TreeModel, sole_rectangles
from biped.spatial import rot_to_quat

if TYPE_CHECKING:
    from biped.control.distribution import ContactQP

__all__ = [
    "DISTRIBUTIONS",
    "TARGET_AXES",
    "W_TARGET_AXIS",
    "W_TARGET_COM_M",
    "W_TARGET_TILT_DEG",
    "ControllerOutput",
    "Gains",
    "Target",
    "WorkspaceController",
]

#: W Alg. 5 readings: "statics" (default) moves each foot's wrench to the central body with
#: Ad^T_{g_{foot,1}}, as power balance and W's eq. 3.6 require; "printed" uses W's print
#: Ad^T_{g_{1,foot}} literally (same sum F_1^bd, a different and unphysical split). Beyond W:
#: "qp" splits F_1^bd by a QP inside the soles' contact wrench cones and the torque limits
#: (:mod:`biped.control.distribution`).
DISTRIBUTIONS = ("statics", "printed", "qp")
_MODE = {"statics": 0, "printed": 1, "qp": STOP_AFTER_ALG4}


@dataclass(frozen=True)
class ControllerOutput:
    """One controller call's results (central-body COM frame unless stated, SI units).

    torques: (n_joints,) joint torques [N m], ordered as ``WorkspaceController.joint_names``.
    P1: (6, 6) approximate workspace inertia ``P_1`` [kg, kg m, kg m^2] (W Alg. 3).
    z1: (6,) workspace bias wrench ``z_1`` (gravity + Coriolis) [N, N m] (W Alg. 3).
    accel_desired: (6,) ``X^b``, the commanded body acceleration [m/s^2, rad/s^2] (W Alg. 4).
    wrench_desired: (6,) ``F_1^bd = P_1 X^b + z_1`` [N, N m] (W Alg. 4).
    wrench_left, wrench_right: (6,) ``F~_2^bd``, ``F~_8^bd``: the shares of the two legs (sum =
        wrench_desired) (W Alg. 5).
    foot_wrench_left, foot_wrench_right: (6,) ``F_l``, ``F_r``: the ground's wrench on each foot that
        the split implies, in that foot's own COM principal frame, at its COM (W Alg. 5).
    quat_error: (4,) ``q_e`` (w, x, y, z), scalar part >= 0 (W Alg. 4).
    """

    torques: np.ndarray
    P1: np.ndarray
    z1: np.ndarray
    accel_desired: np.ndarray
    wrench_desired: np.ndarray
    wrench_left: np.ndarray
    wrench_right: np.ndarray
    foot_wrench_left: np.ndarray
    foot_wrench_right: np.ndarray
    quat_error: np.ndarray


_OUTPUT_FIELDS = tuple(f.name for f in fields(ControllerOutput))


#: (left, right) sole rectangles of a tree's feet, read once a tree (a sweep builds a controller a
#: trial on the same tree: reading them parsed the MJCF again, ~2.5 ms a trial)
_SOLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _tree_soles(tree: TreeModel):
    """:func:`~biped.model.sole_rectangles` of ``tree``'s source and feet, once a tree (the tree
    is immutable; the controller copies them into its QP's buffers)."""
    soles = _SOLES.get(tree)
    if soles is None:
        soles = _SOLES[tree] = sole_rectangles(tree.source, tuple(tree.body_names[f] for f in tree.feet))
    return soles


class WorkspaceController:
    """W's recursive workspace balancing controller on a :class:`~biped.model.TreeModel`.

    The model is immutable; the controller owns preallocated buffers (not thread-safe: use one
    controller per thread or process). One :meth:`compute` is one compiled call (numba) running
    W Alg. 1-6; set ``NUMBA_DISABLE_JIT=1`` to step through it in Python.

    Options: ``big_base`` is W Alg. 3's factor (feet get ``big_base * M_1``; W: 1e6);
    ``distribution`` selects W Alg. 5 (:data:`DISTRIBUTIONS`: "statics", the default, W's
    "printed" subscripts, or "qp", the contact-feasible QP of :mod:`biped.control.distribution`);
    ``target`` and ``gains`` are the defaults of :meth:`compute`. For "qp" only:
    ``qp_weights`` (:class:`~biped.control.distribution.QPWeights`), ``torque_limits`` (a
    :class:`~biped.control.limits.TorqueLimits` in any joint order, or None: unlimited) put
    into the QP, ``soles`` (left, right) :class:`~biped.model.SoleRectangle` (default: read from
    the tree's MJCF file) and ``qp_solver`` ("daqp", default, or "quadprog"). ``self.qp`` is then the
    :class:`~biped.control.distribution.ContactQP` (its ``status`` and ``fallbacks``).
    """

    def __init__(
        self,
        tree: TreeModel,
        *,
        big_base: float = 1e6,
        target: Target | None = None,
        gains: Gains | None = None,
        distribution: str = "statics",
        qp_weights=None,
        torque_limits=None,
        soles=None,
        qp_solver: str = "daqp",
    ):
        if not (np.isfinite(big_base) and big_base > 0):
            raise ScenarioError(f"big_base must be a positive finite factor, got {big_base}")
        if distribution not in DISTRIBUTIONS:
            raise ScenarioError(f"unknown wrench distribution {distribution!r}; valid: {DISTRIBUTIONS}")
        _check_feet(tree)
        say_if_cold(compute_kernel, "W's controller", "controller", 15)  # logging, once a process
        self.distribution = distribution
        self.tree = tree
        self.big_base = float(big_base)
        self.target = target or Target()
        self.gains = gains or Gains()
        n = tree.n_links
        lay = layout(n)
        self._layout = lay
        values = {
            "n": [n],
            "feet": tree.feet,
            "mode": [_MODE[distribution]],
            "parent": tree.parent,
            "qadr": tree.qpos_adr,
            "dadr": tree.dof_adr,
            "leg": tree.leg,
            "beyond": tree.beyond_foot,
            "H": tree.H,
            "G0": tree.G0,
            "mass": tree.mass,
            "inertia": tree.inertia,
            "qref": tree.qpos_ref,
            "gravity": tree.gravity,
            "root_qbi": rot_to_quat(np.ascontiguousarray(tree.G0[0][:3, :3])),
            "big_base": [self.big_base],
        }
        self._mi = np.zeros(lay["ints"]["_size"][0], dtype=np.int64)
        self._mf = np.zeros(lay["model"]["_size"][0])
        for buf, name in ((self._mi, "ints"), (self._mf, "model")):
            for key, (off, shape) in lay[name].items():
                if key != "_size":
                    buf[off : off + int(np.prod(shape))] = np.asarray(values[key]).reshape(-1)
        self._both = np.ones(2, dtype=np.int64)
        self._contact_buf = np.ones(2, dtype=np.int64)
        self._work = np.zeros(lay["work"]["_size"][0])
        self._out = np.zeros(lay["out"]["_size"][0])
        self._tau_out = self._out[: n - 1]  # what torques() returns (tau is the out buffer's head)
        self._shapes = ((tree.nq,), (tree.nv,))
        # named views of the buffers, the kernel's own unpack, for the debugging methods below
        # (not the hot path)
        _, self._m, self._w, _ = unpack(self._mi, self._mf, self._work, self._out)
        # (slice, shape or None for 1-d) of each output field, in ControllerOutput's order
        self._fields = tuple(
            (slice(o, o + int(np.prod(sh))), sh if len(sh) > 1 else None)
            for o, sh in (
                lay["out"][k]
                for k in ("tau", "P1", "z1", "X", "Fd", "Fl_tilde", "Fr_tilde", "Fl", "Fr", "qe")
            )
        )
        self._qp: ContactQP | None = None
        # all the buffers (the kernel's and the ContactQP's) when qp_kernel solves the QP in C
        self._qf: np.ndarray | None = None
        self._qi: np.ndarray | None = None
        if distribution == "qp":
            self._init_qp(qp_weights, torque_limits, soles, qp_solver)

    def _init_qp(self, weights, limits, soles, solver):
        from biped.control.distribution import ContactQP

        tree = self.tree
        if soles is None:
            try:
                soles = _tree_soles(tree)
            except BipedError:
                raise ScenarioError(
                    f"distribution 'qp' needs the soles: the tree's source {tree.source!r} is not "
                    f"a model file; pass soles=biped.model.sole_rectangles(model)"
                ) from None
        lower: np.ndarray | None = None
        upper: np.ndarray | None = None
        if limits is not None and not limits.unlimited:
            lim = limits.reorder(tree.joint_names)
            lower, upper = lim.lower, lim.upper
        # one int and one float buffer for the kernel's and the QP's arrays (biped.control.qp_call:
        # a compiled call from Python pays for every array argument)
        nf, ni = ContactQP.buffer_sizes(tree, lower is not None)
        heads = (self._mi, self._mf, self._work, self._out)
        sizes = [len(b) for b in heads]
        ints = np.zeros(4 + sizes[0] + ni, dtype=np.int64)
        floats = np.zeros(sum(sizes[1:]) + nf)
        ints[:4] = sizes
        self._mi = ints[4 : 4 + sizes[0]]
        o = np.cumsum([0, *sizes[1:]])
        self._mf, self._work, self._out = (floats[o[i] : o[i + 1]] for i in range(3))
        for new, old in zip((self._mi, self._mf, self._work, self._out), heads, strict=True):
            new[:] = old
        self._tau_out = self._out[: tree.n_links - 1]
        _, self._m, self._w, _ = unpack(self._mi, self._mf, self._work, self._out)
        qp = ContactQP(tree, soles, weights, lower, upper, solver, (floats[o[3] :], ints[4 + sizes[0] :]))
        self.qp = qp
        if qp._c is not None:
            self._qf, self._qi = floats, ints
        out, lay = self._out, self._layout
        v = {
            k: out[o : o + int(np.prod(sh))].reshape(sh) for k, (o, sh) in lay["out"].items() if k != "_size"
        }
        self._qp_views = (
            self._w.g,
            self._w.gl,
            v["Fd"],
            v["tau"],
            v["Fl_tilde"],
            v["Fr_tilde"],
            v["Fl"],
            v["Fr"],
        )

    @property
    def qp(self) -> ContactQP | None:
        """The QP distribution's :class:`~biped.control.distribution.ContactQP` (None unless "qp")."""
        return self._qp

    @qp.setter
    def qp(self, value: ContactQP | None) -> None:
        self._qp = value
        self._qf = self._qi = None  # another ContactQP: build, solve and finish from Python

    @classmethod
    def from_mjcf(
        cls, source: str | PathLike, feet: tuple[str, str] = DEFAULT_FEET, **kwargs
    ) -> WorkspaceController:
        """Controller for the biped in an MJCF file (path, XML text or ``mujoco.MjModel``)."""
        return cls(TreeModel.from_mjcf(source, feet=feet), **kwargs)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Hinge names in the order of ``torques`` (MuJoCo body order)."""
        return self.tree.joint_names

    def _contact(self, feet_in_contact):
        if feet_in_contact is None:
            return self._both
        c = self._contact_buf
        try:
            left, right = feet_in_contact
        except (TypeError, ValueError):
            raise StateError(
                f"feet_in_contact must be a pair of booleans (left, right), got {feet_in_contact!r}"
            ) from None
        c[0] = 1 if left else 0
        c[1] = 1 if right else 0
        return c

    def _check_state(self, qpos, qvel):
        """Raise a StateError naming what is wrong with (qpos, qvel): their shapes, non-finite
        entries, or a zero root quaternion."""
        if qpos.shape != (self.tree.nq,) or qvel.shape != (self.tree.nv,):
            raise StateError(
                f"qpos must have shape ({self.tree.nq},) and qvel ({self.tree.nv},) (MuJoCo layout of "
                f"{self.tree.source}), got {qpos.shape} and {qvel.shape}"
            )
        bad = [f"qpos[{i}]" for i in np.flatnonzero(~np.isfinite(qpos))]
        bad += [f"qvel[{i}]" for i in np.flatnonzero(~np.isfinite(qvel))]
        if bad:
            raise StateError(
                f"qpos and qvel must be finite; {len(bad)} non-finite "
                f"{'entry' if len(bad) == 1 else 'entries'} (NaN or infinite): {first_few(bad)}"
            )
        a = self.tree.qpos_adr[0] + 3
        if not np.any(qpos[a : a + 4]):
            raise StateError(
                f"the root quaternion qpos[{a}:{a + 4}] is zero; it must be a "
                f"(w, x, y, z) quaternion of nonzero norm (it is normalized)"
            )

    def _unit_quaternion(self, qpos):
        """A copy of qpos with its root quaternion normalized without overflow or underflow (the
        kernel normalizes by sqrt(q.q), which fails beyond ~1e154 or below ~1e-154), or None if the
        quaternion is zero or non-finite, or already of unit norm."""
        a = self.tree.qpos_adr[0] + 3
        q = qpos[a : a + 4]
        m = float(np.max(np.abs(q))) if q.size == 4 else 0.0
        if not np.isfinite(m) or m == 0.0:
            return None
        u = q / m
        u = u / np.sqrt(u @ u)
        if np.allclose(u, q, rtol=0.0, atol=1e-12):
            return None
        out = qpos.copy()
        out[a : a + 4] = u
        return out

    def _run(self, qpos, qvel, target, gains, feet_in_contact=None):
        if qpos.shape != self._shapes[0] or qvel.shape != self._shapes[1]:
            self._check_state(qpos, qvel)
        t = (target or self.target).array
        k = (gains or self.gains).array
        c = self._both if feet_in_contact is None else self._contact(feet_in_contact)
        try:
            if self._qf is not None:  # the QP in the same compiled call (biped.control.qp_call)
                status = qp_kernel(qpos, qvel, t, k, c, self._qi, self._qf)
            else:
                status = compute_kernel(qpos, qvel, t, k, c, self._mi, self._mf, self._work, self._out)
        except ZeroDivisionError:  # numba's float division: a quaternion of overflowing norm
            status = NONFINITE_RESULT
        if status:
            self._failed(status, qpos, qvel, target, gains, feet_in_contact)
            return
        if self.qp is not None and self._qf is None:
            g, gl, Fd, tau, Flt, Frt, Fl, Fr = self._qp_views
            self.qp.build(g, gl, c, Fd)
            if c[0] == 0 and c[1] == 0:
                self.qp.x[:] = 0.0
            else:
                self.qp.solve()
            self.qp.finish(c, tau, Flt, Frt, Fl, Fr)

    def _failed(self, status, qpos, qvel, target, gains, feet_in_contact):
        """After a kernel status other than 0: run again on a safely normalized quaternion, or raise."""
        if status in (ZERO_QUATERNION, NONFINITE_RESULT):
            unit = self._unit_quaternion(qpos)  # a badly scaled quaternion: normalize safely
            if unit is not None:
                return self._run(unit, qvel, target, gains, feet_in_contact)
        if status in (NONFINITE_STATE, ZERO_QUATERNION):
            self._check_state(qpos, qvel)
            a = self.tree.qpos_adr[0] + 3
            raise StateError(
                f"the root quaternion qpos[{a}:{a + 4}] = {qpos[a : a + 4].tolist()} "
                f"cannot be normalized in double precision"
            )
        if status == SINGULAR_DISTRIBUTION:
            raise SingularityError(
                "wrench distribution: G G^T is singular to working precision (W Alg. 5); it is the "
                "sum of two positive-definite matrices, so this means feet absurdly far from the "
                "central body for double precision"
            )
        raise SingularityError(
            "the controller produced non-finite values at this state: velocities too large for "
            "double precision, or a joint axis with zero articulated inertia (W Alg. 3)"
        )

    def compute(
        self,
        qpos,
        qvel,
        target: Target | None = None,
        gains: Gains | None = None,
        feet_in_contact: tuple[bool, bool] | None = None,
    ) -> ControllerOutput:
        """Run W Alg. 1-6 at state (qpos, qvel) (MuJoCo layout of the biped's own model).

        Returns a :class:`ControllerOutput` of fresh arrays. ``target`` and ``gains`` default to
        the controller's (W's set point and gains unless given at construction).

        ``feet_in_contact`` = (left, right) says which feet are on the ground, as a contact or force
        sensor would. ``None`` (the default) is W's controller: both feet are always taken as fixed
        (the big base of Alg. 3, both shares of Alg. 5). Given flags, a foot off the ground keeps its
        own inertia in Alg. 3 (its leg a passive articulated branch of the central body) and takes no
        share in Alg. 5, so the stance leg realizes all of ``F_1^bd`` and the free leg gets zero
        torque; with no foot down, no wrench is distributed. This goes beyond W: W's controller
        assumes both feet fixed even while one is in the air.
        """
        qpos = np.ascontiguousarray(qpos, dtype=float)
        qvel = np.ascontiguousarray(qvel, dtype=float)
        self._run(qpos, qvel, target, gains, feet_in_contact)
        buf = self._out.copy()  # one fresh buffer; the fields are views of it
        out = object.__new__(ControllerOutput)  # skips the frozen __init__'s 10 setattr calls (3 us)
        out.__dict__.update(
            zip(
                _OUTPUT_FIELDS,
                [buf[sl] if sh is None else buf[sl].reshape(sh) for sl, sh in self._fields],
                strict=True,
            )
        )
        return out

    # ------------------------------------------------------------------ debugging / checking

    def _state(self, qpos, qvel):
        qpos = np.ascontiguousarray(qpos, dtype=float)
        qvel = np.zeros(self.tree.nv) if qvel is None else np.ascontiguousarray(qvel, dtype=float)
        self._check_state(qpos, qvel)
        unit = self._unit_quaternion(qpos)
        return (qpos if unit is None else unit), qvel

    def _kinematics(self, qpos, qvel):
        """W Alg. 1 and Alg. 2 alone (the kernel's own compiled part) into the work buffer."""
        kinematics(qpos, qvel, self._mi, self._mf, self._work, self._out)

    def link_poses(self, qpos) -> np.ndarray:
        """(n_links, 4, 4) world poses ``g_{0,k}`` of every link's COM principal frame (MuJoCo's
        ``xipos``/``ximat``), W Alg. 1-2. For checking and debugging; allocates."""
        qpos, qvel = self._state(qpos, None)
        self._kinematics(qpos, qvel)
        return self._w.g.copy()

    def link_velocities(self, qpos, qvel) -> np.ndarray:
        """(n_links, 6) body velocities ``V_k^b = [v; w]`` of every link (W Alg. 1-2): velocity of
        link k's COM and its angular velocity relative to the world, both in link k's COM
        principal frame [m/s, rad/s]. For checking and debugging; allocates."""
        qpos, qvel = self._state(qpos, qvel)
        self._kinematics(qpos, qvel)
        return self._w.V.copy()

    def leg_torques(self, qpos, wrench_left, wrench_right) -> np.ndarray:
        """W Alg. 6 alone: joint torques (n_joints,) [N m] with which the legs exert the wrenches
        ``F~_2`` (left) and ``F~_8`` (right) [N, N m] on the central body (central-body COM frame),
        feet fixed: ``tau_leg = J_leg^T F~``. Joints off the legs get zero. For checking the
        recursion against a Jacobian and for Jacobian-transpose control; allocates."""
        qpos, qvel = self._state(qpos, None)
        t = self.tree
        fl, fr = (
            np.array(checked_vector(n, v, 6))
            for n, v in (("wrench_left", wrench_left), ("wrench_right", wrench_right))
        )
        self._kinematics(qpos, qvel)  # the joint transforms g_{k.i,k.o}
        F = np.zeros((t.n_links, 6))
        tau = np.zeros(t.n_links - 1)
        alg6_torques(t.parent, self._m.H, t.leg, t.beyond_foot.astype(np.int64), self._w.gl, fl, fr, F, tau)
        return tau

    def torques(
        self,
        qpos: np.ndarray,
        qvel: np.ndarray,
        target: Target | None = None,
        gains: Gains | None = None,
        feet_in_contact: tuple[bool, bool] | None = None,
    ) -> np.ndarray:
        """Joint torques (n_joints,) [N m] as a VIEW OF THE CONTROLLER'S REUSED OUTPUT BUFFER: the
        next :meth:`torques` or :meth:`compute` call overwrites it; copy it to keep it.

        The hot path: W Alg. 1-6 with no allocation. qpos/qvel must be contiguous float64
        arrays; ``target``, ``gains`` and ``feet_in_contact`` as in :meth:`compute`, which
        returns fresh arrays instead."""
        self._run(qpos, qvel, target, gains, feet_in_contact)
        return self._tau_out


def _check_feet(tree: TreeModel) -> None:
    """The feet must be two different links below the root, each ending its own leg (W Alg. 3, 5
    and 6 fix them to the ground and push the central body through the legs above them)."""
    feet = [int(f) for f in np.asarray(tree.feet).reshape(-1)]
    if len(feet) != 2 or feet[0] == feet[1] or not all(0 <= f < tree.n_links for f in feet):
        raise ModelError(f"the tree must name two different feet, got link indices {feet}")
    for f in feet:
        if f == 0:
            raise ModelError(
                f"foot {tree.body_names[0]!r} is the floating root (the central body); "
                f"the feet must be bodies below it, one at the end of each leg"
            )
