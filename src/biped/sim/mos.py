"""Hof's margin of stability over a run's rows, compiled: the rule of
:func:`biped.sim.response.measure_response` (one convex hull of the soles' corners on the floor
per contact state and rounded feet pose, each row's extrapolated COM against its hull,
:func:`biped.sim.response.margin`), for the sweep's rows, where the Python version's per-hull
overhead cost more than the trial (hundreds of hulls a trial: the feet creep by millimetres).

``tests/test_loop_measures.py`` checks it against the Python rule on recorded runs.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["margins"]


@njit(cache=True)
def _quat2mat(q, R):  # pragma: no cover - compiled
    """MuJoCo's ``mju_quat2Mat`` (row-major 3x3 into ``R`` (9,))."""
    if q[0] == 1.0 and q[1] == 0.0 and q[2] == 0.0 and q[3] == 0.0:
        R[:] = 0.0
        R[0] = R[4] = R[8] = 1.0
        return
    q00, q01, q02, q03 = q[0] * q[0], q[0] * q[1], q[0] * q[2], q[0] * q[3]
    q11, q12, q13 = q[1] * q[1], q[1] * q[2], q[1] * q[3]
    q22, q23, q33 = q[2] * q[2], q[2] * q[3], q[3] * q[3]
    R[0] = q00 + q11 - q22 - q33
    R[4] = q00 - q11 + q22 - q33
    R[8] = q00 - q11 - q22 + q33
    R[1] = 2 * (q12 - q03)
    R[2] = 2 * (q13 + q02)
    R[3] = 2 * (q12 + q03)
    R[5] = 2 * (q23 - q01)
    R[6] = 2 * (q13 - q02)
    R[7] = 2 * (q23 + q01)


@njit(cache=True)
def _turn(o, a, b):  # pragma: no cover - compiled
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


@njit(cache=True)
def _hull(pts, out):  # pragma: no cover - compiled
    """Counter-clockwise hull of ``pts`` (m, 2) into ``out``; its size (response._hull's rule:
    the points rounded to 1e-12 and sorted, Andrew's monotone chain; all of them if m <= 2)."""
    m = pts.shape[0]
    p = np.empty((m, 2))
    for i in range(m):
        p[i, 0] = np.rint(pts[i, 0] * 1e12) / 1e12  # np.round(x, 12): rint(x 10^12) / 10^12
        p[i, 1] = np.rint(pts[i, 1] * 1e12) / 1e12
    for i in range(1, m):  # insertion sort by (x, y)
        x, y = p[i, 0], p[i, 1]
        j = i - 1
        while j >= 0 and (p[j, 0] > x or (p[j, 0] == x and p[j, 1] > y)):
            p[j + 1] = p[j]
            j -= 1
        p[j + 1, 0], p[j + 1, 1] = x, y
    if m <= 2:
        out[:m] = p
        return m
    chain = np.empty((2 * m, 2))
    h = 0
    for i in range(m):  # lower half
        while h >= 2 and _turn(chain[h - 2], chain[h - 1], p[i]) <= 0:
            h -= 1
        chain[h] = p[i]
        h += 1
    n_lower = h
    for i in range(m - 1, -1, -1):  # upper half, on its own stack
        while h - n_lower >= 2 and _turn(chain[h - 2], chain[h - 1], p[i]) <= 0:
            h -= 1
        chain[h] = p[i]
        h += 1
    k = 0
    for i in range(n_lower - 1):  # lower[:-1] + upper[:-1]
        out[k] = chain[i]
        k += 1
    for i in range(n_lower, h - 1):
        out[k] = chain[i]
        k += 1
    return k


@njit(cache=True)
def _margin(px, py, hull, h):  # pragma: no cover - compiled
    """response.margin of one point against ``hull[:h]``."""
    if h < 3:
        return np.nan
    inside = True
    cmin, dmin = np.inf, np.inf
    for i in range(h):
        ax, ay = hull[i, 0], hull[i, 1]
        j = i + 1 if i + 1 < h else 0
        ex, ey = hull[j, 0] - ax, hull[j, 1] - ay
        L = math.hypot(ex, ey)
        rx, ry = px - ax, py - ay
        cross = (ex * ry - ey * rx) / L
        t = min(max((rx * ex + ry * ey) / L**2, 0.0), 1.0)
        d = math.hypot(ax + t * ex - px, ay + t * ey - py)
        inside = inside and cross >= 0
        cmin = min(cmin, cross)
        dmin = min(dmin, d)
    return cmin if inside else -dmin


@njit(cache=True)
def _margins(xi, on, feet_pos, feet_quat, corners, first, group, out):  # pragma: no cover - compiled
    ng = first.shape[0]
    nc = corners.shape[1]
    hulls = np.empty((ng, 2 * nc, 2))
    sizes = np.zeros(ng, dtype=np.int64)
    R = np.empty(9)
    pts = np.empty((2 * nc, 2))
    for g in range(ng):
        k = first[g]
        m = 0
        for i in range(2):
            if on[k, i]:
                _quat2mat(feet_quat[k, i], R)
                for c in range(nc):
                    for a in range(2):  # feet_pos + corners @ R.T, the x and y rows
                        pts[m, a] = feet_pos[k, i, a] + (
                            corners[i, c, 0] * R[3 * a]
                            + corners[i, c, 1] * R[3 * a + 1]
                            + corners[i, c, 2] * R[3 * a + 2]
                        )
                    m += 1
        sizes[g] = _hull(pts[:m], hulls[g]) if m else -1
    for r in range(group.shape[0]):
        g = group[r]
        if sizes[g] >= 0:
            out[r] = _margin(xi[r, 0], xi[r, 1], hulls[g], sizes[g])


def margins(xi: np.ndarray, on: np.ndarray, feet_pos: np.ndarray, feet_quat: np.ndarray, corners, k0: int):
    """(n,) Hof's margin [m] of rows k0.. (NaN before k0 and with no foot on the floor): ``xi``
    (n, 2) the extrapolated COM, ``on`` (n, 2) bool the feet on the floor, ``feet_pos`` (n, 2, 3)
    and ``feet_quat`` (n, 2, 4) the feet's poses, ``corners`` the soles' corners per foot in its
    frame ((8, 3) each, :func:`biped.sim.response._sole_corners`)."""
    n = len(xi)
    out = np.full(n, np.nan)
    if k0 >= n:
        return out
    # one hull per contact state and (1 mm, 1e-4) rounded feet pose, from its first row: the key's
    # numbers as integers (np.round(x, 3) == rint(1000 x) / 1000: equal exactly when the integers
    # are), rows sorted by key (stable: a group's first row comes first)
    with np.errstate(invalid="ignore"):  # a diverged run's NaN poses: one key, NaN margins
        key = np.column_stack(
            [
                on[k0:],
                np.rint(feet_pos[k0:].reshape(-1, 6) * 1e3),
                np.rint(feet_quat[k0:].reshape(-1, 8) * 1e4),
            ]
        ).astype(np.int64)
    order = np.lexsort(key.T[::-1])
    s = key[order]
    new = np.ones(len(s), dtype=bool)
    new[1:] = (s[1:] != s[:-1]).any(axis=1)
    first = order[new]
    group = np.empty(len(s), dtype=np.int64)
    group[order] = np.cumsum(new) - 1
    c = np.ascontiguousarray(np.stack([np.asarray(x, dtype=float) for x in corners]))
    _margins(
        np.ascontiguousarray(xi[k0:], dtype=float),
        np.ascontiguousarray(on[k0:], dtype=np.bool_),
        np.ascontiguousarray(feet_pos[k0:], dtype=float),
        np.ascontiguousarray(feet_quat[k0:], dtype=float),
        c,
        first.astype(np.int64),
        group,
        out[k0:],
    )
    return out
