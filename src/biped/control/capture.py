"""Capture-point stepping math on the linear inverted pendulum (LIPM); pure functions, no state
except the small :class:`CaptureTrigger`.

LIPM (Kajita et al. 2001): a point mass at constant height h above the floor over a centre of
pressure p obeys ``x'' = omega_0^2 (x - p)``, ``omega_0 = sqrt(g / h)``, whose closed form is

    x(t) = p + (x_0 - p) cosh(omega_0 t) + v_0 / omega_0 sinh(omega_0 t).

The instantaneous capture point (Pratt et al. 2006; Hof's extrapolated COM)
``xi = x + v / omega_0`` obeys ``xi' = omega_0 (xi - p)``, so with p held for a time T,

    xi(T) = p + (xi_0 - p) e^{omega_0 T}                                   (:func:`predict_capture_point`)

and stepping so that the new CoP can sit at xi(T) brings the pendulum to rest over it (Koolen et
al. 2012). Frames: world, z up; 2-vectors are (x, y) on the floor [m], velocities [m/s].

Support polygons are convex, counter-clockwise (p, 2) arrays; :func:`support_polygon` builds one
from sole rectangles (:class:`biped.model.SoleRectangle` numbers) and foot poses;
:func:`signed_distance` is > 0 outside, < 0 inside (the distance to the nearest edge line).
:func:`min_jerk` and :func:`bump` are the swing foot's path pieces (horizontal, vertical).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from biped.errors import ScenarioError

__all__ = [
    "CaptureTrigger",
    "StepLimits",
    "bump",
    "capture_point",
    "clamp_step",
    "convex_hull",
    "excess",
    "lipm_state",
    "min_jerk",
    "omega0",
    "outward_normal",
    "predict_capture_point",
    "reach_step_limit",
    "shrink_polygon",
    "signed_distance",
    "sole_corners",
    "step_target",
    "support_polygon",
    "xcom_offset",
]


def omega0(com_height_m: float, gravity: float = 9.81) -> float:
    """``omega_0 = sqrt(g / h)`` [1/s] of the LIPM, h the COM height above the floor [m]."""
    if not (com_height_m > 0 and gravity > 0):
        raise ScenarioError(
            f"the LIPM needs a COM height > 0 and gravity > 0; got h = {com_height_m} m, g = {gravity} m/s^2"
        )
    return math.sqrt(gravity / com_height_m)


def capture_point(com_xy, com_vel_xy, omega: float) -> np.ndarray:
    """Instantaneous capture point ``xi = x + v / omega_0`` (2,) [m]."""
    return np.asarray(com_xy, dtype=float)[:2] + np.asarray(com_vel_xy, dtype=float)[:2] / omega


def lipm_state(x0, v0, cop, omega: float, t: float) -> tuple[np.ndarray, np.ndarray]:
    """The LIPM's closed-form (position, velocity) at time t from (x0, v0) over a fixed CoP."""
    x0, v0, p = (np.asarray(a, dtype=float) for a in (x0, v0, cop))
    c, s = math.cosh(omega * t), math.sinh(omega * t)
    return p + (x0 - p) * c + v0 / omega * s, (x0 - p) * omega * s + v0 * c


def predict_capture_point(xi, cop, omega: float, t: float) -> np.ndarray:
    """``xi(T) = p + (xi - p) e^{omega_0 T}``: the capture point after holding the CoP p for T."""
    xi, p = np.asarray(xi, dtype=float), np.asarray(cop, dtype=float)
    return p + (xi - p) * math.exp(omega * t)


# ---------------------------------------------------------------------------------------------
# support polygons


def convex_hull(points) -> np.ndarray:
    """Counter-clockwise convex hull (p, 2) of (n, 2) points (Andrew's monotone chain)."""
    arr = np.asarray(points, dtype=float).reshape(-1, 2)
    # points closer than 1e-12 of the set's extent are one point (rounding, denormal offsets):
    # snap them to that grid before the exact orientation tests
    scale = float(np.abs(arr).max()) if arr.size else 0.0
    if scale > 0:
        q = 1e-12 * scale
        arr = np.round(arr / q) * q
    pts = sorted(set(map(tuple, arr)))
    if len(pts) < 3:
        return np.array(pts, dtype=float)

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple] = []
    upper: list[tuple] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1], dtype=float)


def sole_corners(centre_xy, yaw: float, half_length: float, half_width: float) -> np.ndarray:
    """(4, 2) corners of a sole rectangle centred at ``centre_xy`` [m], turned by ``yaw`` [rad]."""
    c, s = math.cos(yaw), math.sin(yaw)
    R = np.array([[c, -s], [s, c]])
    local = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]], dtype=float) * (half_length, half_width)
    return np.asarray(centre_xy, dtype=float)[:2] + local @ R.T


def support_polygon(soles) -> np.ndarray:
    """Convex hull of the corners of the soles in contact: ``soles`` is a sequence of
    (centre_xy, yaw, half_length, half_width)."""
    soles = list(soles)
    if not soles:
        raise ScenarioError("a support polygon needs at least one sole in contact")
    return convex_hull(np.vstack([sole_corners(*s) for s in soles]))


def _edges(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outward unit normals (p, 2) and offsets (p,) of a CCW polygon: inside is ``n . x <= b``."""
    d = np.roll(poly, -1, axis=0) - poly
    n = np.stack([d[:, 1], -d[:, 0]], axis=1)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return n, np.einsum("ij,ij->i", n, poly)


def signed_distance(poly, point) -> float:
    """max over edges of ``n . x - b``: < 0 inside (minus the distance to the nearest edge), > 0
    outside (a lower bound of the Euclidean distance, exact off the edges' ends)."""
    n, b = _edges(np.asarray(poly, dtype=float))
    return float(np.max(n @ np.asarray(point, dtype=float)[:2] - b))


def outward_normal(poly, point) -> np.ndarray:
    """The outward unit normal (2,) of the polygon's edge with the largest ``n . x - b``."""
    n, b = _edges(np.asarray(poly, dtype=float))
    return n[int(np.argmax(n @ np.asarray(point, dtype=float)[:2] - b))]


def shrink_polygon(poly, margin: float) -> np.ndarray:
    """The polygon with every edge moved inward by ``margin`` [m] (vertices of consecutive edge
    lines' intersections; the polygon must stay non-empty: margin below its inradius)."""
    poly = np.asarray(poly, dtype=float)
    n, b = _edges(poly)
    b = b - margin
    out = []
    k = len(poly)
    for i in range(k):
        j = (i - 1) % k  # the edges meeting at vertex i: j (into it) and i (out of it)
        A = np.array([n[j], n[i]])
        out.append(np.linalg.solve(A, [b[j], b[i]]))
    return np.array(out)


# ---------------------------------------------------------------------------------------------
# trigger and step target


class CaptureTrigger:
    """Step trigger with hysteresis: fires once the capture point has stayed outside the support
    polygon shrunk by ``margin_m`` for ``hold`` consecutive calls; re-arms only after it has
    come back inside the polygon shrunk by ``rearm_margin_m`` (> margin_m).

    ``lateral_margin_m`` (>= margin_m) shrinks the polygon's extent along world y (the biped's
    sideways axis) further: sideways the feet-in-place strategy holds the capture point just
    inside the polygon's edge while the trunk rolls over, so waiting for xi to cross the edge
    steps too late (:func:`excess` is the test). Re-arming asks for the same extra inside."""

    def __init__(
        self,
        margin_m: float = 0.0,
        rearm_margin_m: float = 0.02,
        hold: int = 3,
        lateral_margin_m=None,
        min_rate_m_s: float | None = None,
    ):
        if rearm_margin_m < margin_m:
            raise ScenarioError(f"rearm_margin_m ({rearm_margin_m}) must be >= margin_m ({margin_m})")
        lateral = margin_m if lateral_margin_m is None else float(lateral_margin_m)
        if lateral < margin_m:
            raise ScenarioError(f"lateral_margin_m ({lateral}) must be >= margin_m ({margin_m})")
        self.margin_m, self.rearm_margin_m, self.hold = margin_m, rearm_margin_m, int(hold)
        self.lateral_margin_m = lateral
        self.min_rate_m_s = min_rate_m_s
        self.armed = True
        self._count = 0

    def update(self, poly, xi, xi_rate=None) -> bool:
        ex, ey = excess(poly, xi)
        d = max(ex + self.margin_m, ey + self.lateral_margin_m)  # > 0: outside the shrunk polygon
        if d > 0 and self.min_rate_m_s is not None and xi_rate is not None:
            # the feet cannot hold only while xi still moves away from the polygon
            if d == ey + self.lateral_margin_m and ey + self.lateral_margin_m > ex + self.margin_m:
                y = float(np.asarray(xi, dtype=float)[1])
                mid = 0.5 * (float(np.max(poly[:, 1])) + float(np.min(poly[:, 1])))
                n = np.array([0.0, 1.0 if y > mid else -1.0])
            else:
                n = outward_normal(poly, xi)
            if float(n @ np.asarray(xi_rate, dtype=float)[:2]) <= self.min_rate_m_s:
                d = -1.0
        if not self.armed:
            if d < -(self.rearm_margin_m - self.margin_m):
                self.armed = True
            self._count = 0
            return False
        self._count = self._count + 1 if d > 0 else 0
        if self._count >= self.hold:
            self.armed = False
            self._count = 0
            return True
        return False


def excess(poly, xi) -> tuple[float, float]:
    """(signed distance of xi to the polygon (:func:`signed_distance`), signed distance of xi's
    y to the polygon's y-extent [ymin, ymax]) [m]: > 0 outside, < 0 inside."""
    poly = np.asarray(poly, dtype=float)
    y = float(np.asarray(xi, dtype=float)[1])
    return signed_distance(poly, xi), max(y - float(poly[:, 1].max()), float(poly[:, 1].min()) - y)


@dataclass(frozen=True)
class StepLimits:
    """Where a swing foot may land, relative to the stance foot's sole centre (world axes; the
    stance foot's side given by ``side`` = +1 left of it... see :func:`clamp_step`) [m].

    max_step: largest distance between the sole centres; min_width / max_width: the lateral
    (y) separation of the sole centres, swing foot on its own side (no crossover: min_width
    leaves a gap between the 9.2 cm soles); max_back: how far behind the stance foot (along +x,
    the biped faces -x) a foot may land.
    """

    max_step: float = 0.50
    min_width: float = 0.13
    max_width: float = 0.22
    max_back: float = 0.30


def reach_step_limit(reach_m: float, hip_height_m: float) -> float:
    """The longest step between the ankles that two legs reaching ``reach_m`` from hips
    ``hip_height_m`` above the ankles allow: each leg at its reach, one ahead of the hips and one
    behind, ``2 sqrt(reach^2 - h^2)`` [m] (0 if the hips are higher than the reach)."""
    if not (reach_m > 0 and hip_height_m >= 0):
        raise ValueError(f"reach_m must be > 0 and hip_height_m >= 0; got {reach_m!r}, {hip_height_m!r}")
    return 2.0 * math.sqrt(max(reach_m**2 - hip_height_m**2, 0.0))


def clamp_step(target_xy, stance_xy, side: float, limits: StepLimits = StepLimits()) -> np.ndarray:
    """The landing point nearest ``target_xy`` that the limits allow. ``side`` is the sign of
    the swing foot's y relative to the stance foot (+1: the swing foot is the right foot, which
    lies on +y; -1: the left)."""
    rel = np.asarray(target_xy, dtype=float)[:2] - np.asarray(stance_xy, dtype=float)[:2]
    lat = min(max(side * rel[1], limits.min_width), limits.max_width)
    fwd = min(rel[0], limits.max_back)
    rel = np.array([fwd, side * lat])
    r = np.linalg.norm(rel)
    if r > limits.max_step:  # shorten along x first, keep the lateral gap
        fwd_max = math.sqrt(max(limits.max_step**2 - lat**2, 0.0))
        rel[0] = math.copysign(min(abs(rel[0]), fwd_max), rel[0])
    return np.asarray(stance_xy, dtype=float)[:2] + rel


def step_target(
    xi,
    cop,
    omega: float,
    t_remaining: float,
    stance_xy,
    side: float,
    offset_m: float = 0.03,
    limits: StepLimits = StepLimits(),
    side_margin_m: float = 0.0,
) -> np.ndarray:
    """Landing point of the swing sole's centre: ``xi_td = p + (xi - p) e^{omega_0 T}`` (the
    capture point when the foot lands, T = t_remaining, CoP p held), moved ``offset_m`` further
    along ``xi_td - p`` so that the capture point lands inside the new support polygon by that
    much; with ``side_margin_m`` > 0 the sole centre also lies at least that far beyond xi_td
    sideways, on the swing foot's side (``side``), so that xi_td lands inside the sole across
    too; then :func:`clamp_step`."""
    p = np.asarray(cop, dtype=float)[:2]
    xi_td = predict_capture_point(xi, p, omega, max(t_remaining, 0.0))
    d = xi_td - p
    r = np.linalg.norm(d)
    land = xi_td + offset_m * d / r if r > 1e-9 else xi_td.copy()
    if side_margin_m > 0.0:
        land[1] = side * max(side * land[1], side * xi_td[1] + side_margin_m)
    return clamp_step(land, stance_xy, side, limits)


def xcom_offset(landing_xy, xcom_xy, stance_xy) -> float:
    """How far [m] the landing sole centre lies beyond the extrapolated COM (Hof's XCoM, the
    capture point) at touchdown, along the line from the stance sole centre through the XCoM:
    > 0 outward of it (Hof, Vermerris & Gjaltema 2010: people land a constant offset outward)."""
    u = np.asarray(xcom_xy, dtype=float)[:2] - np.asarray(stance_xy, dtype=float)[:2]
    r = float(np.linalg.norm(u))
    if r < 1e-9:
        return float("nan")
    return float((np.asarray(landing_xy, dtype=float)[:2] - np.asarray(xcom_xy, dtype=float)[:2]) @ u / r)


# ---------------------------------------------------------------------------------------------
# swing path


def min_jerk(s: float) -> tuple[float, float, float]:
    """h(s) = 10 s^3 - 15 s^4 + 6 s^5 and its first two derivatives, s clamped to [0, 1]."""
    if s <= 0.0:
        return 0.0, 0.0, 0.0
    if s >= 1.0:
        return 1.0, 0.0, 0.0
    return (s**3 * (10 - 15 * s + 6 * s * s), 30 * s * s * (1 - s) ** 2, 60 * s * (1 - s) * (1 - 2 * s))


def bump(s: float) -> tuple[float, float, float]:
    """64 s^3 (1 - s)^3 (peak 1 at s = 1/2, zero value, slope and curvature at both ends) and its
    first two derivatives."""
    if s <= 0.0 or s >= 1.0:
        return 0.0, 0.0, 0.0
    u = 1 - s
    return (
        64 * s**3 * u**3,
        192 * s * s * u * u * (u - s),
        192 * (2 * s * u**3 - 6 * s * s * u * u + 2 * s**3 * u),
    )
