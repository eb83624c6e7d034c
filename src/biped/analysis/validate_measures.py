"""The measures :mod:`biped.analysis.validate` reads off a trial's recorded run: the ankle torque's
peak change and onset after a release, the first step's
length and time to contact, the waist's position ahead of the ankles (Mille et al. 2003), the
base of support ahead of the ankles."""

from __future__ import annotations

import functools
import math

import mujoco
import numpy as np

from biped.sim import Scenario


def _ankle_measures(r, scenario: Scenario) -> tuple[float, float, float]:
    """(peak change of the summed ankle plantar/dorsiflexion torque after release [N m], its onset
    [ms]: the first row where it exceeds 10 % of that peak, the largest hip or knee motion [deg])."""
    ank = [i for i, n in enumerate(r.joint_names) if "dorsiflexion" in n]
    tau = r.torques[:, ank].sum(axis=1)
    t0 = getattr(scenario, "release_time_s", 0.0) if scenario.perturbation == "release" else 0.0
    k0 = min(round(t0 * scenario.control_rate_hz), len(tau) - 1)
    change = np.abs(tau[k0:] - tau[k0])
    peak = float(change.max()) if len(change) else math.nan
    onset = (
        float(np.argmax(change > 0.1 * peak)) * 1000.0 / scenario.control_rate_hz if peak > 0 else math.nan
    )
    hk = [i for i, n in enumerate(r.joint_names) if "ankle" not in n]
    motion = float(np.degrees(np.abs(r.joint_angles[:, hk] - r.joint_angles[0, hk])).max())
    return peak, onset, motion


#: A landing is a contact of the stepping foot that lasts this long [s].
LANDING_S = 0.03


def _step_measures(r, scenario: Scenario) -> tuple[int, float, float]:
    """(steps taken, the first step's foot horizontal displacement from the start to its landing
    (its first contact lasting :data:`LANDING_S` after the sole rose 1 cm off the floor) [m], the
    time from the release to that contact [ms]) from MuJoCo's
    recorded foot poses and sole contacts (not the controller's delayed view); NaN when the foot
    never rose 1 cm or never came down."""
    steps = r.extra.get("steps") or []
    if not steps or r.feet_pos is None:
        return len(steps), math.nan, math.nan
    i = ("left", "right").index(steps[0]["foot"])
    on = r.left_contact if i == 0 else r.right_contact
    n = len(r.times)
    k_up = int(np.searchsorted(r.times, steps[0]["start_s"]))
    m = min(n, len(r.feet_pos))
    hold = max(1, round(LANDING_S * scenario.control_rate_hz))

    def lasting(flags) -> np.ndarray:  # the rows that start a run of `hold` True rows
        f = np.asarray(flags, dtype=np.int64)
        if len(f) < hold:
            return np.zeros(0, dtype=np.int64)
        return np.flatnonzero(np.convolve(f, np.ones(hold, dtype=np.int64), mode="valid") == hold)

    # the lift: the sole off the floor and 1 cm up for LANDING_S (a heel raised about the toe or
    # a contact flicker is not a step); the landing: the first contact after it lasting LANDING_S
    # (a toe scuffing the floor mid-swing is not one)
    on_k = on[k_up:m].astype(bool)
    up = lasting((r.feet_pos[k_up:m, i, 2] > r.feet_pos[0, i, 2] + 0.01) & ~on_k)
    if not len(up):
        return len(steps), math.nan, math.nan
    k0 = k_up + int(up[0])
    back = lasting(on[k0:m].astype(bool))
    if not len(back):
        return len(steps), math.nan, math.nan
    k = k0 + int(back[0])
    length = float(np.linalg.norm(r.feet_pos[k, i, :2] - r.feet_pos[0, i, :2]))
    t0 = getattr(scenario, "release_time_s", 0.0) if scenario.perturbation == "release" else 0.0
    return len(steps), length, 1000.0 * (float(r.times[k]) - t0)


def waist_ahead_of_ankles_m(scene, r) -> float:
    """The pulled point (the pelvis, between the hip joints) ahead of the ankles' midpoint along
    the pull [m], when the cable is let go (the end of the motor's travel; the last recorded row if
    the run ended before), from MuJoCo's recorded state: Mille et al. 2003's threshold position."""
    from biped.sim.perturbations.base import pelvis_point, point_track
    from biped.sim.perturbations.pull import pull_rows

    s = r.scenario
    k = min(pull_rows(s)[1], len(r.qpos) - 1)
    m = scene.model
    cb = scene.central_body
    waist = point_track(scene, r.qpos, cb, pelvis_point(m, cb), [k])[0]
    d = mujoco.MjData(m)
    d.qpos[:] = r.qpos[k]
    mujoco.mj_kinematics(m, d)
    ankles = np.mean([d.xpos[m.body(f"{side}_ankle_1").id] for side in ("left", "right")], axis=0)
    u = np.asarray(s.pull_displacement_m, dtype=float)
    u = u / np.linalg.norm(u)
    return float((waist[:2] - ankles[:2]) @ u)


@functools.lru_cache(maxsize=4)
def ankle_to_toe_m(model: str) -> float:
    """Forward distance [m] from the ankle joints to the front of the toe boxes at the model's
    keyframe (W's biped: 0.199 m of a 0.249 m foot), the base of support ahead of the ankles."""
    from biped.models.subject import resolve

    m = mujoco.MjModel.from_xml_path(str(resolve(model)))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    out = []
    for side in ("left", "right"):
        g = m.geom(f"{side}_toe").id
        R = d.geom_xmat[g].reshape(3, 3)
        corners = [d.geom_xpos[g] + R @ (m.geom_size[g] * (2 * np.array(c) - 1)) for c in np.ndindex(2, 2, 2)]
        front = min(float(c[0]) for c in corners)
        out.append(float(d.xpos[m.body(f"{side}_ankle_1").id][0]) - front)
    return float(np.mean(out))
