"""What the biped's response to a perturbation was: the strategy (ankle, hip, step or fall, after
Horak & Nashner 1986), the peak COM and CoP excursions, Hof's margin of stability, the peak joint
torques per plane and the time to come to rest (docs/perturbations.md, "The response").

Everything is measured from the run's recorded states with MuJoCo (:func:`biped.sim.measure.measure_rows`
for the whole-body COM and the feet's CoP; MuJoCo kinematics for the body angles), from the
perturbation's onset (:func:`onset_s`) on.

The strategy rule (:func:`strategy`), in the plane of the push (vertical, along the direction the
perturbation pushes the body): ``fall`` if the run fell; ``step`` if a foot left the floor (heel
and toe) and the feet's relative placement changed by more than 2 cm; otherwise the trunk's
inclination change dtheta_trunk and the legs' (the line from the ankles' midpoint to the hips'
midpoint) dtheta_leg over the response window (1 s from the onset) decide: ``hip`` when the trunk
rotates against the legs (their correlation is negative) by more than the legs rotate
(peak |dtheta_trunk| > peak |dtheta_leg|) -- Horak & Nashner's hip strategy, the trunk and the
legs moving in opposite directions; else ``ankle`` -- the body swaying as one inverted pendulum,
hip and ankle angle changes in phase. A second, independent reading (:func:`strategy_by_torque`)
labels the same run by torques alone: ``hip`` when the peak change of the sagittal hip torque
exceeds that of the ankle torque, else ``ankle`` (fall and step as above); ``strategy_agree``
says whether both readings agree.

Hof's margin of stability (Hof, Gazendam & Sinke 2005): the extrapolated COM
``xi = x + v / omega_0`` (horizontal, whole-body COM x and velocity v, ``omega_0 = sqrt(g / l)``
with l the COM height at the onset), and its signed distance to the edge of the base of support
(the convex hull of the corners of the soles of the feet on the floor): positive inside. The
minimum over the run after the onset, and when.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import asdict, dataclass

import mujoco
import numpy as np

from biped.sim.loop_measures import LoopRows
from biped.sim.measure import RowMeasurements, measure_rows
from biped.sim.mos import margins
from biped.sim.perturbations import of as perturbation_of

#: the response window after the onset for the strategy [s]
WINDOW_S = 1.0
#: a step: the feet's relative placement changes by more than this [m]
STEP_M = 0.02
#: a swing: a foot off the floor (heel and toe) at least this long [s]
SWING_S = 0.02
#: at rest: whole-body COM speed below this [m/s]
REST_M_S = 0.01

_PLANES = {
    "sagittal": ("hip_flexion", "knee", "ankle_dorsiflexion"),
    "frontal": ("hip_abduction", "ankle_inversion"),
    "transverse": ("hip_rotation",),
}


@dataclass(frozen=True)
class _Onset:
    onset_s: float = math.nan


@dataclass(frozen=True)
class ResponseMeasures:
    """The response measures of one run but its onset: the columns a sweep row takes from it
    (:class:`biped.sim.sweep.record.Measured` derives from this class, so they are one list)."""

    strategy: str = ""
    strategy_torque: str = ""
    strategy_agree: bool = False
    trunk_leg_correlation: float = math.nan
    peak_trunk_change_deg: float = math.nan
    peak_leg_change_deg: float = math.nan
    hip_ankle_torque_ratio: float = math.nan
    peak_com_excursion_m: float = math.nan
    peak_com_excursion_time_s: float = math.nan
    peak_cop_excursion_m: float = math.nan
    peak_cop_excursion_time_s: float = math.nan
    mos_min_m: float = math.nan
    mos_min_time_s: float = math.nan
    peak_hip_sagittal_n_m: float = math.nan
    peak_knee_sagittal_n_m: float = math.nan
    peak_ankle_sagittal_n_m: float = math.nan
    peak_hip_frontal_n_m: float = math.nan
    peak_ankle_frontal_n_m: float = math.nan
    peak_hip_transverse_n_m: float = math.nan
    time_to_rest_s: float = math.nan
    step_needed: bool = False
    step_length_m: float = math.nan
    time_to_foot_contact_s: float = math.nan


@dataclass(frozen=True)
class Response(ResponseMeasures, _Onset):
    """The response measures of one run (SI units, world frame, times from the run's start): the
    onset (its first field, from :class:`_Onset`), then :class:`ResponseMeasures`'s."""

    def to_dict(self) -> dict:
        return asdict(self)


def onset_s(result) -> float:
    """When the perturbation starts acting [s]: the block's hit (the start if it never hits), the
    force's start, the platform's start, the tether's release, the pull's start."""
    s = result.scenario
    if s.perturbation == "block":
        return float(result.block_contact_time_s) if result.block_contact_time_s is not None else 0.0
    return float({"force": s.force_start_s, "platform": s.platform_start_s, "release": s.release_time_s,
                  "pull": s.pull_start_s}[s.perturbation])  # fmt: skip


def push_direction(result) -> np.ndarray:
    """(2,) the unit horizontal direction the perturbation pushes the body (world)."""
    size = perturbation_of(result.scenario).size(1.0)
    a = math.radians(size.direction_deg)
    return np.array([math.cos(a), math.sin(a)])


def body_angles(scene, qpos: np.ndarray, direction) -> tuple[np.ndarray, np.ndarray]:
    """(n,) the legs' and (n,) the trunk's inclination [rad] in the vertical plane along
    ``direction`` (2,), positive toward it: the line from the ankles' midpoint to the hips'
    midpoint, and the central body's z axis (MuJoCo kinematics of each row of ``qpos``)."""
    m = scene.model
    d = mujoco.MjData(m)
    u = np.array([direction[0], direction[1], 0.0])
    ankles = [m.body(f"{s}_ankle_1").id for s in ("left", "right")]
    hips = [m.body(f"{s}_hip_1").id for s in ("left", "right")]
    cb = scene.central_body
    n = len(qpos)
    leg, trunk = np.zeros(n), np.zeros(n)
    for k in range(n):
        d.qpos[:] = qpos[k]
        mujoco.mj_kinematics(m, d)
        v = d.xpos[hips].mean(axis=0) - d.xpos[ankles].mean(axis=0)
        leg[k] = math.atan2(float(v @ u), float(v[2]))
        z = d.xmat[cb].reshape(3, 3)[:, 2]
        trunk[k] = math.atan2(float(z @ u), float(z[2]))
    return leg, trunk


def angles_from_rows(limbs: np.ndarray, trunk_z: np.ndarray, direction) -> tuple[np.ndarray, np.ndarray]:
    """:func:`body_angles` from the loop's records (:class:`~biped.sim.loop_measures.LoopRows`):
    ``limbs`` (n, 4, 3) the left and right ankle_1, then hip_1 frame origins, ``trunk_z`` (n, 3)
    the central body's z axis."""
    u = np.array([direction[0], direction[1], 0.0])
    v = limbs[:, 2:4].mean(axis=1) - limbs[:, 0:2].mean(axis=1)
    return np.arctan2(v @ u, v[:, 2]), np.arctan2(trunk_z @ u, trunk_z[:, 2])


def strategy_from_angles(leg: np.ndarray, trunk: np.ndarray) -> tuple[str, float, float, float]:
    """("ankle" | "hip", correlation, peak |d trunk| [deg], peak |d leg| [deg]) of the angle
    changes ``leg``, ``trunk`` (n,) [rad] over the response window (module docstring)."""
    dl, dt = leg - leg[0], trunk - trunk[0]
    pl, pt = float(np.abs(dl).max()), float(np.abs(dt).max())
    if pl == 0 or pt == 0:
        corr = 0.0
    else:
        corr = float(np.dot(dl, dt) / (np.linalg.norm(dl) * np.linalg.norm(dt)))
    label = "hip" if corr < 0 and pt > pl else "ankle"
    return label, corr, math.degrees(pt), math.degrees(pl)


def strategy_by_torque(torques: np.ndarray, joint_names) -> tuple[str, float]:
    """("ankle" | "hip", ratio): the second reading, peak |change| of the sagittal hip torque over
    that of the ankle torque (both legs summed) over the window's ``torques`` (n, 12)."""
    names = list(joint_names)
    hip = torques[:, names.index("left_hip_flexion")] + torques[:, names.index("right_hip_flexion")]
    ank = (
        torques[:, names.index("left_ankle_dorsiflexion")]
        + torques[:, names.index("right_ankle_dorsiflexion")]
    )
    h, a = float(np.abs(hip - hip[0]).max()), float(np.abs(ank - ank[0]).max())
    ratio = h / a if a > 0 else math.inf
    return ("hip" if ratio > 1.0 else "ankle"), ratio


def _hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull of (m, 2) points (Andrew's monotone chain)."""
    pts = sorted(map(tuple, np.round(points, 12)))
    if len(pts) <= 2:
        return np.array(pts)

    def half(seq):
        out: list = []
        for p in seq:
            while (
                len(out) >= 2
                and (
                    (out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                    - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])
                )
                <= 0
            ):
                out.pop()
            out.append(p)
        return out

    lower, upper = half(pts), half(reversed(pts))
    return np.array(lower[:-1] + upper[:-1])


def margin(points: np.ndarray, hull: np.ndarray) -> np.ndarray:
    """Signed distances [m] of ``points`` (k, 2) to the edge of the convex polygon ``hull``
    (ccw): positive inside, negative outside (NaN for a hull of fewer than 3 points)."""
    points = np.atleast_2d(points)
    if len(hull) < 3:
        return np.full(len(points), np.nan)
    a = hull
    e = np.roll(hull, -1, axis=0) - a  # (h, 2) edges
    L = np.hypot(e[:, 0], e[:, 1])
    rel = points[:, None, :] - a[None, :, :]  # (k, h, 2)
    cross = (e[None, :, 0] * rel[..., 1] - e[None, :, 1] * rel[..., 0]) / L[None, :]
    t = np.clip((rel * e[None]).sum(axis=2) / L[None, :] ** 2, 0.0, 1.0)
    near = a[None] + t[..., None] * e[None] - points[:, None, :]
    dist = np.hypot(near[..., 0], near[..., 1]).min(axis=1)
    inside = (cross >= 0).all(axis=1)
    return np.where(inside, cross.min(axis=1), -dist)


_CORNERS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _sole_corners(m: mujoco.MjModel, scene) -> list:
    """Per foot (left, right): (8, 3) corners of its sole boxes in the body's frame (once a
    model)."""
    found = _CORNERS.get(m)
    if found is not None and found[0] == tuple(scene.sole_geoms):
        return found[1]
    out = []
    for foot in ("left", "right"):
        body = m.body(f"{foot}_foot").id
        pts = []
        for g in scene.sole_geoms:
            if m.geom_bodyid[g] != body:
                continue
            R = np.zeros(9)
            mujoco.mju_quat2Mat(R, m.geom_quat[g])
            h = m.geom_size[g]
            for sx in (-1, 1):
                for sy in (-1, 1):
                    pts.append(m.geom_pos[g] + R.reshape(3, 3) @ (np.array([sx, sy, -1.0]) * h))
        out.append(np.array(pts))
    _CORNERS[m] = (tuple(scene.sole_geoms), out)
    return out


@dataclass(frozen=True, eq=False)
class Traces:
    """The response along the push direction ``u`` (2,), per row [m], from the feet's midpoint at
    the onset: whole-body COM, net CoP, Hof's extrapolated COM xi, and the base of support's
    front (along u) and back edges (NaN with no foot on the floor); ``omega0`` [1/s]."""

    times: np.ndarray
    u: np.ndarray
    com: np.ndarray
    cop: np.ndarray
    xi: np.ndarray
    bos_front: np.ndarray
    bos_back: np.ndarray
    onset_s: float
    omega0: float


def traces(scene, result, rows: RowMeasurements | None = None) -> Traces:
    """:class:`Traces` of ``result`` (W's Fig. 5 style: COM, CoP and xi against the base of support)."""
    rows = rows if rows is not None else measure_rows(scene, result)
    n = len(result.times)
    t0 = onset_s(result)
    k0 = min(int(np.searchsorted(result.times, t0 - 1e-9)), max(n - 1, 0))
    u = push_direction(result)
    origin = result.feet_pos[k0, :, :2].mean(axis=0)
    g = float(np.linalg.norm(rows.gravity))
    w0 = math.sqrt(g / float(rows.whole_body_com[k0, 2]))
    com = (rows.whole_body_com[:, :2] - origin) @ u
    xi = (rows.whole_body_com[:, :2] + rows.whole_body_com_vel[:, :2] / w0 - origin) @ u
    fz = rows.grf[:, :, 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        cop = ((np.nan_to_num(rows.cop) * fz[:, :, None]).sum(axis=1) / fz.sum(axis=1)[:, None] - origin) @ u
    front, back = np.full(n, np.nan), np.full(n, np.nan)
    corners = _sole_corners(scene.model, scene)
    on = (result.left_contact, result.right_contact)
    for k in range(n):
        pts = []
        for i in range(2):
            if on[i][k]:
                R = np.zeros(9)
                mujoco.mju_quat2Mat(R, result.feet_quat[k, i])
                pts.append((result.feet_pos[k, i] + corners[i] @ R.reshape(3, 3).T)[:, :2])
        if pts:
            proj = (np.vstack(pts) - origin) @ u
            front[k], back[k] = proj.max(), proj.min()
    return Traces(result.times, u, com, cop, xi, front, back, t0, w0)


def _first_swing(result, k0: int, on, t0: float) -> tuple[float, float]:
    """(step length [m], time from the onset to its touchdown [s]) of the first swing after row
    ``k0``: a foot off the floor (heel and toe) for at least :data:`SWING_S`, then down again;
    the length is that foot's horizontal displacement over the swing. NaN, NaN if none lands."""
    t = result.times
    need = max(1, round(SWING_S * result.scenario.control_rate_hz))
    best = None
    for i in range(2):
        air = ~np.asarray(on[i][k0:], dtype=bool)
        k = 0
        while k < len(air):
            if not air[k]:
                k += 1
                continue
            j = k
            while j < len(air) and air[j]:
                j += 1
            if j - k >= need and j < len(air):  # a swing that lands at row k0 + j
                if best is None or k0 + j < best[0]:
                    best = (k0 + j, i, k0 + k)
                break
            k = j
    if best is None:
        return math.nan, math.nan
    land, foot, lift = best
    length = float(np.linalg.norm(result.feet_pos[land, foot, :2] - result.feet_pos[lift, foot, :2]))
    return length, float(t[land] - t0)


def _margins(xi: np.ndarray, on, result, corners, k0: int) -> np.ndarray:
    """(n,) Hof's margin of stability of rows k0.. (NaN before and with no foot on the floor):
    one hull of the soles' corners per contact state and (1 mm, 1e-4) rounded feet pose, from its
    first row (:func:`biped.sim.mos.margins` is the same rule, compiled)."""
    n = len(xi)
    mos = np.full(n, np.nan)
    hulls: dict = {}
    for k in range(k0, n):
        key = (bool(on[0][k]), bool(on[1][k]), *np.round(result.feet_pos[k], 3).ravel(),
               *np.round(result.feet_quat[k], 4).ravel())  # fmt: skip
        hulls.setdefault(key, []).append(k)
    for key, ks in hulls.items():
        k = ks[0]
        pts = []
        for i in range(2):
            if key[i]:
                R = np.zeros(9)
                mujoco.mju_quat2Mat(R, result.feet_quat[k, i])
                pts.append((result.feet_pos[k, i] + corners[i] @ R.reshape(3, 3).T)[:, :2])
        if pts:
            mos[ks] = margin(xi[ks], _hull(np.vstack(pts)))
    return mos


def measure_response(scene, result, rows: RowMeasurements | LoopRows | None = None) -> Response:
    """The :class:`Response` of ``result`` (``rows``: its :func:`measure_rows`, computed if None,
    or the loop's records of the same quantities, :func:`biped.sim.loop_measures.loop_rows`)."""
    n = len(result.times)
    if n < 2:
        return Response()
    rows = rows if rows is not None else measure_rows(scene, result)
    t = result.times
    t0 = onset_s(result)
    k0 = min(int(np.searchsorted(t, t0 - 1e-9)), n - 1)
    after = slice(k0, n)
    u = push_direction(result)
    # COM relative to the feet's midpoint (a platform carries the feet)
    mid = result.feet_pos[:, :, :2].mean(axis=1)
    com = rows.whole_body_com[:, :2] - mid
    exc = np.linalg.norm(com[after] - com[k0], axis=1)
    grf = rows.grf
    fz = grf[:, :, 2]
    cop_feet = np.nan_to_num(rows.cop)
    tot = fz.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cop = (cop_feet * fz[:, :, None]).sum(axis=1) / tot[:, None]
    cop = cop - mid
    ok = np.isfinite(cop[after]).all(axis=1)
    cop_exc = np.where(ok, np.linalg.norm(np.nan_to_num(cop[after] - cop[k0]), axis=1), np.nan)
    # Hof's margin of stability
    g = float(np.linalg.norm(rows.gravity))
    l0 = float(rows.whole_body_com[k0, 2])
    xi = rows.whole_body_com[:, :2] + rows.whole_body_com_vel[:, :2] / math.sqrt(g / l0)
    m = scene.model
    corners = _sole_corners(m, scene)
    on = (result.left_contact, result.right_contact)
    if isinstance(rows, LoopRows):  # a sweep's row: the same rule, compiled (biped.sim.mos)
        mos = margins(xi, np.column_stack(on), result.feet_pos, result.feet_quat, corners, k0)
    else:
        mos = _margins(xi, on, result, corners, k0)
    # torques per plane, peak |tau| after the onset, over both legs
    names = list(result.joint_names)
    peaks = {}
    for plane, joints in _PLANES.items():
        for j in joints:
            cols = [names.index(f"{s}_{j}") for s in ("left", "right")]
            peaks[(j.split("_")[0], plane)] = float(np.abs(result.torques[after][:, cols]).max())
    # at rest: the last time the COM moved faster than REST_M_S
    speed = np.linalg.norm(rows.whole_body_com_vel[after, :2], axis=1)
    moving = np.flatnonzero(speed >= REST_M_S)
    rest = math.nan
    if not result.fell and len(moving) and moving[-1] + 1 < len(speed):
        rest = float(t[k0 + moving[-1] + 1] - t0)
    elif not result.fell and not len(moving):
        rest = 0.0
    # stepping: a foot fully off the floor, and the feet's relative placement changed
    win = slice(k0, min(n, k0 + round(WINDOW_S * result.scenario.control_rate_hz) + 1))
    rel = result.feet_pos[:, 1, :2] - result.feet_pos[:, 0, :2]
    airborne = ~np.asarray(on[0][after]) | ~np.asarray(on[1][after])
    moved = float(np.linalg.norm(rel[after] - rel[k0], axis=1).max())
    stepped = bool(airborne.any() and moved > STEP_M) or bool(result.extra.get("steps"))
    step_len, contact_t = math.nan, math.nan
    if stepped:  # the first swing: a foot off the floor (heel and toe) for >= SWING_S, then down
        step_len, contact_t = _first_swing(result, k0, on, t0)
    if isinstance(rows, LoopRows):
        leg, trunk = angles_from_rows(rows.limbs[win], rows.trunk_z[win], u)
    else:
        leg, trunk = body_angles(scene, result.qpos[win], u)
    label, corr, pt, pl = strategy_from_angles(leg, trunk)
    tlabel, ratio = strategy_by_torque(result.torques[win], names)
    if result.fell:
        label = tlabel = "fall"
    elif stepped:
        label = tlabel = "step"
    kc = int(np.argmax(exc))
    kp = int(np.nanargmax(cop_exc)) if np.isfinite(cop_exc).any() else 0
    finite = np.isfinite(mos)
    km = int(np.nanargmin(mos)) if finite.any() else 0
    return Response(
        onset_s=t0,
        strategy=label,
        strategy_torque=tlabel,
        strategy_agree=label == tlabel,
        trunk_leg_correlation=corr,
        peak_trunk_change_deg=pt,
        peak_leg_change_deg=pl,
        hip_ankle_torque_ratio=ratio,
        peak_com_excursion_m=float(exc[kc]),
        peak_com_excursion_time_s=float(t[k0 + kc]),
        peak_cop_excursion_m=float(cop_exc[kp]) if np.isfinite(cop_exc).any() else math.nan,
        peak_cop_excursion_time_s=float(t[k0 + kp]) if np.isfinite(cop_exc).any() else math.nan,
        mos_min_m=float(mos[km]) if finite.any() else math.nan,
        mos_min_time_s=float(t[km]) if finite.any() else math.nan,
        peak_hip_sagittal_n_m=peaks[("hip", "sagittal")],
        peak_knee_sagittal_n_m=peaks[("knee", "sagittal")],
        peak_ankle_sagittal_n_m=peaks[("ankle", "sagittal")],
        peak_hip_frontal_n_m=peaks[("hip", "frontal")],
        peak_ankle_frontal_n_m=peaks[("ankle", "frontal")],
        peak_hip_transverse_n_m=peaks[("hip", "transverse")],
        time_to_rest_s=rest,
        step_needed=stepped,
        step_length_m=step_len,
        time_to_foot_contact_s=contact_t,
    )


__all__ = [
    "Response",
    "Traces",
    "traces",
    "angles_from_rows",
    "body_angles",
    "margin",
    "measure_response",
    "onset_s",
    "push_direction",
    "strategy_by_torque",
    "strategy_from_angles",
]
