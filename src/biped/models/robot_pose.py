"""A robot's standing pose away from the stretched-knee singularity (:func:`bend_legs`).

W's controller moves the central body through the legs, each foot a big base (W Alg. 3): at a
straight knee the leg's 6 x 6 Jacobian (foot twist per joint rate) is singular, the central
body's articulated inertia ``P_1`` takes in the feet's big-base inertia along the locked
direction, and the desired wrench ``F_1^bd = P_1 X + z_1`` follows whatever error there is times
that factor. A keyframe with every leg joint at 0 (straight knees, the Jacobian's smallest
singular value 0) fell at once with W's factor 1e6, and with 1e2 a block of 0.07 m/s of COM
velocity change threw it (docs/robots.md).

The rule: when a leg's Jacobian (rows: the foot's linear [m] and angular velocity per joint rate,
MuJoCo's ``mj_jacBody``) has its smallest singular value below :data:`LEG_SV_MIN_M` at the
keyframe, both legs are crouched symmetrically until it reaches it: the knee (the chain's 4th
hinge) by ``2a``, the hip and ankle hinges whose axes are most nearly parallel to the knee's by
``-a`` each (signs along the knee's axis: the foot keeps its orientation), the knee bent toward
the wider side of its joint range. A keyframe already bent enough is kept as it is.
"""

from __future__ import annotations

import mujoco
import numpy as np

from biped.errors import ModelError

#: The smallest singular value of each leg's Jacobian at the standing pose [m] (see the module).
LEG_SV_MIN_M = 0.07
#: The largest crouch tried [rad] (the knee bends by twice this).
MAX_CROUCH_RAD = 0.6


def leg_sv(m: mujoco.MjModel, qpos: np.ndarray, foot: int, dofs: list[int]) -> float:
    """Smallest singular value of the foot's 6 x 6 Jacobian over the leg's joint rates at ``qpos``."""
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    mujoco.mj_jacBody(m, d, jp, jr, foot)
    return float(np.linalg.svd(np.vstack([jp, jr])[:, dofs], compute_uv=False)[-1])


def _crouch(m, qpos, legs, a) -> np.ndarray:
    q = qpos.copy()
    for joints, signs in legs:
        for j, s in zip(joints, signs, strict=True):
            q[m.jnt_qposadr[j]] += s * a
    return q


def _crouch_legs(m: mujoco.MjModel, qpos: np.ndarray, leg_joints: list[int]):
    """(legs, chains): per leg the crouch's (hip, knee, ankle) hinges and their signs (the
    module's rule), and the leg's dof addresses."""
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    legs, chains = [], []
    for side in range(2):
        js = leg_joints[6 * side : 6 * side + 6]
        chains.append([int(m.jnt_dofadr[j]) for j in js])
        axis = {j: d.xaxis[j] for j in js}
        knee = js[3]
        hip = max(js[:3], key=lambda j: abs(axis[j] @ axis[knee]))
        ankle = max(js[4:], key=lambda j: abs(axis[j] @ axis[knee]))
        lo, hi = m.jnt_range[knee] if m.jnt_limited[knee] else (-np.pi, np.pi)
        q = qpos[m.jnt_qposadr[knee]]
        bend = 1.0 if hi - q >= q - lo else -1.0
        legs.append(
            (
                (hip, knee, ankle),
                tuple(
                    bend * c * np.sign(axis[j] @ axis[knee])
                    for j, c in ((hip, -1.0), (knee, 2.0), (ankle, -1.0))
                ),
            )
        )
    return legs, chains


def bend_legs(m: mujoco.MjModel, qpos: np.ndarray, feet: tuple[int, int], leg_joints: list[int]):
    """(qpos, a): the keyframe ``qpos`` crouched by ``a`` [rad] per the module's rule (a = 0: kept).
    ``leg_joints``: the 12 hinges, left leg then right, hip to ankle (the 4th of each the knee)."""
    legs, chains = _crouch_legs(m, qpos, leg_joints)

    def worst(a):
        qa = _crouch(m, qpos, legs, a)
        return min(leg_sv(m, qa, f, c) for f, c in zip(feet, chains, strict=True))

    if worst(0.0) >= LEG_SV_MIN_M:
        return qpos.copy(), 0.0
    if worst(MAX_CROUCH_RAD) < LEG_SV_MIN_M:
        raise ModelError(
            f"the legs stay near a singular pose (leg Jacobian's smallest singular value < {LEG_SV_MIN_M} m) "
            f"even crouched by {MAX_CROUCH_RAD} rad: name a bent standing keyframe"
        )
    lo_a, hi_a = 0.0, MAX_CROUCH_RAD
    for _ in range(30):
        mid = (lo_a + hi_a) / 2
        lo_a, hi_a = (lo_a, mid) if worst(mid) >= LEG_SV_MIN_M else (mid, hi_a)
    return _crouch(m, qpos, legs, hi_a), hi_a


def ankle_crouch_m(
    m: mujoco.MjModel, qpos: np.ndarray, feet: tuple[int, int], leg_joints: list[int]
) -> float:
    """How far [m] the hips can be lowered from ``qpos`` over the flat feet by the module's crouch
    (knee ``2a``, hip and ankle ``-a``) before an ankle hinge reaches the end of its joint range:
    the smaller leg's drop of the first hinge's body over the foot body."""
    legs, _ = _crouch_legs(m, qpos, leg_joints)
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    out = []
    for side, ((_hip, _knee, ankle), signs) in enumerate(legs):
        q = qpos[m.jnt_qposadr[ankle]]
        lo, hi = m.jnt_range[ankle] if m.jnt_limited[ankle] else (-np.inf, np.inf)
        a = (hi - q) / signs[2] if signs[2] > 0 else (q - lo) / -signs[2]
        if not np.isfinite(a):
            out.append(np.inf)
            continue
        qa = _crouch(m, qpos, [legs[side]], a)
        da = mujoco.MjData(m)
        da.qpos[:] = qa
        mujoco.mj_kinematics(m, da)
        first, foot = int(m.jnt_bodyid[leg_joints[6 * side]]), feet[side]
        out.append(float((d.xpos[first][2] - d.xpos[foot][2]) - (da.xpos[first][2] - da.xpos[foot][2])))
    return min(out)
