"""The contact wrench cone of a rectangular sole, and the legs' weight that the ground carries too
(also the sole frames' poses and maps the QP builds on: :func:`sole_to_body`).

Rows ``Ct[r] . w >= b[r]`` on a foot's ground wrench ``w = [fx, fy, fz, tx, ty, tz]`` in its sole
frame at the sole centre (Caron, Pham & Nakamura, ICRA 2015): normal force in [fmin, fmax], the
friction pyramid ``|fx|, |fy| <= mu fz``, the centre of pressure inside the sole ``|tx| <= Y fz``,
``|ty| <= X fz`` and the eight yaw-moment rows.

The QP's variables are the wrenches the legs pass to the central body (W Alg. 5-6), moved to the
soles as if the legs were massless. The ground carries the legs' weight as well (14.5 kg a leg in
W's model, 142 N, its line about 7 cm from the sole centre): quasi-statically the ground's wrench
on a foot is the QP's share plus the leg's weight, so a cone on the share alone keeps the real
centre of pressure well inside the sole on the side away from the leg's weight line.
:func:`carry_leg_weight` moves the rows onto the real ground wrench (``share`` of the weight),
except two that keep the massless-leg form, chosen by push-recovery sweeps (docs/controller.md):
the CoP row of the sole edge FAR from the leg's weight line (with it, the real CoP reached that
edge during a push, where the legs' inertia is not quasi-static, and the feet rocked: 0 deg
fell from 15 to 9 m/s) and the yaw rows.
"""

from __future__ import annotations

from numba import njit

__all__ = [
    "ROWS_PER_FOOT",
    "carry_leg_weight",
    "cone_rows",
    "contact_rows",
    "edge_contact",
    "foot_rows",
    "floor_friction_rows",
    "leg_weight_wrench",
    "map_contact_rows",
    "sole_to_body",
]

ROWS_PER_FOOT = 18  # min and max normal force + 4 friction + 4 CoP + 8 yaw moment
#: half length of the strip along the lower edge that stands for a line contact [m]: a strip
#: 4 mm wide whose outer side is the edge (MuJoCo's box-on-plane contacts of a pitched sole lie on
#: the edge itself, tests/test_qp_edge_contact.py); not zero: a zero-width strip is an equality
#: written as two opposite inequalities
EDGE_HALF_LINE = 0.002


@njit(cache=True)
def cone_rows(X, Y, mu, fmin, fmax, o, Ct, b, m):
    """Write the 18 rows ``Ct[r] . w >= b[r]`` of one rectangular sole's contact wrench cone
    (half length X along x, half width Y along y, friction mu, normal force in [fmin, fmax]) for the
    wrench w = x[o:o+6] = [fx, fy, fz, tx, ty, tz] from row m on; returns the next row."""
    for r in range(m, m + ROWS_PER_FOOT):
        for c in range(Ct.shape[1]):
            Ct[r, c] = 0.0
        b[r] = 0.0
    Ct[m, o + 2] = 1.0
    b[m] = fmin
    Ct[m + 1, o + 2] = -1.0
    b[m + 1] = -fmax
    r = m + 2
    for s in (-1.0, 1.0):
        Ct[r, o + 2] = mu  # mu fz + s fx >= 0
        Ct[r, o + 0] = s
        Ct[r + 1, o + 2] = mu  # mu fz + s fy >= 0
        Ct[r + 1, o + 1] = s
        Ct[r + 2, o + 2] = Y  # Y fz + s tx >= 0 (CoP_y = tx / fz)
        Ct[r + 2, o + 3] = s
        Ct[r + 3, o + 2] = X  # X fz + s ty >= 0 (CoP_x = -ty / fz)
        Ct[r + 3, o + 4] = s
        r += 4
    k = (X + Y) * mu
    for s1 in (-1.0, 1.0):
        for s2 in (-1.0, 1.0):
            # tz >= -k fz + |Y fx - mu tx| + |X fy - mu ty|
            Ct[r, o + 5] = 1.0
            Ct[r, o + 2] = k
            Ct[r, o + 0] = -s1 * Y
            Ct[r, o + 3] = s1 * mu
            Ct[r, o + 1] = -s2 * X
            Ct[r, o + 4] = s2 * mu
            # tz <= k fz - |Y fx + mu tx| - |X fy + mu ty|
            Ct[r + 1, o + 5] = -1.0
            Ct[r + 1, o + 2] = k
            Ct[r + 1, o + 0] = -s1 * Y
            Ct[r + 1, o + 3] = -s1 * mu
            Ct[r + 1, o + 1] = -s2 * X
            Ct[r + 1, o + 4] = -s2 * mu
            r += 2
    return r


@njit(cache=True)
def contact_rows(X, Y, cx, mu, fmin, fmax, o, Ct, b, m):
    """:func:`cone_rows` of the rectangle of half length X, half width Y centred at ``cx`` on the
    sole's x axis, written on the wrench x[o:o+6] at the sole centre: the rows hold the wrench
    moved to (cx, 0, 0), ``tau' = tau - p x f`` = (tx, ty + cx fz, tz - cx fy); returns the next row."""
    r_end = cone_rows(X, Y, mu, fmin, fmax, o, Ct, b, m)
    if cx != 0.0:
        for r in range(m, r_end):
            Ct[r, o + 2] += Ct[r, o + 4] * cx
            Ct[r, o + 1] -= Ct[r, o + 5] * cx
    return r_end


@njit(cache=True)
def edge_contact(gf, gfs, X, lift0, lift1, half_line):
    """(half length, centre on the sole's x axis) of the part of a rectangular sole (half length X)
    that can carry load when the foot is pitched about one end's edge (on its toe, heel up; or on
    its heel): the end raised ``lift = 2 X |z . x_s|`` above the other (x_s the sole's x axis in
    the world, the floor's normal world z). Up to ``lift0`` the whole sole; from ``lift1`` on a
    strip ``2 half_line`` wide along the lower end's edge (a line contact: the CoP on that edge,
    no moment about it); between, the far edge of the rectangle moves linearly toward the lower
    end (no step in the QP's rows as the foot rolls). gf = g_{0,foot}, gfs = g_{foot,sole}."""
    e = sole_rotation_row(gf, gfs, 2)[0]
    lift = 2.0 * X * abs(e)
    if lift0 < 0.0 or lift <= lift0:
        return X, 0.0
    s = 1.0 if lift >= lift1 else (lift - lift0) / (lift1 - lift0)
    xn = max(X * (1.0 - s), half_line)
    if xn >= X:
        return X, 0.0
    return xn, (X - xn) if e < 0.0 else (xn - X)  # e < 0: the +x end is the lower one


@njit(cache=True)
def foot_rows(g, foot, gfs, dims, f, prm, leg, mass, grav, wg, Ct, b, m):
    """Write foot ``f``'s 18 cone rows from row m on (the wrench x[6f:6f+6]; gfs = g_{foot,sole},
    ``dims[f]`` = (half length, half width, and here written: the half length and centre of the
    part of the sole in use, :func:`edge_contact`, if ``prm[10] >= 0``), with the QP's parameters
    ``prm``: the friction rows on the floor's axes (``prm[9]``), the rows on the
    ground's wrench with the leg's weight (``prm[8]``); returns the next row."""
    gf = g[foot]
    X, Y = dims[f, 0], dims[f, 1]
    xn, cx = X, 0.0
    if prm[10] >= 0.0:
        xn, cx = edge_contact(gf, gfs, X, prm[10], prm[11], EDGE_HALF_LINE)
    dims[f, 2], dims[f, 3] = xn, cx
    o = 6 * f
    r = contact_rows(xn, Y, cx, prm[6], prm[5], prm[7], o, Ct, b, m)
    if prm[9] != 0.0:  # the friction rows on the floor's axes
        floor_friction_rows(gf, gfs, prm[6], o, Ct, m)
    if prm[8] != 0.0:  # the cone holds the ground's wrench: the QP's share plus the leg's weight
        leg_weight_wrench(g, foot, gfs, leg, f, mass, grav, prm[8], wg[f])
        carry_leg_weight(Ct, b, m, o, wg[f])
    return r


@njit(cache=True, inline="always")
def sole_rotation_row(gf, gfs, i):
    """Row i of the rotation of g_{0,foot} g_{foot,sole} (gf = g_{0,foot}, gfs = g_{foot,sole})."""
    return (
        gf[i, 0] * gfs[0, 0] + gf[i, 1] * gfs[1, 0] + gf[i, 2] * gfs[2, 0],
        gf[i, 0] * gfs[0, 1] + gf[i, 1] * gfs[1, 1] + gf[i, 2] * gfs[2, 1],
        gf[i, 0] * gfs[0, 2] + gf[i, 1] * gfs[1, 2] + gf[i, 2] * gfs[2, 2],
    )


@njit(cache=True, inline="always")
def sole_position(gf, gfs, i):
    """Entry i of the position of g_{0,foot} g_{foot,sole}."""
    return gf[i, 3] + gf[i, 0] * gfs[0, 3] + gf[i, 1] * gfs[1, 3] + gf[i, 2] * gfs[2, 3]


@njit(cache=True)
def floor_friction_rows(gf, gfs, mu, o, Ct, m):
    """Rewrite the four friction rows of one foot's cone (rows m+2, m+3, m+6, m+7 of
    :func:`cone_rows`, on the sole-frame force x[o:o+3]) on the floor's axes:
    ``mu (n . f_w) +- (t . f_w) >= 0`` for the world force ``f_w = R_s f`` (R_s the sole's world
    rotation, gf = g_{0,foot}, gfs = g_{foot,sole}), floor normal n = world z, tangents t_x the
    sole's x axis projected onto the floor and t_y = n x t_x. With the sole flat these are the
    sole-frame rows; tilted on an edge, the sole-frame rows let the floor-frame ratio exceed mu
    by the tilt (measured: 0.21 in the sole frame was 0.32 on the floor, 6 deg of roll)."""
    Rs = (sole_rotation_row(gf, gfs, 0), sole_rotation_row(gf, gfs, 1), sole_rotation_row(gf, gfs, 2))
    tx0, tx1 = Rs[0][0], Rs[1][0]
    nrm = (tx0 * tx0 + tx1 * tx1) ** 0.5
    if nrm < 1e-9:  # the sole's x axis vertical: keep the sole-frame rows
        return
    tx0 /= nrm
    tx1 /= nrm
    ty0, ty1 = -tx1, tx0
    for r, (u0, u1), s in (
        (m + 2, (tx0, tx1), -1.0),
        (m + 3, (ty0, ty1), -1.0),
        (m + 6, (tx0, tx1), 1.0),
        (m + 7, (ty0, ty1), 1.0),
    ):
        for j in range(3):  # coefficient of f_j: (mu n + s u) . R_s e_j
            Ct[r, o + j] = mu * Rs[2][j] + s * (u0 * Rs[0][j] + u1 * Rs[1][j])


@njit(cache=True)
def leg_weight_wrench(g, foot, gfs, leg, side, mass, grav, share, out):
    """out (6,) = ``share`` x the wrench [f; tau] with which the ground carries the weight of leg
    ``side``'s links (``leg[k] == side``, the foot included), in the sole frame at the sole centre
    (g: world poses of the link COM frames, gfs = g_{foot,sole}, grav: gravity in the world)."""
    gf = g[foot]  # the sole's world pose g_{0,foot} g_{foot,sole}: (Rs, ps), as tuples (no allocation)
    Rs = (sole_rotation_row(gf, gfs, 0), sole_rotation_row(gf, gfs, 1), sole_rotation_row(gf, gfs, 2))
    ps = (sole_position(gf, gfs, 0), sole_position(gf, gfs, 1), sole_position(gf, gfs, 2))
    f0 = f1 = f2 = t0 = t1 = t2 = 0.0
    for k in range(leg.shape[0]):
        if leg[k] != side:
            continue
        fk0, fk1, fk2 = -share * mass[k] * grav[0], -share * mass[k] * grav[1], -share * mass[k] * grav[2]
        d0, d1, d2 = g[k, 0, 3] - ps[0], g[k, 1, 3] - ps[1], g[k, 2, 3] - ps[2]
        f0 += fk0
        f1 += fk1
        f2 += fk2
        t0 += d1 * fk2 - d2 * fk1
        t1 += d2 * fk0 - d0 * fk2
        t2 += d0 * fk1 - d1 * fk0
    for i in range(3):  # world -> sole frame
        out[i] = Rs[0][i] * f0 + Rs[1][i] * f1 + Rs[2][i] * f2
        out[3 + i] = Rs[0][i] * t0 + Rs[1][i] * t1 + Rs[2][i] * t2


@njit(cache=True, inline="always")
def _row_times(Ct, r, o, w):
    """Ct[r, o:o+6] . w (w (6,))."""
    s = 0.0
    for c in range(6):
        s += Ct[r, o + c] * w[c]
    return s


@njit(cache=True)
def carry_leg_weight(Ct, b, m, o, wg):
    """Move one foot's cone rows m .. m+17 (written by :func:`cone_rows` for x[o:o+6]) onto the
    ground's wrench ``x_f + wg``: ``Ct (x_f + wg) >= b``, i.e. ``b -= Ct wg``, on the normal-force,
    friction and lateral CoP rows and on the CoP row of the sole edge nearer the leg's weight line
    (the smaller shift of the two); the far edge's CoP row and the yaw rows stay as they are."""
    # row order of cone_rows: 0-1 normal force; for s = -1 then +1: friction x, friction y,
    # CoP y (|tx| <= Y fz), CoP x (|ty| <= X fz) at 2-5 and 6-9; yaw moment 10-17
    for r in (0, 1, 2, 3, 4, 6, 7, 8):
        b[m + r] -= _row_times(Ct, m + r, o, wg)
    c5, c9 = _row_times(Ct, m + 5, o, wg), _row_times(Ct, m + 9, o, wg)
    if c5 < c9:
        b[m + 5] -= c5
    else:
        b[m + 9] -= c9


@njit(cache=True)
def map_contact_rows(Ct, b, f0, f1, cmap):
    """Contact maps: for foot f (cone rows from ``f0`` / ``f1``, -1: not in contact) with
    ``cmap[f, 0] != 0``, move its two normal-force rows and four friction rows (``cmap[f, 0]`` 2:
    also the eight yaw rows, 3: also the four CoP rows) onto the contact
    wrench predicted as ``K w + r`` of the foot's QP wrench ``w = x[6f:6f+6]`` (sole frame, sole
    centre; ``K = cmap[f, 1:37]`` row by row, ``r = cmap[f, 37:43]``): ``Ct_r . (K w + r) >= b_r``,
    i.e. the row's coefficients times K and ``b_r -= Ct_r . r``. The stepping controller's stance
    model (:mod:`biped.control.stance_dynamics`): the prediction carries the legs' inertia, the
    driven swing leg's reaction and the legs' weight."""
    for f in range(2):
        m = f0 if f == 0 else f1
        if m < 0 or cmap[f, 0] == 0.0:
            continue
        o = 6 * f
        level = cmap[f, 0]
        for r in range(ROWS_PER_FOOT):
            if r in (4, 5, 8, 9):  # the CoP rows: level 3
                if level < 3.0:
                    continue
            elif r >= 10 and level < 2.0:  # the yaw rows: level 2 and up
                continue
            row = Ct[m + r]
            s = 0.0
            for i in range(6):
                s += row[o + i] * cmap[f, 37 + i]
            b[m + r] -= s
            c0, c1, c2, c3, c4, c5 = row[o], row[o + 1], row[o + 2], row[o + 3], row[o + 4], row[o + 5]
            for j in range(6):
                k = 1 + j
                row[o + j] = (
                    c0 * cmap[f, k]
                    + c1 * cmap[f, k + 6]
                    + c2 * cmap[f, k + 12]
                    + c3 * cmap[f, k + 18]
                    + c4 * cmap[f, k + 24]
                    + c5 * cmap[f, k + 30]
                )


@njit(cache=True)
def sole_to_body(gf, gfs, g1, A):
    """A = Ad^T_{g_{sole,1}}: maps a wrench in the sole frame at the sole centre to the same
    wrench in the central body's frame (gf = g_{0,foot}, gfs = g_{foot,sole}, g1 = g_{0,1})."""
    Rs = (sole_rotation_row(gf, gfs, 0), sole_rotation_row(gf, gfs, 1), sole_rotation_row(gf, gfs, 2))
    ps = (sole_position(gf, gfs, 0), sole_position(gf, gfs, 1), sole_position(gf, gfs, 2))
    # g_{s,1} = (R, p), R = Rs^T R1, p = Rs^T (p1 - ps); A = [[R^T, 0], [-R^T p^, R^T]]
    d0, d1, d2 = g1[0, 3] - ps[0], g1[1, 3] - ps[1], g1[2, 3] - ps[2]
    p = (
        Rs[0][0] * d0 + Rs[1][0] * d1 + Rs[2][0] * d2,
        Rs[0][1] * d0 + Rs[1][1] * d1 + Rs[2][1] * d2,
        Rs[0][2] * d0 + Rs[1][2] * d1 + Rs[2][2] * d2,
    )
    for i in range(3):
        for j in range(3):
            rt = g1[0, i] * Rs[0][j] + g1[1, i] * Rs[1][j] + g1[2, i] * Rs[2][j]  # (R^T)_{ij}
            A[i, j] = rt
            A[3 + i, 3 + j] = rt
            A[i, 3 + j] = 0.0
    for i in range(3):  # -(R^T p^)_{ij}, p^ = [[0,-p2,p1],[p2,0,-p0],[-p1,p0,0]]
        r0, r1, r2 = A[i, 0], A[i, 1], A[i, 2]
        A[3 + i, 0] = -(r1 * p[2] - r2 * p[1])
        A[3 + i, 1] = -(r2 * p[0] - r0 * p[2])
        A[3 + i, 2] = -(r0 * p[1] - r1 * p[0])
