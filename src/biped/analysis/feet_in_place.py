"""Hof's feet-in-place bound on a push: the largest impulse the biped can take without stepping,
from its extrapolated centre of mass (Hof, Gazendam & Sinke, J. Biomech. 38:1-8, 2005), for given
body numbers (:func:`hof_bound`, a closed form) or for the shipped biped at a scenario's initial
state (:func:`feet_in_place_bound`, body numbers from MuJoCo).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from scipy.spatial import ConvexHull

from biped import models
from biped.errors import ScenarioError
from biped.sim.scenario import Scenario
from biped.sim.scene import build_scene, initial_state

GRAVITY = float(-models.gravity("wendlandt")[2])  # [m/s^2], the biped model's, which the scene keeps


@dataclass(frozen=True)
class FeetInPlaceBound:
    """Hof's feet-in-place bound on the impulse (Hof, Gazendam & Sinke, J. Biomech. 38:1-8,
    2005: the extrapolated centre of mass ``xcom = x + v / omega_0`` must stay inside the base
    of support). An impulse J on a body of mass m changes its COM velocity by J / m, moving the
    XCoM by J / (m omega_0); the feet can hold it while that is at most d, the distance from the
    COM's ground projection to the edge of the support polygon in the push direction:

        J_max = m omega_0 d,     omega_0 = sqrt(g / h)

    directions_deg (k,) push directions (the block's travel); d_m (k,) [m]; j_max_n_s (k,)
    [N s]; mass_kg, com_height_m (h: whole-body COM above the soles), omega0 [1/s];
    com_xy (2,) and polygon_xy (p, 2) (counter-clockwise) [m], world frame.
    """

    directions_deg: np.ndarray
    d_m: np.ndarray
    j_max_n_s: np.ndarray
    mass_kg: float
    com_height_m: float
    omega0: float
    com_xy: np.ndarray
    polygon_xy: np.ndarray

    def speed_equivalent(self, block_mass_kg: float, restitution: float) -> np.ndarray:
        """Block speed [m/s] that delivers J_max in a head-on impact on a much heavier body,
        ``v = J_max / ((1 + e) m_block)`` (the point-mass collision law; an approximation)."""
        return self.j_max_n_s / ((1.0 + restitution) * block_mass_kg)


def ray_to_polygon_edge(point: Any, direction_deg: float, polygon: Any) -> float:
    """Distance [m] from ``point`` (2,) inside a convex ``polygon`` (p, 2) to its edge along
    the direction ``direction_deg`` (from +x toward +y). Raises if the point is outside."""
    p = np.asarray(point, dtype=float)
    poly = np.asarray(polygon, dtype=float)
    a = math.radians(direction_deg)
    u = np.array([math.cos(a), math.sin(a)])
    best = np.inf
    for i in range(len(poly)):
        q0, q1 = poly[i], poly[(i + 1) % len(poly)]
        e = q1 - q0
        den = u[0] * (-e[1]) - u[1] * (-e[0])
        if abs(den) < 1e-15:
            continue
        r = q0 - p
        t = (r[0] * (-e[1]) - r[1] * (-e[0])) / den
        s = (u[0] * r[1] - u[1] * r[0]) / den
        if t >= -1e-12 and -1e-12 <= s <= 1 + 1e-12:
            best = min(best, t)
    if not np.isfinite(best):
        raise ScenarioError(f"the point {p.tolist()} is outside the support polygon")
    return float(max(best, 0.0))


def hof_bound(
    directions_deg: Any,
    mass_kg: float,
    com_height_m: float,
    com_xy: Any,
    polygon_xy: Any,
    gravity: float = GRAVITY,
) -> FeetInPlaceBound:
    """:class:`FeetInPlaceBound` for given body numbers (closed form, no model)."""
    if not (mass_kg > 0 and com_height_m > 0):
        raise ScenarioError("mass_kg and com_height_m must be > 0")
    dirs = np.asarray(directions_deg, dtype=float)
    omega0 = math.sqrt(gravity / com_height_m)
    d = np.array([ray_to_polygon_edge(com_xy, a, polygon_xy) for a in dirs])
    return FeetInPlaceBound(
        dirs,
        d,
        mass_kg * omega0 * d,
        float(mass_kg),
        float(com_height_m),
        omega0,
        np.asarray(com_xy, float),
        np.asarray(polygon_xy, float),
    )


@functools.lru_cache(maxsize=8)
def _support_polygon(scenario: Scenario) -> tuple[np.ndarray, float, float, np.ndarray]:
    scene = build_scene(scenario)
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:], _ = initial_state(scene, scenario)
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    points = []
    for g in scene.sole_geoms:
        half = m.geom_size[g]
        R = d.geom_xmat[g].reshape(3, 3)
        for sx in (-1, 1):
            for sy in (-1, 1):
                for sz in (-1, 1):
                    points.append(d.geom_xpos[g] + R @ (half * [sx, sy, sz]))
    corners = np.array(points)
    z_sole = corners[:, 2].min()
    bottom = corners[corners[:, 2] < z_sole + 1e-3]
    hull = ConvexHull(bottom[:, :2])
    polygon = bottom[hull.vertices, :2]  # counter-clockwise
    # the biped's tree alone: not the block, nor a paradigm's bodies (the 1000 kg platform)
    mass = float(m.body_subtreemass[m.body_rootid[scene.central_body]])
    com = d.subtree_com[scene.central_body]
    return com[:2].copy(), float(com[2] - z_sole), mass, polygon


def support_polygon(scenario: Scenario | None = None) -> tuple[np.ndarray, float, float, np.ndarray]:
    """(com_xy (2,), com height above the soles [m], biped mass [kg], polygon (p, 2)) of the
    biped at the scenario's initial state: whole-body COM from MuJoCo (``subtree_com`` of the
    central body) and the convex hull of the bottom corners of the four sole boxes."""
    com_xy, h, mass, polygon = _support_polygon(scenario or Scenario())
    return com_xy.copy(), h, mass, polygon.copy()


def feet_in_place_bound(directions_deg: Any, scenario: Scenario | None = None) -> FeetInPlaceBound:
    """Hof's bound for the shipped biped at the scenario's initial state (W's by default)."""
    com_xy, h, mass, polygon = support_polygon(scenario)
    return hof_bound(directions_deg, mass, h, com_xy, polygon)


__all__ = ["FeetInPlaceBound", "feet_in_place_bound", "hof_bound", "ray_to_polygon_edge", "support_polygon"]
