"""Another subject's biped: validate its MJCF and move W's experiment onto it.

>>> from biped.models import subject
>>> subject.resolve("wendlandt").name   # a shipped name or an MJCF path, checked up front
'wendlandt.xml'

then ``subject.subject_state(path, ...)`` gives W's initial state and set point on that body.

A model file works with the push, sweep and walk commands when it has W's structure, the one
``biped model`` writes (:data:`EXPECTED`): checked by :func:`check_biped` with MuJoCo before any
simulation, every problem reported in one line that says what is expected.

How W's experiment moves onto a subject (:func:`subject_state`, used by
``biped.sim.scenario.Scenario.for_model``), with W's own numbers as the reference:

- initial state: W's body tilt and joint angles (the same crouch), the central-body COM at
  x = y = 0 and at the height that puts the lowest sole point ``clearance_m`` (5 mm, W's
  "slightly above the ground") above the floor, measured with MuJoCo's forward kinematics;
- set point: W's set-point COM and tilt are first turned into joint angles on W's shipped biped
  (feet flat where they stand initially; a 3-unknown sagittal inverse kinematics, Newton's
  method on MuJoCo's forward kinematics); the subject's set point is where the same tilt and
  the same joint angles put its central-body COM with its feet where they stand initially;
- ``height_ratio``: subject's initial COM height / W's, for quantities such as the block's aim
  height; ``mass_ratio``: subject's total mass / W's, for the block's mass (the same momentum
  per kilogram of body: the same push).

On W's shipped biped this reproduces W's numbers (tests/test_subject.py).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from biped.errors import ModelError

SIDES = ("left", "right")
LEG_JOINTS = ("hip_abduction", "hip_flexion", "hip_rotation", "knee", "ankle_inversion", "ankle_dorsiflexion")
HINGES = tuple(f"{side}_{j}" for side in SIDES for j in LEG_JOINTS)
SOLES = ("heel", "toe")
DEFAULT = "wendlandt"

EXPECTED = (
    "W's biped structure as `biped model` writes it: body 'central_body' on a free joint "
    "'root'; per leg (left_, right_) one hinge per body in the chain hip_abduction -> "
    "hip_flexion -> hip_rotation -> knee -> ankle_inversion -> ankle_dorsiflexion ending at "
    "body '<side>_foot' with box geoms '<side>_heel' and '<side>_toe'; a box geom 'trunk' on "
    "'central_body'; a motor per hinge; finite positions, sizes and masses (sizes and positions "
    "within 100 m, each body's mass within 1000 kg)"
)

#: The largest geom size or body / geom position [m] and the largest body mass [kg] a model may
#: have: a human-sized biped is ~1 m and ~100 kg; 1e30 m is a typo, not a biped.
MAX_LENGTH_M = 100.0
MAX_BODY_MASS_KG = 1000.0


def _shipped() -> list[str]:
    from biped import models

    return models.names()


def resolve(model: str | Path) -> Path:
    """Path of ``model``: a shipped model's name (``"wendlandt"``) or an MJCF file that passes
    :func:`check_biped` (shipped models are not re-checked)."""
    from biped import models

    if isinstance(model, str) and model in _shipped():
        return models.path(model)
    return check_biped(model)


def _xml_problem(path: Path) -> str | None:
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        return f"is not XML ({exc})"
    if root.tag != "mujoco":
        return f"is XML but not MJCF (root element <{root.tag}>, expected <mujoco>)"
    return None


def check_biped(model: str | Path):
    """``Path`` of the MJCF file ``model`` after checking it is W's biped structure (see
    :data:`EXPECTED`); raises :class:`~biped.errors.ModelError` naming the first problem."""
    import mujoco

    HINGE, FREE = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_FREE)
    from biped import files

    shipped = ", ".join(map(repr, _shipped()))
    if str(model) == "":
        raise ModelError(f"model '' is an empty path; give a shipped model ({shipped}) or an MJCF file")
    path = Path(model)
    if not path.exists():
        raise ModelError(
            f"model file {str(path)!r} not found; give a shipped model ({shipped}) or "
            f"the path of an MJCF file (e.g. written by `biped model`)"
        )
    files.check_input_file(path, "model", files.MAX_MODEL_BYTES, ModelError)
    problem = _xml_problem(path)
    if problem:
        raise ModelError(f"model file {str(path)!r} {problem}; expected an MJCF file with {EXPECTED}")
    try:
        m = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ModelError(f"MuJoCo cannot load model file {str(path)!r}: {first}") from None

    def fail(what: str):
        raise ModelError(f"model file {str(path)!r}: {what}; expected {EXPECTED}")

    def body_of(joint: str) -> int:
        j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, joint)
        if j < 0:
            fail(f"no joint {joint!r}")
        return int(m.jnt_bodyid[j])

    root_body = body_of("root")
    j_root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "root")
    if int(m.jnt_type[j_root]) != FREE:
        fail("joint 'root' is not a free joint")
    if m.body(root_body).name != "central_body" or m.body_parentid[root_body] != 0:
        fail("joint 'root' must move body 'central_body', a child of the world")
    if np.any(np.abs(m.body_ipos[root_body]) > 1e-9):
        fail("the frame of 'central_body' must sit at its centre of mass (W's body frame)")
    hinges = [m.joint(j).name for j in range(m.njnt) if int(m.jnt_type[j]) == HINGE]
    extra = sorted(set(hinges) - set(HINGES))
    others = [m.joint(j).name for j in range(m.njnt) if int(m.jnt_type[j]) not in (HINGE, FREE)]
    if extra or others or m.njnt != 13:
        fail(
            f"joints {extra + others or [m.joint(j).name for j in range(m.njnt)]} are not W's "
            f"13 (root + 12 hinges)"
        )
    for side in SIDES:
        parent = root_body
        for j in LEG_JOINTS:
            name = f"{side}_{j}"
            b = body_of(name)
            jt = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
            if int(m.jnt_type[jt]) != HINGE:
                fail(f"joint {name!r} is not a hinge")
            if m.body_parentid[b] != parent or m.body_jntnum[b] != 1:
                fail(
                    f"hinge {name!r} is not the only joint of a child of the body of the previous "
                    f"joint in the chain"
                )
            parent = b
        if m.body(parent).name != f"{side}_foot":
            fail(f"the {side} chain ends at body {m.body(parent).name!r}, not '{side}_foot'")
        for part in SOLES:
            g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, f"{side}_{part}")
            if g < 0 or m.geom_bodyid[g] != parent or int(m.geom_type[g]) != int(mujoco.mjtGeom.mjGEOM_BOX):
                fail(f"no box geom '{side}_{part}' on body '{side}_foot'")
    driven = {
        m.joint(int(m.actuator_trnid[a, 0])).name
        for a in range(m.nu)
        if int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT)
    }
    missing = [h for h in HINGES if h not in driven]
    if missing:
        fail(f"hinges without a motor: {missing}")
    g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "trunk")
    if g < 0 or m.geom_bodyid[g] != root_body or int(m.geom_type[g]) != int(mujoco.mjtGeom.mjGEOM_BOX):
        fail("no box geom 'trunk' on body 'central_body' (the replay's camera follows it)")
    problem = _physical_problem(m)
    if problem:
        fail(problem)
    return path


def _physical_problem(m) -> str | None:
    """The first body with a non-finite or absurd position, size or mass, in words (else None)."""
    for b in range(1, m.nbody):
        name = m.body(b).name or f"#{b}"
        values = {
            "pos": m.body_pos[b],
            "quat": m.body_quat[b],
            "mass": m.body_mass[b : b + 1],
            "inertia": m.body_inertia[b],
            "centre of mass": m.body_ipos[b],
        }
        for what, v in values.items():
            if not np.all(np.isfinite(v)):
                return f"body {name!r} has a non-finite {what} ({v.tolist()})"
        if np.max(np.abs(m.body_pos[b])) > MAX_LENGTH_M:
            return (
                f"body {name!r} sits {np.max(np.abs(m.body_pos[b])):.3g} m away (at most {MAX_LENGTH_M:g} m)"
            )
        if m.body_mass[b] > MAX_BODY_MASS_KG:
            return f"body {name!r} has a mass of {m.body_mass[b]:.3g} kg (at most {MAX_BODY_MASS_KG:g} kg)"
    for gi in range(m.ngeom):
        b = int(m.geom_bodyid[gi])
        if b == 0:
            continue
        where = f"geom {m.geom(gi).name or '#' + str(gi)!r} of body {m.body(b).name!r}"
        for what, v in (("size", m.geom_size[gi]), ("pos", m.geom_pos[gi])):
            if not np.all(np.isfinite(v)):
                return f"{where} has a non-finite {what} ({v.tolist()})"
            if np.max(np.abs(v)) > MAX_LENGTH_M:
                return f"{where} has a {what} of {np.max(np.abs(v)):.3g} m (at most {MAX_LENGTH_M:g} m)"
    return None


# ---------------------------------------------------------------------------------------------
# W's experiment on another body


class _Poser:
    """Forward kinematics of a biped model in a posture given by body tilt and W's joint angles."""

    def __init__(self, path: Path):
        import mujoco

        self.mj = mujoco
        self.m = mujoco.MjModel.from_xml_path(str(path))
        self.d = mujoco.MjData(self.m)
        self.qadr = {h: int(self.m.jnt_qposadr[self.m.joint(h).id]) for h in HINGES}
        self.root = int(self.m.jnt_qposadr[self.m.joint("root").id])
        self.cb = self.m.body("central_body").id
        self.foot = self.m.body("left_foot").id
        self.soles = [self.m.geom(f"{s}_{p}").id for s in SIDES for p in SOLES]

    def pose(self, com, tilt_deg: float, angles_deg) -> None:
        q = self.m.qpos0.copy()
        q[self.root : self.root + 3] = com
        h = math.radians(tilt_deg) / 2  # rotation of tilt_deg about -y
        q[self.root + 3 : self.root + 7] = (math.cos(h), 0.0, -math.sin(h), 0.0)
        for name, a in zip(HINGES, angles_deg, strict=True):
            q[self.qadr[name]] = math.radians(a)
        self.d.qpos[:] = q
        self.mj.mj_kinematics(self.m, self.d)

    def lowest_sole(self) -> float:
        z = math.inf
        for g in self.soles:
            R = self.d.geom_xmat[g].reshape(3, 3)
            half = self.m.geom_size[g]
            for sx in (-1, 1):
                for sy in (-1, 1):
                    for sz in (-1, 1):
                        z = min(z, float((self.d.geom_xpos[g] + R @ (half * [sx, sy, sz]))[2]))
        return z

    def foot_xz_pitch(self) -> np.ndarray:
        R = self.d.xmat[self.foot].reshape(3, 3)
        p = self.d.xpos[self.foot]
        return np.array([p[0], p[2], math.atan2(R[0, 2], R[2, 2])])

    def com(self) -> np.ndarray:
        return self.d.xipos[self.cb].copy()


def _sagittal(angles_deg, hip, knee, ankle) -> list[float]:
    """W's 12 angles with the sagittal hinges (hip flexion, knee, ankle dorsiflexion) replaced."""
    out = list(angles_deg)
    for k in (0, 6):
        out[k + 1], out[k + 3], out[k + 5] = hip, knee, ankle
    return out


@dataclass(frozen=True)
class SubjectState:
    """W's experiment moved onto a subject (see the module docstring); world frame, [m], [deg]."""

    initial_com_m: tuple
    target_com_m: tuple
    target_joint_angles_deg: tuple  # W's set point as joint angles (hip, knee, ankle; sagittal)
    height_ratio: float  # subject's initial central-body COM height / W's
    mass_ratio: float  # subject's total mass / W's (MuJoCo's body masses)


def _initial(poser: _Poser, tilt_deg: float, angles_deg, clearance_m: float) -> np.ndarray:
    poser.pose((0.0, 0.0, 0.0), tilt_deg, angles_deg)
    return np.array([0.0, 0.0, clearance_m - poser.lowest_sole()])


def subject_state(
    path: str | Path,
    *,
    initial_tilt_deg: float,
    joint_angles_deg,
    target_com_m,
    target_tilt_deg: float,
    reference_com_m,
    clearance_m: float = 0.005,
    reference: str | Path | None = None,
) -> SubjectState:
    """W's initial state and set point on the biped ``path`` (see the module docstring).

    ``reference_com_m`` and ``target_com_m`` are W's initial and set-point central-body COM on the
    ``reference`` biped (default: the shipped one), ``initial_tilt_deg`` / ``target_tilt_deg``
    its tilts about -y, ``joint_angles_deg`` W's theta_2..theta_13.
    Raises ModelError when the set point is out of the subject's reach.
    """
    from biped import models

    ref = _Poser(Path(reference) if reference else models.path(DEFAULT))
    # W's set point as joint angles: the feet stay flat where they stand in W's initial state
    ref.pose(reference_com_m, initial_tilt_deg, joint_angles_deg)
    foot0 = ref.foot_xz_pitch()
    x = np.array([joint_angles_deg[1], joint_angles_deg[3], joint_angles_deg[5]], dtype=float)

    def residual(v):
        ref.pose(target_com_m, target_tilt_deg, _sagittal(joint_angles_deg, *v))
        r = ref.foot_xz_pitch() - foot0
        return r * np.array([1.0, 1.0, 0.5])  # radians weighted like half a metre

    for _ in range(50):
        r = residual(x)
        if np.max(np.abs(r)) < 1e-12:
            break
        J = np.empty((3, 3))
        for i in range(3):
            e = np.zeros(3)
            e[i] = 1e-6
            J[:, i] = (residual(x + e) - residual(x - e)) / 2e-6
        x = x - np.linalg.lstsq(J, r, rcond=None)[0]
    if np.max(np.abs(residual(x))) > 1e-9:
        raise ModelError(
            f"W's set point (COM {tuple(target_com_m)} m, tilt {target_tilt_deg} deg) "
            f"is out of reach of the reference biped's legs"
        )
    angles_set = _sagittal(joint_angles_deg, *x)

    sub = _Poser(Path(path))
    com0 = _initial(sub, initial_tilt_deg, joint_angles_deg, clearance_m)
    sub.pose(com0, initial_tilt_deg, joint_angles_deg)
    foot_s = sub.foot_xz_pitch()
    sub.pose((0.0, 0.0, 0.0), target_tilt_deg, angles_set)
    at_zero = sub.foot_xz_pitch()
    if abs(at_zero[2] - foot_s[2]) > 1e-6:
        raise ModelError(
            "the subject's feet are not flat at W's set-point joint angles; its legs "
            "do not have W's sagittal joint axes"
        )
    target = (float(foot_s[0] - at_zero[0]), float(target_com_m[1]), float(foot_s[1] - at_zero[1]))
    ref_com0 = _initial(ref, initial_tilt_deg, joint_angles_deg, clearance_m)
    return SubjectState(
        initial_com_m=tuple(float(v) for v in com0),
        target_com_m=target,
        target_joint_angles_deg=tuple(float(v) for v in x),
        height_ratio=float(com0[2] / ref_com0[2]),
        mass_ratio=float(sub.m.body_mass.sum() / ref.m.body_mass.sum()),
    )


__all__ = ["EXPECTED", "HINGES", "SubjectState", "check_biped", "resolve", "subject_state"]
