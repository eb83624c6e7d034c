"""From kinematics to dynamics: what Bediz's kinematic gait would ask of a body with mass.

B's conclusion (VI-B) asks to integrate the kinematic figure with a dynamic model. Here the
figure's motion drives the project's 3D biped (Wendlandt's 13 bodies, de Leva masses,
``biped.models.path("wendlandt")``) and MuJoCo's inverse dynamics (``mj_inverse``, contacts
disabled) gives the generalized forces that motion needs. The feet that bear weight supply the
6 forces of the free root; what is left are the joint torques:

    qfrc_inverse = sum_stance J_f^T w_f + [0_6; tau]       (J_f: 6 x nv Jacobian at the sole centre)

With one foot down ``w_f`` is unique; with two it is the minimum-norm split (as W's Alg. 5); with
none (the jump's flight) nothing can supply the root's 6 forces and they are reported as a
*residual*: the non-physical external wrench the kinematic motion would need.

Mapping figure -> biped (names, never indices): the biped's central body (head, arms, trunk: one
rigid body in W's model) follows the figure's pelvis; the figure's torso roll and arm swing have
no counterpart and are left out. The biped faces -x with its left leg on -y, the figure faces +x
with its left leg on +y: the biped's root is the figure's pelvis turned by pi about z. The sagittal
joints map one to one (same sign conventions, see :mod:`biped.kinematic.ik`): ``*_hip_flexion``,
``*_knee``, ``*_ankle_dorsiflexion``; abduction, rotation and inversion stay 0. Velocities and
accelerations are central differences of the plan (``h`` = 1 ms) through ``mj_differentiatePos``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from biped.errors import ModelError, unknown_name
from biped.kinematic.gaits import SIDES, Motion, Plan
from biped.spatial import rot_to_quat

__all__ = ["BIPED_JOINTS", "FRICTION", "InverseDynamics", "biped_qpos", "inverse_dynamics", "load_biped"]

#: The biped's hinge joints, per side, in W's order.
BIPED_JOINTS = (
    "hip_abduction",
    "hip_flexion",
    "hip_rotation",
    "knee",
    "ankle_inversion",
    "ankle_dorsiflexion",
)
_FROM_FIGURE = {"hip_flexion": "hip_flexion", "knee": "knee", "ankle_dorsiflexion": "ankle_dorsiflexion"}
#: W's friction coefficient (W section 4), to judge the friction the gait needs.
FRICTION = 0.3
_RZ_PI = np.diag([-1.0, -1.0, 1.0])


def load_biped(name: str | Path = "wendlandt"):
    """The biped MJCF (a shipped model's name or a checked MJCF path, see
    :func:`biped.models.subject.resolve`) as a ``mujoco.MjModel`` with contacts disabled (the
    feet's wrenches are solved for, not simulated)."""
    import mujoco

    from biped.models.subject import resolve

    m = mujoco.MjModel.from_xml_path(str(resolve(name)))
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    return m


class _Names:
    """Addresses of the biped's joints and bodies, resolved once by name."""

    def __init__(self, model):
        import mujoco

        def jid(name):
            i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
            if i < 0:
                names = [model.joint(k).name for k in range(model.njnt)]
                raise ModelError(unknown_name("joint", name, names))
            return i

        def bid(name):
            i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
            if i < 0:
                names = [model.body(k).name for k in range(model.nbody)]
                raise ModelError(unknown_name("body", name, names))
            return i

        root = jid("root")
        if model.jnt_type[root] != mujoco.mjtJoint.mjJNT_FREE:
            raise ModelError("the biped's joint 'root' must be a free joint")
        self.root_q = int(model.jnt_qposadr[root])
        self.root_v = int(model.jnt_dofadr[root])
        self.hinges = [f"{sd}_{j}" for sd in SIDES for j in BIPED_JOINTS]
        self.qadr = {n: int(model.jnt_qposadr[jid(n)]) for n in self.hinges}
        self.vadr = {n: int(model.jnt_dofadr[jid(n)]) for n in self.hinges}
        self.root_body = int(model.jnt_bodyid[root])
        self.foot = {sd: bid(f"{sd}_foot") for sd in SIDES}
        # central body COM above the mid-hip point, along the body z axis
        self.com_above_hips = -float(body_of_joint(model, "left_hip_abduction").pos[2])
        # sole centre in the foot frame, from the heel and toe sole boxes
        self.sole = {}
        for sd in SIDES:
            heel, toe = model.geom(f"{sd}_heel"), model.geom(f"{sd}_toe")
            xb = heel.pos[0] + heel.size[0]
            xf = toe.pos[0] - toe.size[0]
            self.sole[sd] = np.array([0.5 * (xb + xf), 0.0, heel.pos[2] - heel.size[2]])
            self.sole_half = (0.5 * abs(xb - xf), float(heel.size[1]))


def body_of_joint(model, joint: str):
    """The body the hinge ``joint`` moves: the model check names joints, not bodies, so a model
    whose bodies are named otherwise is found by its joints."""
    return model.body(int(model.jnt_bodyid[model.joint(joint).id]))


def _check_dims(model, names: _Names, dims) -> None:
    """The figure must have the biped's leg geometry, or its feet would not land on the floor."""
    pairs = {
        "hip_half_width": (-float(body_of_joint(model, "left_hip_abduction").pos[1]), dims.hip_half_width),
        "thigh": (-float(body_of_joint(model, "left_knee").pos[2]), dims.thigh),
        "shank": (-float(body_of_joint(model, "left_ankle_inversion").pos[2]), dims.shank),
        "ankle_height": (-float(names.sole["left"][2]), dims.ankle_height),
    }
    for k, (b, f) in pairs.items():
        if abs(b - f) > 1e-4:
            raise ModelError(
                f"figure {k} = {f:.6g} m differs from the biped's {b:.6g} m; build the figure "
                f"with FigureDims.from_anthropometry() (FigureDims.from_mjcf(path) for another "
                f"model) to run it on the biped"
            )


def biped_qpos(model, motion_or_arrays, names: _Names | None = None) -> np.ndarray:
    """The biped's ``qpos`` (T, nq) for the figure's pose: root = pelvis turned by pi about z and
    raised to the central body's COM; sagittal hinges = the figure's leg angles (by name)."""
    names = names or _Names(model)
    pelvis_pos, pelvis_rot, angles = motion_or_arrays
    from biped.kinematic.figure import JOINT_NAMES

    J = {n: i for i, n in enumerate(JOINT_NAMES)}
    T = pelvis_pos.shape[0]
    q = np.zeros((T, model.nq))
    Rb = pelvis_rot @ _RZ_PI
    q[:, names.root_q : names.root_q + 3] = pelvis_pos + Rb[:, :, 2] * names.com_above_hips
    prev = None
    for t in range(T):
        qt = rot_to_quat(np.ascontiguousarray(Rb[t]))
        if prev is not None and float(qt @ prev) < 0:
            qt = -qt  # keep the quaternion on one hemisphere along the motion
        q[t, names.root_q + 3 : names.root_q + 7] = qt
        prev = qt
    for sd in SIDES:
        for bj, fj in _FROM_FIGURE.items():
            q[:, names.qadr[f"{sd}_{bj}"]] = angles[:, J[f"{sd}_{fj}"]]
    return q


@dataclass(frozen=True)
class InverseDynamics:
    """Inverse dynamics of a kinematic motion on the biped.

    Attributes:
        times: (T,) s.
        joint_names: the 12 biped hinges (``left_hip_abduction`` ...).
        torques: (T, 12) joint torques [N m].
        grf: (T, 2, 3) force of the ground on the [left, right] foot at its sole centre, world [N].
        grf_moment: (T, 2, 3) moment of that wrench about the sole centre, world [N m].
        cop: (T, 2, 3) centre of pressure on the sole plane, world [m] (nan without load).
        sole_centre: (T, 2, 3) the sole centres where the wrenches act, world [m].
        stance: (T, 2) bool, the foot bears weight.
        residual: (T, 6) root force [N] (world) and torque [N m] (central-body frame) that no foot
            supplies (nonzero only in flight).
        mass: total mass of the biped [kg].
        gravity: the biped model's gravitational acceleration (along -z) [m/s^2].
        qpos, qvel, qacc: the biped trajectory used, (T, nq), (T, nv), (T, nv).
        sole_half: half length and half width of a sole [m].
    """

    times: np.ndarray
    joint_names: tuple
    torques: np.ndarray
    grf: np.ndarray
    grf_moment: np.ndarray
    cop: np.ndarray
    sole_centre: np.ndarray
    stance: np.ndarray
    residual: np.ndarray
    mass: float
    gravity: float
    qpos: np.ndarray
    qvel: np.ndarray
    qacc: np.ndarray
    sole_half: tuple = (0.0, 0.0)

    def friction_ratio(self) -> np.ndarray:
        """(T, 2) |tangential| / normal force the ground must supply (nan without load)."""
        fz = self.grf[..., 2]
        ft = np.linalg.norm(self.grf[..., :2], axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.stance & (fz > 0), ft / fz, np.nan)

    def summary(self) -> dict:
        """Peaks and physical-plausibility counts (SI units)."""
        st = self.stance
        fz = self.grf[..., 2]
        mg = self.mass * self.gravity
        half_x, half_y = self.sole_half
        with np.errstate(invalid="ignore"):
            fr = self.friction_ratio()
        loaded = st & (fz > 1e-6 * mg)
        outside = np.zeros_like(st)
        for j in range(2):
            # a foot bearing weight is flat and faces +x: the CoP offset from the sole centre in
            # world x / y is its offset along / across the sole
            d = self.cop[:, j, :2] - self.sole_centre[:, j, :2]
            outside[:, j] = loaded[:, j] & ((np.abs(d[:, 0]) > half_x) | (np.abs(d[:, 1]) > half_y))
        n_st = max(int(np.sum(st)), 1)
        flight = ~np.any(st, axis=1)
        out = {
            "mass_kg": self.mass,
            "peak_torque_Nm": {
                n: float(np.max(np.abs(self.torques[:, i])))
                for i, n in enumerate(self.joint_names)
                if np.any(self.torques[:, i] != 0)
            },
            "peak_grf_z_N": float(np.nanmax(fz)) if np.any(st) else 0.0,
            "peak_grf_z_body_weights": float(np.nanmax(fz) / mg) if np.any(st) else 0.0,
            "min_grf_z_N": float(np.min(fz[st])) if np.any(st) else 0.0,
            "stance_frames_pulling": int(np.sum(st & (fz < 0))),
            "peak_friction_ratio": float(np.nanmax(fr)) if np.any(np.isfinite(fr)) else 0.0,
            "stance_frames_over_friction_0.3": int(np.sum(fr > FRICTION)),
            "stance_frames_cop_outside_sole": int(np.sum(outside)),
            "stance_foot_frames": int(np.sum(st)),
            "fraction_cop_outside_sole": float(np.sum(outside) / n_st),
            "flight_frames": int(np.sum(flight)),
            "peak_flight_residual_force_N": float(np.max(np.linalg.norm(self.residual[flight, :3], axis=1)))
            if np.any(flight)
            else 0.0,
            "peak_flight_residual_torque_Nm": float(np.max(np.linalg.norm(self.residual[flight, 3:], axis=1)))
            if np.any(flight)
            else 0.0,
        }
        return out


def _plan_derivatives(model, plan: Plan, times: np.ndarray, names, h: float):
    """qpos, qvel, qacc of the biped at ``times`` by central differences of the plan."""
    import mujoco

    T0, T1 = 0.0, plan.duration
    tm = np.clip(times - h, T0, T1)
    tp = np.clip(times + h, T0, T1)
    qs = []
    for t in (tm, times, tp):
        m = plan.evaluate(t)
        qs.append(biped_qpos(model, (m.pelvis_pos, m.pelvis_rot, m.angles), names))
    # keep the three quaternions of each time on one hemisphere
    for k in (0, 2):
        sl = slice(names.root_q + 3, names.root_q + 7)
        flip = np.sum(qs[k][:, sl] * qs[1][:, sl], axis=1) < 0
        qs[k][flip, sl] *= -1.0
    T = times.size
    vm, vp = np.zeros((T, model.nv)), np.zeros((T, model.nv))
    hm, hp = times - tm, tp - times
    for i in range(T):
        if hp[i] > 0:
            mujoco.mj_differentiatePos(model, vp[i], hp[i], qs[1][i], qs[2][i])
        if hm[i] > 0:
            mujoco.mj_differentiatePos(model, vm[i], hm[i], qs[0][i], qs[1][i])
        if hp[i] == 0:
            vp[i] = vm[i]
        if hm[i] == 0:
            vm[i] = vp[i]
    qvel = 0.5 * (vp + vm)
    qacc = 2.0 * (vp - vm) / np.maximum(hm + hp, 1e-12)[:, None]
    return qs[1], qvel, qacc, plan.evaluate(times)


def inverse_dynamics(motion: Motion, model=None, h: float = 1e-3) -> InverseDynamics:
    """Joint torques and ground reaction forces the kinematic ``motion`` needs on the biped.

    Args:
        motion: a sampled :class:`~biped.kinematic.gaits.Motion` (its plan is re-evaluated at
            ``t +- h`` for the derivatives).
        model: the biped ``mujoco.MjModel`` (default :func:`load_biped`); contacts must be off.
        h: time step of the central differences [s].

    Returns:
        :class:`InverseDynamics`.

    Raises:
        ModelError: the biped lacks a joint or body by name, or the figure's legs differ from it.
    """
    import mujoco

    model = model if model is not None else load_biped()
    names = _Names(model)
    _check_dims(model, names, motion.dims)
    times = motion.times
    qpos, qvel, qacc, mo = _plan_derivatives(model, motion.plan, times, names, h)
    stance = mo.stance
    data = mujoco.MjData(model)
    T, nv = times.size, model.nv
    torques = np.zeros((T, len(names.hinges)))
    grf = np.zeros((T, 2, 3))
    grm = np.zeros((T, 2, 3))
    cop = np.full((T, 2, 3), np.nan)
    centres = np.full((T, 2, 3), np.nan)
    residual = np.zeros((T, 6))
    jacp, jacr = np.zeros((3, nv)), np.zeros((3, nv))
    r0 = names.root_v
    vidx = np.array([names.vadr[n] for n in names.hinges])
    for t in range(T):
        data.qpos[:], data.qvel[:], data.qacc[:] = qpos[t], qvel[t], qacc[t]
        mujoco.mj_inverse(model, data)
        qf = data.qfrc_inverse.copy()
        cols, pts = [], {}
        for j, sd in enumerate(SIDES):
            b = names.foot[sd]
            p = data.xpos[b] + data.xmat[b].reshape(3, 3) @ names.sole[sd]
            centres[t, j] = p
            if stance[t, j]:
                mujoco.mj_jac(model, data, jacp, jacr, p, b)
                cols.append((j, jacp.copy(), jacr.copy()))
                pts[j] = p
        if cols:
            A = np.hstack([np.vstack([jp, jr]).T[r0 : r0 + 6] for _, jp, jr in cols])  # 6 x 6k
            w = np.linalg.lstsq(A, qf[r0 : r0 + 6], rcond=None)[0]
            for k, (j, jp, jr) in enumerate(cols):
                f, m = w[6 * k : 6 * k + 3], w[6 * k + 3 : 6 * k + 6]
                grf[t, j], grm[t, j] = f, m
                qf -= jp.T @ f + jr.T @ m
                if f[2] > 0:
                    # centre of pressure on the horizontal sole plane through p
                    cop[t, j] = pts[j] + np.array([-m[1] / f[2], m[0] / f[2], 0.0])
        residual[t] = qf[r0 : r0 + 6]
        torques[t] = qf[vidx]
    return InverseDynamics(
        times,
        tuple(names.hinges),
        torques,
        grf,
        grm,
        cop,
        centres,
        stance,
        residual,
        float(np.sum(model.body_mass)),
        -float(model.opt.gravity[2]),
        qpos,
        qvel,
        qacc,
        names.sole_half,
    )
