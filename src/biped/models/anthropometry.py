"""Generates ``wendlandt.xml``: W's 13-body, 18-DOF biped with de Leva (1996) segment parameters.

The shipped MJCF is the single source of truth for the simulator and the controller; this module
documents how its numbers were made and regenerates it (``python -m biped.models.anthropometry``).
A test checks that the shipped file equals what this module writes.

Source of the segment parameters: P. de Leva, "Adjustments to Zatsiorsky-Seluyanov's segment
inertia parameters", J. Biomechanics 29(9):1223-1230, 1996, Table 4 (males: sample stature
1.741 m, mass 73.0 kg; females: 1.735 m, 61.9 kg). Lengths, centre-of-mass positions (fraction of
segment length from the proximal end) and radii of gyration (fraction of segment length) are de
Leva's. Assumptions that de Leva's table does not cover are stated below (ASSUMPTIONS) and in
docs/model.md.

The same code path writes W's shipped biped (:data:`W_SUBJECT`) and any subject's
(:class:`Subject`, ``biped model --stature M --mass KG --sex male|female``): lengths scale with
stature / de Leva's sample stature of that sex, masses with the body mass, and the central-body
COM height of W's initial posture is the one that puts the soles 5 mm above the floor.

The biped faces -x: W's initial body tilt is "5 deg about -y" and the joint angles
40 - 77.4595 + 42.4595 = 5 deg cancel it, so the sagittal joints turn about +y; with human
knees that bend backward, forward is -x and the left leg is on -y.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from biped import files
from biped.models import LEG_JOINTS, W_INITIAL_ANGLES_DEG, W_INITIAL_COM_M, W_INITIAL_TILT_DEG

#: de Leva (1996) Table 4, males: (length at 1.741 m [m], mass fraction, CM from proximal end,
#: r_sagittal, r_transverse, r_longitudinal) with r as fractions of the segment length.
DE_LEVA_MALE = {
    "head": (0.2429, 0.0694, 0.5002, 0.303, 0.315, 0.261),  # VERT-CERV
    "trunk": (0.6033, 0.4346, 0.5138, 0.328, 0.306, 0.169),  # CERV-MIDH
    "upper_arm": (0.2817, 0.0271, 0.5772, 0.285, 0.269, 0.158),  # SJC-EJC
    "forearm": (0.2689, 0.0162, 0.4574, 0.276, 0.265, 0.121),  # EJC-WJC
    "hand": (0.0862, 0.0061, 0.7900, 0.628, 0.513, 0.401),  # WJC-MET3
    "thigh": (0.4222, 0.1416, 0.4095, 0.329, 0.329, 0.149),  # HJC-KJC
    "shank": (0.4340, 0.0433, 0.4459, 0.255, 0.249, 0.103),  # KJC-LMAL
    "foot": (0.2581, 0.0137, 0.4415, 0.257, 0.245, 0.124),  # HEEL-TTIP
}
DE_LEVA_STATURE = 1.741

#: de Leva (1996) Table 4, females, same columns and segment definitions as :data:`DE_LEVA_MALE`.
#: The printed mass fractions sum to 0.9999 (rounding); :func:`mass_fractions` rescales them to 1.
#: Cross-checked against two independent transcriptions of Table 4; they differ only in the head's
#: longitudinal radius (26.1 % and 26.3 %), 26.1 % is used (as for males).
DE_LEVA_FEMALE = {
    "head": (0.2437, 0.0668, 0.4841, 0.271, 0.295, 0.261),  # VERT-CERV
    "trunk": (0.6148, 0.4257, 0.4964, 0.307, 0.292, 0.147),  # CERV-MIDH
    "upper_arm": (0.2751, 0.0255, 0.5754, 0.278, 0.260, 0.148),  # SJC-EJC
    "forearm": (0.2643, 0.0138, 0.4559, 0.261, 0.257, 0.094),  # EJC-WJC
    "hand": (0.0780, 0.0056, 0.7474, 0.531, 0.454, 0.335),  # WJC-MET3
    "thigh": (0.3685, 0.1478, 0.3612, 0.369, 0.364, 0.162),  # HJC-KJC
    "shank": (0.4323, 0.0481, 0.4416, 0.271, 0.267, 0.093),  # KJC-LMAL
    "foot": (0.2283, 0.0129, 0.4014, 0.299, 0.279, 0.139),  # HEEL-TTIP
}
DE_LEVA = {"male": DE_LEVA_MALE, "female": DE_LEVA_FEMALE}
#: de Leva's sample means (stature [m], body mass [kg]) per sex.
DE_LEVA_SAMPLE = {"male": (1.741, 73.0), "female": (1.735, 61.9)}
SEXES = ("male", "female")
#: Segments of the whole body: each arm and leg segment counts twice.
_COUNT = {"head": 1, "trunk": 1, "upper_arm": 2, "forearm": 2, "hand": 2, "thigh": 2, "shank": 2, "foot": 2}


def mass_fractions(sex: str = "male") -> dict[str, float]:
    """de Leva's segment mass fractions for ``sex``, rescaled so that the whole body sums to 1
    (males: printed sum 1.0000, unchanged; females: printed sum 0.9999)."""
    table = DE_LEVA[sex]
    total = sum(_COUNT[k] * v[1] for k, v in table.items())
    if sex == "male":
        return {k: v[1] for k, v in table.items()}  # sums to 1.0 exactly in floating point
    return {k: v[1] / total for k, v in table.items()}


ASSUMPTIONS = {
    "body_mass_kg": 73.0,  # de Leva's male sample mean
    "ankle_height_fraction_of_stature": 0.039,  # Winter (2009), Fig. 4.1: LMAL above the sole
    "heel_to_ankle_fraction_of_foot": 0.20,  # the ankle sits 20 % of the foot length from the heel
    "hip_half_width_fraction_of_stature": 0.05,  # hip joint centres 0.10 H apart
    "shoulder_below_cerv_fraction_of_trunk": 0.10,  # shoulder joint centres 10 % of trunk below CERV
    "shoulder_half_width_fraction_of_stature": 0.10,
    "intermediate_body_mass_kg": 0.01,  # W's massless hip and ankle intermediate bodies
    "intermediate_body_inertia_kgm2": 1e-5,
    "sole_clearance_m": 0.005,  # soles above the floor in W's initial state
    # Passive viscous damping of every hinge [N m s/rad]: a property of the simulated plant that
    # W's controller (like W's model) does not know. Without it the closed loop on MuJoCo's
    # compliant contacts is unstable (measured: W's run diverges at 0.62 s with 0.5 ms steps and no
    # damping; 0.3 diverges, 0.5 and above converge to the set point). Order of magnitude of the
    # passive damping measured at human joints (~1 N m s/rad).
    "joint_damping_Nms_per_rad": 1.0,
}

#: W's initial state (section 4), defined in biped.models; the legs start alike.
INITIAL_COM = W_INITIAL_COM_M
INITIAL_TILT_DEG = W_INITIAL_TILT_DEG  # about -y
INITIAL_ANGLES_DEG = W_INITIAL_ANGLES_DEG[:6]
assert W_INITIAL_ANGLES_DEG[6:] == INITIAL_ANGLES_DEG

#: Per leg, in W's joint order (left 2..7, right 8..13): (name, axis for the left leg).
#: The right leg mirrors the frontal-plane axes (abduction, rotation, inversion).
_LEFT_AXES = {
    "hip_abduction": (-1.0, 0.0, 0.0),
    "hip_flexion": (0.0, 1.0, 0.0),
    "hip_rotation": (0.0, 0.0, -1.0),  # internal rotation positive
    "knee": (0.0, 1.0, 0.0),  # positive = extension; W's -77.5 deg is flexion
    "ankle_inversion": (1.0, 0.0, 0.0),
    "ankle_dorsiflexion": (0.0, 1.0, 0.0),
}
JOINTS = tuple((name, _LEFT_AXES[name]) for name in LEG_JOINTS)

MIRRORED = {"hip_abduction", "hip_rotation", "ankle_inversion"}


@dataclass(frozen=True)
class Segment:
    mass: float
    com: np.ndarray  # in the body frame [m]
    inertia: np.ndarray  # principal moments about x, y, z at the COM [kg m^2]


def _seg(name: str, scale: float, mass_total: float, axis: int, sign: float = -1.0, sex: str = "male"):
    """A de Leva segment along body axis ``axis`` (pointing ``sign``) from its proximal end."""
    L0, _, cm, r_sag, r_tr, r_long = DE_LEVA[sex][name]
    L = L0 * scale
    m = mass_fractions(sex)[name] * mass_total
    com = np.zeros(3)
    com[axis] = sign * cm * L
    # axes: x anteroposterior (sagittal axis), y mediolateral (transverse axis), z vertical
    moments = np.array([(r_sag * L) ** 2, (r_tr * L) ** 2, (r_tr * L) ** 2]) * m
    moments[axis] = m * (r_long * L) ** 2
    return L, Segment(m, com, moments)


def _combine(parts):
    """Mass, COM and principal inertia of rigid parts [(Segment, offset)] (parallel axes)."""
    m = sum(s.mass for s, _ in parts)
    c = sum(s.mass * (s.com + off) for s, off in parts) / m
    inertia = np.zeros((3, 3))
    for s, off in parts:
        d = s.com + off - c
        inertia += np.diag(s.inertia) + s.mass * (d @ d * np.eye(3) - np.outer(d, d))
    return m, c, inertia


def central_body(scale: float, mass_total: float, sex: str = "male"):
    """Head, arms and trunk (HAT) as one rigid body; returns (mass, COM above MIDH, inertia, dims)."""
    A = ASSUMPTIONS
    H = DE_LEVA_SAMPLE[sex][0] * scale
    L_tr, trunk = _seg("trunk", scale, mass_total, 2, -1.0, sex)
    L_hd, head = _seg("head", scale, mass_total, 2, -1.0, sex)
    L_ua, uarm = _seg("upper_arm", scale, mass_total, 2, -1.0, sex)
    L_fa, farm = _seg("forearm", scale, mass_total, 2, -1.0, sex)
    L_ha, hand = _seg("hand", scale, mass_total, 2, -1.0, sex)
    cerv = np.array([0.0, 0.0, L_tr])  # MIDH at the origin
    vert = cerv + [0, 0, L_hd]
    parts = [(trunk, cerv), (head, vert)]
    sj_z = L_tr * (1.0 - A["shoulder_below_cerv_fraction_of_trunk"])
    sj_y = A["shoulder_half_width_fraction_of_stature"] * H
    for side in (-1.0, 1.0):
        sjc = np.array([0.0, side * sj_y, sj_z])
        parts += [(uarm, sjc), (farm, sjc - [0, 0, L_ua]), (hand, sjc - [0, 0, L_ua + L_fa])]
    m, c, inertia = _combine(parts)
    dims = {
        "trunk": L_tr,
        "head": L_hd,
        "upper_arm": L_ua,
        "forearm": L_fa,
        "hand": L_ha,
        "shoulder_z": sj_z,
        "shoulder_y": sj_y,
    }
    return m, c, inertia, dims


def _sole_height(scale: float) -> float:
    """Sole height above the floor in W's initial state for a stature scale factor."""
    A = ASSUMPTIONS
    H = DE_LEVA_STATURE * scale
    _, c, _, _ = central_body(scale, A["body_mass_kg"])
    d_hip = c[2]  # COM height above the hip joint centres, along the body axis
    tilt = math.radians(INITIAL_TILT_DEG)
    th = [math.radians(a) for a in INITIAL_ANGLES_DEG]
    L1 = DE_LEVA_MALE["thigh"][0] * scale
    L2 = DE_LEVA_MALE["shank"][0] * scale
    h_a = A["ankle_height_fraction_of_stature"] * H
    # sagittal chain (rotations about +y, body pitched by -tilt about +y)
    z = INITIAL_COM[2] - d_hip * math.cos(tilt)
    z -= L1 * math.cos(-tilt + th[1])
    z -= L2 * math.cos(-tilt + th[1] + th[3])
    return z - h_a


def solve_scale() -> float:
    """Stature scale factor that puts the soles ``sole_clearance_m`` above the floor (bisection)."""
    target = ASSUMPTIONS["sole_clearance_m"]
    lo, hi = 0.5, 1.5
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if _sole_height(mid) > target:  # taller legs push the soles down
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _f(x) -> str:
    return " ".join(f"{v:.6g}" for v in np.atleast_1d(x))


#: Adult ranges accepted for a subject (de Leva's regressions come from young adults; outside
#: these the scaled segment parameters are an extrapolation the project does not offer).
STATURE_RANGE_M = (1.40, 2.10)
MASS_RANGE_KG = (35.0, 150.0)
BMI_RANGE = (15.0, 45.0)
N_INTERMEDIATE = 6  # W's light hip (2 per leg) and ankle (1 per leg) bodies


@dataclass(frozen=True)
class Subject:
    """A subject for :func:`build_xml`: stature [m], total body mass [kg] and sex.

    The model's total mass is ``mass_kg``: de Leva's fractions apply to ``mass_kg`` minus the six
    intermediate hip and ankle bodies (0.01 kg each). Out-of-range values raise ModelError.
    """

    stature_m: float
    mass_kg: float
    sex: str = "male"

    def __post_init__(self):
        from biped.errors import ModelError

        if self.sex not in SEXES:
            raise ModelError(
                f"sex must be one of {', '.join(map(repr, SEXES))} (de Leva 1996 Table 4); got {self.sex!r}"
            )
        for name, v, (lo, hi), unit in (
            ("stature", self.stature_m, STATURE_RANGE_M, "m"),
            ("mass", self.mass_kg, MASS_RANGE_KG, "kg"),
        ):
            if (
                not isinstance(v, (int, float))
                or isinstance(v, bool)
                or not math.isfinite(v)
                or not lo <= v <= hi
            ):
                raise ModelError(
                    f"{name} must be in [{lo:g}, {hi:g}] {unit} (adult humans, the "
                    f"range de Leva's parameters are scaled over); got {v!r}"
                )
        bmi = self.mass_kg / self.stature_m**2
        if not BMI_RANGE[0] <= bmi <= BMI_RANGE[1]:
            raise ModelError(
                f"mass / stature^2 = {bmi:.1f} kg/m^2 is outside [{BMI_RANGE[0]:g}, "
                f"{BMI_RANGE[1]:g}] kg/m^2 (adult body mass index range accepted)"
            )

    @property
    def scale(self) -> float:
        """Stature / de Leva's sample stature of the same sex (all lengths scale with it)."""
        return self.stature_m / DE_LEVA_SAMPLE[self.sex][0]

    @property
    def segment_mass_kg(self) -> float:
        """The mass de Leva's fractions are applied to [kg]."""
        return self.mass_kg - N_INTERMEDIATE * ASSUMPTIONS["intermediate_body_mass_kg"]


def w_subject() -> Subject:
    """The subject of W's shipped biped: male, stature solved so that W's initial posture puts the
    soles 5 mm above the floor with the central-body COM at W's 1.035 m (:func:`solve_scale`),
    de Leva's 73.0 kg male mean plus the six 0.01 kg intermediate bodies."""
    A = ASSUMPTIONS
    return Subject(
        DE_LEVA_STATURE * solve_scale(),
        A["body_mass_kg"] + N_INTERMEDIATE * A["intermediate_body_mass_kg"],
        "male",
    )


def initial_com_height(subject: Subject) -> float:
    """Central-body COM height [m] of W's initial posture (5 deg tilt, W's joint angles, feet
    flat) with the soles ``sole_clearance_m`` above the floor (the sagittal chain in closed form)."""
    A = ASSUMPTIONS
    s, sex = subject.scale, subject.sex
    _, c, _, _ = central_body(s, subject.segment_mass_kg, sex)
    tilt = math.radians(INITIAL_TILT_DEG)
    th = [math.radians(a) for a in INITIAL_ANGLES_DEG]
    L1 = DE_LEVA[sex]["thigh"][0] * s
    L2 = DE_LEVA[sex]["shank"][0] * s
    h_a = A["ankle_height_fraction_of_stature"] * subject.stature_m
    return (
        A["sole_clearance_m"]
        + h_a
        + L2 * math.cos(-tilt + th[1] + th[3])
        + L1 * math.cos(-tilt + th[1])
        + c[2] * math.cos(tilt)
    )


def build_xml(subject: Subject | None = None) -> str:
    """The MJCF text of W's biped for ``subject`` (W's shipped biped if None; see the module
    docstring). Same bodies, joints, axes, actuators and keyframe for every subject."""
    A = ASSUMPTIONS
    subject = subject or w_subject()
    sex = subject.sex
    s = subject.scale
    H = subject.stature_m
    M = subject.segment_mass_kg
    table = DE_LEVA[sex]
    com0 = (0.0, 0.0, initial_com_height(subject))
    m1, c1, I1, dims = central_body(s, M, sex)
    evals, evecs = np.linalg.eigh(I1)
    assert np.allclose(evecs @ np.diag(evals) @ evecs.T, I1)
    # the HAT inertia is diagonal in the body axes by symmetry (the arms hang in the frontal plane)
    assert np.allclose(I1, np.diag(np.diag(I1)), atol=1e-9)
    L1, thigh = _seg("thigh", s, M, 2, -1.0, sex)
    L2, shank = _seg("shank", s, M, 2, -1.0, sex)
    Lf, foot = _seg("foot", s, M, 0, -1.0, sex)
    h_a = A["ankle_height_fraction_of_stature"] * H
    heel_x = A["heel_to_ankle_fraction_of_foot"] * Lf  # heel behind (+x of) the ankle
    toe_x = heel_x - Lf
    foot_com = np.array([heel_x - table["foot"][2] * Lf, 0.0, -0.5 * h_a])
    hip_y = A["hip_half_width_fraction_of_stature"] * H
    mi, Ii = A["intermediate_body_mass_kg"], A["intermediate_body_inertia_kgm2"]
    sole_t = 0.02
    foot_w = 0.055 * H  # Winter's foot breadth
    split_x = heel_x - 0.35 * Lf  # heel box: rear 35 % of the foot
    q0 = [
        math.cos(math.radians(INITIAL_TILT_DEG) / 2),
        0.0,
        -math.sin(math.radians(INITIAL_TILT_DEG) / 2),
        0.0,
    ]

    def leg(side: str, y: float) -> str:
        ax = {
            n: (tuple(-a for a in axis) if (side == "right" and n in MIRRORED) else axis)
            for n, axis in JOINTS
        }
        inter = f'<inertial pos="0 0 0" mass="{mi}" diaginertia="{Ii} {Ii} {Ii}"/>'
        r_th, r_sh = 0.065 * s, 0.048 * s
        return f"""
    <body name="{side}_hip_1" pos="0 {y:.6g} {-c1[2]:.6g}">
      {inter}
      <joint name="{side}_hip_abduction" axis="{_f(ax["hip_abduction"])}"/>
      <body name="{side}_hip_2">
        {inter}
        <joint name="{side}_hip_flexion" axis="{_f(ax["hip_flexion"])}"/>
        <body name="{side}_thigh">
          <inertial pos="{_f(thigh.com)}" mass="{thigh.mass:.6g}" diaginertia="{_f(thigh.inertia)}"/>
          <joint name="{side}_hip_rotation" axis="{_f(ax["hip_rotation"])}"/>
          <geom name="{side}_thigh" type="capsule" fromto="0 0 -{r_th:.4g} 0 0 {-L1 + r_th:.6g}" size="{r_th:.4g}" rgba="0.35 0.45 0.65 1"/>
          <body name="{side}_shank" pos="0 0 {-L1:.6g}">
            <inertial pos="{_f(shank.com)}" mass="{shank.mass:.6g}" diaginertia="{_f(shank.inertia)}"/>
            <joint name="{side}_knee" axis="{_f(ax["knee"])}"/>
            <geom name="{side}_shank" type="capsule" fromto="0 0 -{r_sh:.4g} 0 0 {-L2 + r_sh:.6g}" size="{r_sh:.4g}" rgba="0.35 0.45 0.65 1"/>
            <body name="{side}_ankle_1" pos="0 0 {-L2:.6g}">
              {inter}
              <joint name="{side}_ankle_inversion" axis="{_f(ax["ankle_inversion"])}"/>
              <body name="{side}_foot">
                <inertial pos="{_f(foot_com)}" mass="{foot.mass:.6g}" diaginertia="{_f(foot.inertia)}"/>
                <joint name="{side}_ankle_dorsiflexion" axis="{_f(ax["ankle_dorsiflexion"])}"/>
                <geom name="{side}_heel" class="sole" pos="{(heel_x + split_x) / 2:.6g} 0 {-h_a + sole_t / 2:.6g}" size="{(heel_x - split_x) / 2:.6g} {foot_w / 2:.6g} {sole_t / 2}"/>
                <geom name="{side}_toe" class="sole" pos="{(split_x + toe_x) / 2:.6g} 0 {-h_a + sole_t / 2:.6g}" size="{(split_x - toe_x) / 2:.6g} {foot_w / 2:.6g} {sole_t / 2}"/>
              </body>
            </body>
          </body>
        </body>
      </body>
    </body>"""

    tr, hd = dims["trunk"], dims["head"]
    z0 = -c1[2]  # MIDH relative to the central body COM
    arms = ""
    for side, sgn in (("left", -1.0), ("right", 1.0)):
        y = sgn * dims["shoulder_y"]
        zs = z0 + dims["shoulder_z"]
        za = dims["upper_arm"] + dims["forearm"] + dims["hand"]
        arms += (
            f'\n    <geom name="{side}_arm" type="capsule" fromto="0 {y:.6g} {zs - 0.04 * s:.6g} '
            f'0 {y:.6g} {zs - za:.6g}" size="{0.04 * s:.4g}" rgba="0.8 0.65 0.55 1"/>'
        )
    angles = " ".join(f"{a:.6g}" for a in INITIAL_ANGLES_DEG * 2)
    angles_rad = " ".join(f"{math.radians(a):.10g}" for a in INITIAL_ANGLES_DEG * 2)
    actuators = "\n".join(
        f'    <motor name="{side}_{n}" joint="{side}_{n}"/>' for side in ("left", "right") for n, _ in JOINTS
    )
    return f"""<!--
  Wendlandt (1997) biped: 13 rigid bodies, 18 DOF. Generated by biped.models.anthropometry; do not edit.
  Segment parameters: P. de Leva, J. Biomech. 29(9):1223-1230, 1996, Table 4 ({sex}s), scaled to a
  stature of {H:.4f} m (scale {s:.5f} of de Leva's {DE_LEVA_SAMPLE[sex][0]} m) and a body mass of {round(M, 9)} kg, so that W's
  initial posture (joint angles {angles} deg, central body tilted {INITIAL_TILT_DEG} deg about -y,
  its COM at {com0[2]:.6g} m) puts both soles flat and {A["sole_clearance_m"]} m above the floor.
  Central body (link 1) = head + arms + trunk of de Leva. Intermediate hip/ankle bodies: {mi} kg.
  Other assumptions: ankle height {A["ankle_height_fraction_of_stature"]} H and foot breadth 0.055 H
  (Winter 2009); the ankle {A["heel_to_ankle_fraction_of_foot"]} of the foot length from the heel;
  hip joint centres {2 * hip_y:.4f} m apart; passive hinge damping {A["joint_damping_Nms_per_rad"]} N m s/rad
  (a plant property the controller does not model). The biped faces -x; its left leg is on -y.
  W's joint numbers: left 2..7 and right 8..13 = hip_abduction, hip_flexion, hip_rotation, knee,
  ankle_inversion, ankle_dorsiflexion. Body frames of the central body sit at its COM.
-->
<mujoco model="wendlandt">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="0.0005" gravity="0 0 -9.81"/>
  <default>
    <geom contype="2" conaffinity="1" friction="0.3 0.005 0.0001" condim="3"/>
    <joint type="hinge" limited="false" damping="{A["joint_damping_Nms_per_rad"]}"/>
    <default class="sole">
      <geom type="box" rgba="0.25 0.25 0.25 1"/>
    </default>
  </default>
  <worldbody>
    <body name="central_body" pos="{_f(com0)}" quat="{_f(q0)}">
      <freejoint name="root"/>
      <inertial pos="0 0 0" mass="{m1:.6g}" diaginertia="{_f(np.diag(I1))}"/>
      <geom name="trunk" type="box" pos="0 0 {z0 + tr / 2:.6g}" size="{0.1 * s:.4g} {0.17 * s:.4g} {tr / 2:.6g}" rgba="0.8 0.35 0.3 1"/>
      <geom name="head" type="sphere" pos="0 0 {z0 + tr + 0.5 * hd:.6g}" size="{0.1 * s:.4g}" rgba="0.8 0.65 0.55 1"/>{arms}
{leg("left", -hip_y)}
{leg("right", hip_y)}
    </body>
  </worldbody>
  <actuator>
{actuators}
  </actuator>
  <keyframe>
    <key name="wendlandt_initial" qpos="{_f(com0)} {_f(q0)} {angles_rad}"/>
  </keyframe>
</mujoco>
"""


def write(path: Path | None = None, subject: Subject | None = None) -> Path:
    """Write :func:`build_xml` of ``subject`` to ``path`` (default: the shipped ``wendlandt.xml``)."""
    path = path or Path(__file__).with_name("wendlandt.xml")
    files.write_text(path, build_xml(subject))
    return path


if __name__ == "__main__":
    print(write())
