"""W's lean-and-release (:mod:`biped.sim.perturbations.release`) on a robot's own MJCF
(``biped push --model NAME --perturbation release``, its sweeps and envelopes; docs/robots.md).

The same three steps as on W's biped, through the robot's description instead of W's names:

1. **the pose**: the standing pose (:func:`biped.sim.robot.standing_qpos`), the floating body
   (and with it every held joint's body: the whole robot above the feet) turned by the lean about
   the horizontal axis through **the ankles' midpoint** (the anchors of each leg's 5th hinge, its
   first ankle joint), perpendicular to the lean's direction; each leg's six hinges are solved by
   W's Newton solver on MuJoCo's Jacobians
   (:func:`~biped.sim.perturbations.release.turn_about`) to put its foot back where it stood,
   flat. Refused (one line) when a leg finds no solution or a leg joint leaves its range;
2. **the tether**: W's constant horizontal force ``T = m g e / h`` at **the hip joints' midpoint**
   (the anchors of each leg's first hinge, where the robots' force pulse and waist pull act) on the
   floating body, against the lean (:func:`~biped.sim.perturbations.release.tether_force`; refused
   when the floor's friction at the feet, MuJoCo's own contact friction, could not hold it);
3. **the controller holds the rest**: its set point is the leaned central body (the folded body's
   COM frame) with W's feed-forward ``X = -P_1^{-1} W_tether`` (the tether's wrench about the
   folded central body's COM; :func:`~biped.sim.perturbations.release.hold_acceleration`).

At ``release_s`` the tether goes and the set point returns upright (W's
:class:`~biped.sim.perturbations.release.ReleaseDriver`, run every physics step: the robots'
controller has no feedback delay, so the release is sensed at once; with stepping, the stepping
controller's set point holds the lean and its trigger is armed at the release).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from biped.errors import ScenarioError
from biped.models.robot import RobotDescription
from biped.sim.perturbations.base import horizontal
from biped.sim.perturbations.release import (
    ReleaseDriver,
    hold_acceleration,
    tether_force,
    turn_about,
)
from biped.spatial import rot_to_quat


@dataclass(frozen=True)
class ReleaseLean:
    """The lean ``lean_deg`` [deg, 0 to 45] toward ``direction_deg`` (world, from +x toward +y: the
    robots face +x, so 0 is a forward lean, 90 to the robot's left), released at ``release_s``
    [s] (at or after the run's end: never, the held state)."""

    lean_deg: float
    direction_deg: float = 0.0
    release_s: float = 0.1


def _points(m: mujoco.MjModel, d: mujoco.MjData, desc: RobotDescription) -> tuple[np.ndarray, np.ndarray]:
    """(the ankles' midpoint, the hips' midpoint) [m, world]: the anchors of each leg's 5th and
    1st hinge (``desc.leg_joints``: left then right, hip to ankle)."""
    j = [m.joint(n).id for n in desc.leg_joints]
    return d.xanchor[[j[4], j[10]]].mean(axis=0), d.xanchor[[j[0], j[6]]].mean(axis=0)


def lean_robot(desc: RobotDescription, m: mujoco.MjModel, q0: np.ndarray, lean: ReleaseLean, tree) -> dict:
    """The leaned pose of the robot standing at ``q0`` (the plant ``m``'s qpos), module docstring
    step 1: ``qpos`` (the leaned plant qpos), the upright whole-body COM, the ankles' midpoint,
    the lean's unit direction; :class:`ScenarioError` for a pose the legs cannot reach."""
    if not (0.0 <= lean.lean_deg <= 45.0) or not math.isfinite(lean.direction_deg):
        raise ScenarioError(
            f"release_lean_deg must be in [0, 45] deg (a lean about the ankles); got {lean.lean_deg!r}"
        )
    d = mujoco.MjData(m)
    d.qpos[:] = q0
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    rb = m.body(desc.root).id
    upright_com = d.subtree_com[rb].copy()
    ankles, _ = _points(m, d, desc)
    u = horizontal(lean.direction_deg)
    q = np.array(q0, dtype=float)
    root = tree.qpos_adr[0] + np.arange(7)
    legs = [[m.joint(n).id for n in desc.leg_joints[k : k + 6]] for k in (0, 6)]
    feet = [m.body(f).id for f in desc.feet]
    try:
        ok = turn_about(
            m, q, root, feet, legs, ankles, np.cross([0.0, 0.0, 1.0], u), math.radians(lean.lean_deg)
        )
    except np.linalg.LinAlgError:
        ok = False
    if not ok:
        raise ScenarioError(
            f"release_lean_deg = {lean.lean_deg:g} toward {lean.direction_deg:g} deg: a foot of "
            f"{desc.path.name} cannot stay flat where it stood (its leg's joints found no solution); lean less"
        )
    for j in (m.joint(n) for n in desc.leg_joints):
        lo, hi = m.jnt_range[j.id]
        a = float(q[m.jnt_qposadr[j.id]])
        if m.jnt_limited[j.id] and not (lo - 1e-9 <= a <= hi + 1e-9):
            raise ScenarioError(
                f"release_lean_deg = {lean.lean_deg:g} toward {lean.direction_deg:g} deg is out of "
                f"{desc.path.name}'s reach: joint {j.name!r} would be at {math.degrees(a):.1f} deg, outside "
                f"its range [{math.degrees(lo):.1f}, {math.degrees(hi):.1f}] deg; lean less"
            )
    return {"qpos": q, "upright_com": upright_com, "ankles": ankles, "direction": u}


def _friction(m: mujoco.MjModel, d: mujoco.MjData, floor: int) -> float:
    """The smallest sliding friction of the floor's contacts in ``d`` (MuJoCo's own, the
    geoms' or the pair's); the floor's own without a contact."""
    mus = [
        float(d.contact.friction[i, 0])
        for i in range(d.ncon)
        if floor in (int(d.contact.geom1[i]), int(d.contact.geom2[i]))
    ]
    return min(mus) if mus else float(m.geom_friction[floor, 0])


def _check_hold(desc: RobotDescription, ctrl, f: np.ndarray, weight: float, mu_floor: float, u) -> None:
    """Refuse a tether the feet cannot hold before the release (W's 0.95 margin): more than the
    floor's friction (MuJoCo's contacts) or, with the QP, more than its friction pyramid lets the
    controller ask of the feet along the lean (``friction * friction_scale`` on each sole axis)."""
    mu, what = mu_floor, f"the floor's friction {mu_floor:g}"
    qp = getattr(ctrl, "qp", None)
    if qp is not None:
        w = qp.weights
        mu_qp = w.friction * w.friction_scale / max(abs(float(u[0])), abs(float(u[1])))
        if mu_qp < mu:
            mu, what = (
                mu_qp,
                f"the QP's friction pyramid {mu_qp:.3g} along the lean (friction {w.friction:g})",
            )
    T = float(np.linalg.norm(f))
    if T > 0.95 * mu * weight:
        raise ScenarioError(
            f"release_lean_deg: the feet of {desc.path.name} cannot hold this lean before the release: "
            f"the tether pulls {T:.0f} N, {T / weight:.2f} of the robot's weight, more than 0.95 x {what} "
            "lets them hold; lean less"
        )


def robot_hold(
    desc: RobotDescription, m: mujoco.MjModel, q: np.ndarray, pose: dict, ctrl, floor: int
) -> dict:
    """The tether and the controller's hold at the leaned pose ``q`` (module docstring, steps 2
    and 3), as W's :class:`ReleaseDriver` takes them; ``ctrl`` the controller whose ``P_1``
    holds (the stepping controller's holding one when stepping)."""
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    rb = m.body(desc.root).id
    total = float(m.body_subtreemass[rb])
    g = float(-m.opt.gravity[2])
    _, p = _points(m, d, desc)
    e = float((d.subtree_com[rb] - pose["upright_com"]) @ pose["direction"])
    f = tether_force(total, g, e, float(p[2]), pose["direction"], math.inf)
    _check_hold(desc, ctrl, f, total * g, _friction(m, d, floor), pose["direction"])
    tree = ctrl.tree
    g_cb = ctrl.link_poses(q[: tree.nq])[0]  # the folded central body's COM frame
    c, R = g_cb[:3, 3].copy(), np.ascontiguousarray(g_cb[:3, :3])
    out = ctrl.compute(q[: tree.nq], np.zeros(tree.nv), feet_in_contact=(True, True))
    return {
        "body": rb,
        "tether_force": f,
        "tether_moment": np.cross(p - d.xipos[rb], f),  # the plant's: about the floating body's own COM
        "hold_acc": hold_acceleration(out.P1, R, f, np.cross(p - c, f)),  # the controller's: about c
        "hold_com": c,
        "hold_quat": np.asarray(rot_to_quat(R), dtype=float),
        "pelvis": p,
    }


def release_driver(
    desc: RobotDescription, m: mujoco.MjModel, d: mujoco.MjData, ctrl, q0, lean: ReleaseLean, steps: int,
    floor: int, stepper=None,
) -> ReleaseDriver:  # fmt: skip
    """``d`` put in the leaned pose (at rest) and W's :class:`ReleaseDriver` for it: call its
    ``apply(i, t, d)`` before every physics step ``i`` (of ``steps``). The upright set point is
    ``ctrl.target``'s (the standing one)."""
    from types import SimpleNamespace

    tree = ctrl.tree
    upright = (np.array(ctrl.target.com, dtype=float), np.array(ctrl.target.quat, dtype=float))
    pose = lean_robot(desc, m, q0, lean, tree)
    d.qpos[: tree.nq] = pose["qpos"][: tree.nq]
    d.qvel[:] = 0.0
    holder = stepper.holding_controller if stepper is not None else ctrl
    hold = robot_hold(desc, m, np.array(d.qpos), pose, holder, floor)
    hold["upright_com"], hold["upright_quat"] = upright
    if stepper is not None:  # no step while the tether holds: armed at the release
        stepper.reset()
        stepper.arm_time_s = math.inf
    keys = SimpleNamespace(
        control_rate_hz=1.0 / float(m.opt.timestep),
        release_time_s=float(lean.release_s),
        delay_steps=0,
        control_steps=int(steps),
    )
    drv = ReleaseDriver(keys, m, d, ctrl, hold, stepper)
    if stepper is not None and drv.k_release == 0:
        stepper.arm_time_s = 0.0
    return drv


def check_release(desc: RobotDescription, lean: ReleaseLean, ctrl) -> None:
    """Refuse, before any run, a lean the legs cannot reach or the feet cannot hold
    (:func:`lean_robot`, :func:`robot_hold`) on the robot's plant."""
    from biped.sim.robot import FLOOR, robot_plant, standing_qpos

    m = robot_plant(desc)
    q0 = standing_qpos(desc, ctrl)
    pose = lean_robot(desc, m, q0, lean, ctrl.tree)
    robot_hold(desc, m, pose["qpos"], pose, ctrl, m.geom(FLOOR).id)
