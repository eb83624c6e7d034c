"""Independent derivations of Bediz's planar models with ``sympy.physics.mechanics``.

Nothing here reuses the hand-written forms of ``pendulum`` and ``body_leg``: the equations come from
Lagrange's method applied to the kinematics (frames, points, a rigid body, loads), and the reaction
forces from Newton's law on the body, F = m a_com - m g, with a_com differentiated by sympy. Tests
compare the hand-written forms against these; where B's print disagrees, the derivation wins.

Each derivation is cached (``functools.cache``), so a session pays for it once.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np
import sympy as sp
from sympy.physics import mechanics as me


@dataclass(frozen=True)
class Derivation:
    """A derived model: symbols, the accelerations and reaction forces as sympy expressions, and
    numeric callables ``f(params..., q..., qd..., torques...)``.

    params: tuple of parameter symbols; q, qd: coordinate and rate symbols; torques: input symbols;
    qdd: tuple of acceleration expressions; forces: dict name -> expression (in terms of q, qd,
    torques and the accelerations already substituted).
    """

    params: tuple
    q: tuple
    qd: tuple
    torques: tuple
    qdd: tuple
    forces: dict
    mass_matrix: sp.Matrix
    forcing: sp.Matrix

    def numeric(self):
        """Lambdified (accelerations, forces) -> function of (params, q, qd, torques) as flat args."""
        args = (*self.params, *self.q, *self.qd, *self.torques)
        names = sorted(self.forces)
        f = sp.lambdify(args, [list(self.qdd), [self.forces[n] for n in names]], "math")

        def evaluate(params, q, qd, torques):
            acc, frc = f(*params, *q, *qd, *torques)
            return np.array(acc, dtype=float), dict(zip(names, map(float, frc), strict=True))

        return evaluate


@cache
def pendulum() -> Derivation:
    """Single-link pendulum on a pivot (B Fig. 1 / Fig. 21) by Lagrange's method.

    Frame: N.x horizontal, N.y up. theta is the counter-clockwise tilt from upward, the centre of
    mass at -l sin(theta) N.x + l cos(theta) N.y. Torque M on the body about N.z. Forces: the
    ground's push on the pendulum at the pivot, (F_x, F_y) = m a_com + m g N.y.
    """
    m, I, l, g, M = sp.symbols("m I l g M", real=True)
    th = me.dynamicsymbols("theta")
    thd = me.dynamicsymbols("theta", 1)
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [th, N.z])
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", l * A.y)  # A.y = -sin(theta) N.x + cos(theta) N.y
    P.v2pt_theory(O, N, A)
    body = me.RigidBody("body", P, A, m, (me.inertia(A, 0, 0, I), P))
    body.potential_energy = m * g * P.pos_from(O).dot(N.y)
    L = me.Lagrangian(N, body)
    lm = me.LagrangesMethod(L, [th], forcelist=[(A, M * N.z)], frame=N)
    lm.form_lagranges_equations()
    mm, fo = lm.mass_matrix, lm.forcing
    thdd = (mm.LUsolve(fo))[0]
    t_sym = sp.Symbol("t")
    acc = P.acc(N).subs(th.diff(t_sym, 2), thdd)
    F = m * acc + m * g * N.y
    q, qd = sp.symbols("q qd", real=True)
    rep = {thd: qd, th: q}
    return Derivation(
        params=(m, I, l, g),
        q=(q,),
        qd=(qd,),
        torques=(M,),
        qdd=(thdd.subs(rep),),
        forces={"fx": F.dot(N.x).subs(rep), "fy": F.dot(N.y).subs(rep)},
        mass_matrix=mm.subs(rep),
        forcing=fo.subs(rep),
    )


@cache
def body_leg() -> Derivation:
    """Body on a massless leg of constant length (B Fig. 9) by Lagrange's method.

    Frame: N.x horizontal (B's y), N.y up (B's z). Angles from upward, positive toward +N.x, i.e.
    clockwise: the leg frame L is N rotated by -theta_1 about N.z, the body frame B by -theta_2.
    Loads: ankle torque M_1 on the leg, hip torque M_2 on the body and -M_2 on the leg, each about
    -N.z (the sense of increasing angle); gravity on the body. Forces: the leg's push on the body
    at the hip, m a_com + m g N.y, split into F along the leg and F_r along (cos t1, -sin t1).
    """
    m, I, r, l, g, M1, M2 = sp.symbols("m I r l g M_1 M_2", real=True)
    t1, t2 = me.dynamicsymbols("theta_1 theta_2")
    t1d, t2d = me.dynamicsymbols("theta_1 theta_2", 1)
    N = me.ReferenceFrame("N")
    Lf = N.orientnew("L", "Axis", [-t1, N.z])
    Bf = N.orientnew("B", "Axis", [-t2, N.z])
    O = me.Point("O")
    O.set_vel(N, 0)
    H = O.locatenew("H", r * Lf.y)
    H.v2pt_theory(O, N, Lf)
    P = H.locatenew("P", l * Bf.y)
    P.v2pt_theory(H, N, Bf)
    body = me.RigidBody("body", P, Bf, m, (me.inertia(Bf, 0, 0, I), P))
    body.potential_energy = m * g * P.pos_from(O).dot(N.y)
    Lag = me.Lagrangian(N, body)
    loads = [(Lf, (M1 - M2) * (-N.z)), (Bf, M2 * (-N.z))]
    lm = me.LagrangesMethod(Lag, [t1, t2], forcelist=loads, frame=N)
    lm.form_lagranges_equations()
    mm, fo = lm.mass_matrix, lm.forcing
    sol = mm.LUsolve(fo)
    qdd = list(sol)
    t_sym = sp.Symbol("t")
    acc = P.acc(N).subs({t1.diff(t_sym, 2): qdd[0], t2.diff(t_sym, 2): qdd[1]})
    Fvec = m * acc + m * g * N.y
    q1, q2, qd1, qd2 = sp.symbols("q1 q2 qd1 qd2", real=True)
    rep = {t1d: qd1, t2d: qd2, t1: q1, t2: q2}
    along = sp.sin(t1) * N.x + sp.cos(t1) * N.y
    perp = sp.cos(t1) * N.x - sp.sin(t1) * N.y
    return Derivation(
        params=(m, I, r, l, g),
        q=(q1, q2),
        qd=(qd1, qd2),
        torques=(M1, M2),
        qdd=tuple(e.subs(rep) for e in qdd),
        forces={
            "F": Fvec.dot(along).subs(rep),
            "F_r": Fvec.dot(perp).subs(rep),
        },
        mass_matrix=mm.subs(rep),
        forcing=fo.subs(rep),
    )


@cache
def body_leg_linearization():
    """Symbolic A (4, 4) and B (4, 2) of the derivation linearized at the upright equilibrium
    (x = 0, u = 0), the counterpart of eq. 3.58, 3.59. Returns (A, B, params)."""
    d = body_leg()
    q1, q2 = d.q
    qd1, qd2 = d.qd
    M1, M2 = d.torques
    f = sp.Matrix([qd1, d.qdd[0], qd2, d.qdd[1]])
    xs = [q1, qd1, q2, qd2]
    at = {q1: 0, q2: 0, qd1: 0, qd2: 0, M1: 0, M2: 0}
    A = sp.simplify(f.jacobian(xs).subs(at))
    B = sp.simplify(f.jacobian([M1, M2]).subs(at))
    return A, B, d.params


@cache
def body_leg_characteristic_polynomial():
    """det(s I - (A - B K)) * I m r^2 for the local gains K of eq. 3.60, as a sympy Poly in s,
    with gain symbols (K_theta1, K_theta1dot, K_theta2, K_theta2dot). Counterpart of eq. 3.80."""
    A, B, params = body_leg_linearization()
    m, I, r, _l, _g = params
    k1, k1d, k2, k2d, s = sp.symbols("K_theta1 K_theta1dot K_theta2 K_theta2dot s", real=True)
    K = sp.Matrix([[-k1, -k1d, 0, 0], [0, 0, -k2, -k2d]])
    det = (s * sp.eye(4) - (A + B * K)).det(method="berkowitz")
    poly = sp.Poly(sp.expand(sp.simplify(det * I * m * r**2)), s)
    return poly, (k1, k1d, k2, k2d), params


@dataclass(frozen=True)
class RigidBodyDerivation:
    """Kane's equations of a free rigid body: ``qdot`` (6,) and ``udot`` (6,) sympy expressions of
    params (m, I_xx, I_yy, I_zz, g), q (x, y, z, phi, theta, psi), u (u, v, w, p, q, r) and the
    body-frame wrench (f_x, f_y, f_z, L, M, N)."""

    params: tuple
    q: tuple
    u: tuple
    wrench: tuple
    qdot: tuple
    udot: tuple

    def numeric(self):
        """Function (params, state (12,), wrench (6,)) -> d state / dt (12,)."""
        args = (*self.params, *self.q, *self.u, *self.wrench)
        f = sp.lambdify(args, [*self.qdot, *self.udot], "math")
        return lambda params, state, wrench: np.array(f(*params, *state, *wrench), dtype=float)


@cache
def rigid_body() -> RigidBodyDerivation:
    """The 6-DOF body of B's Appendix A by Kane's method (independent of eq. 4.24, 4.25).

    Earth frame N with N.z down and gravity m g N.z; body frame B = N rotated by the body-fixed
    z-y-x sequence (psi, theta, phi); generalized speeds are the body-axis components of the centre
    of mass velocity and of the angular velocity; the wrench acts at the centre of mass in B.
    """
    m, Ixx, Iyy, Izz, g = sp.symbols("m I_xx I_yy I_zz g", real=True)
    fx, fy, fz, L, M, Nn = sp.symbols("f_x f_y f_z L M N", real=True)
    qs = me.dynamicsymbols("x y z phi theta psi")
    us = me.dynamicsymbols("u v w p q r")
    x, y, z, phi, theta, psi = qs
    u, v, w, p, q, r = us
    N = me.ReferenceFrame("N")
    B = me.ReferenceFrame("B")
    B.orient_body_fixed(N, (psi, theta, phi), "zyx")
    w_euler = B.ang_vel_in(N)  # in terms of the Euler-angle rates
    t = me.dynamicsymbols._t
    kd = [w_euler.dot(B.x) - p, w_euler.dot(B.y) - q, w_euler.dot(B.z) - r]
    vel = u * B.x + v * B.y + w * B.z
    kd += [x.diff(t) - vel.dot(N.x), y.diff(t) - vel.dot(N.y), z.diff(t) - vel.dot(N.z)]
    B.set_ang_vel(N, p * B.x + q * B.y + r * B.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y + z * N.z)
    P.set_vel(N, vel)
    body = me.RigidBody("body", P, B, m, (me.inertia(B, Ixx, Iyy, Izz), P))
    loads = [(P, fx * B.x + fy * B.y + fz * B.z + m * g * N.z), (B, L * B.x + M * B.y + Nn * B.z)]
    km = me.KanesMethod(N, q_ind=list(qs), u_ind=list(us), kd_eqs=kd)
    km.kanes_equations([body], loads)
    udot = km.mass_matrix.LUsolve(km.forcing)
    kdd = km.kindiffdict()
    qsym = sp.symbols("q0:6", real=True)
    usym = sp.symbols("u0:6", real=True)
    rep = dict(zip(us, usym, strict=True)) | dict(zip(qs, qsym, strict=True))
    return RigidBodyDerivation(
        params=(m, Ixx, Iyy, Izz, g),
        q=qsym,
        u=usym,
        wrench=(fx, fy, fz, L, M, Nn),
        qdot=tuple(kdd[qq.diff(t)].subs(rep) for qq in qs),
        udot=tuple(e.subs(rep) for e in udot),
    )
