"""The biped model (W section 2 and 4) and the tree model built from MJCF.

References: W's topology and initial state (section 4, printed numbers), de Leva (1996) Table 4
(male segment parameters, printed numbers), MuJoCo's forward kinematics of the shipped file.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from biped import models
from biped.errors import ModelError
from biped.model import TreeModel
from biped.models import anthropometry

# W section 4: initial joint angles theta_2..theta_13 [deg], COM (0, 0, 103.5) cm, 5 deg about -y.
W_ANGLES_DEG = [0.0, 40.0, 0.0, -77.4595, 0.0, 42.4595] * 2
W_COM = np.array([0.0, 0.0, 1.035])
W_TILT_DEG = 5.0

# W's joint k = 2..13 in MJCF names (docs/controller.md lists the same table).
W_JOINTS = [
    f"{side}_{j}"
    for side in ("left", "right")
    for j in ("hip_abduction", "hip_flexion", "hip_rotation", "knee", "ankle_inversion", "ankle_dorsiflexion")
]
W_BODIES = ["central_body"] + [
    f"{side}_{b}"
    for side in ("left", "right")
    for b in ("hip_1", "hip_2", "thigh", "shank", "ankle_1", "foot")
]

# de Leva (1996), Table 4, males: mass fraction, segment length [m] at stature 1.741 m, CM from the
# proximal end (fraction of length), radii of gyration (sagittal, transverse, longitudinal; fraction).
DE_LEVA = {
    "head": 0.0694,
    "trunk": 0.4346,
    "upper_arm": 0.0271,
    "forearm": 0.0162,
    "hand": 0.0061,
}
DE_LEVA_THIGH = (0.1416, 0.4222, 0.4095, 0.329, 0.329, 0.149)
DE_LEVA_SHANK = (0.0433, 0.4340, 0.4459, 0.255, 0.249, 0.103)
DE_LEVA_FOOT_MASS = 0.0137
BODY_MASS = 73.0  # kg, the stated body mass (de Leva's male sample)
INTERMEDIATE_MASS = 0.01  # kg, W's massless hip/ankle intermediate bodies


def w_initial_qpos(m: mujoco.MjModel) -> np.ndarray:
    """MuJoCo qpos of W's initial state built from the paper's numbers (not the keyframe)."""
    qpos = np.zeros(m.nq)
    half = math.radians(W_TILT_DEG) / 2
    quat = np.array([math.cos(half), 0.0, -math.sin(half), 0.0])  # about -y
    body = m.body("central_body").id
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, quat)
    qpos[:3] = W_COM - R.reshape(3, 3) @ m.body_ipos[body]
    qpos[3:7] = quat
    for name, angle in zip(W_JOINTS, W_ANGLES_DEG, strict=True):
        qpos[m.jnt_qposadr[m.joint(name).id]] = math.radians(angle)
    return qpos


def sole_corners(m, d, geom: str) -> np.ndarray:
    gid = m.geom(geom).id
    R, c, s = d.geom_xmat[gid].reshape(3, 3), d.geom_xpos[gid], m.geom_size[gid]
    return np.array([c + R @ (s * np.array([a, b, e])) for a in (-1, 1) for b in (-1, 1) for e in (-1, 1)])


# --------------------------------------------------------------------------- the shipped biped


def test_topology_matches_w(wendlandt_mj):
    m = wendlandt_mj
    assert m.nbody - 1 == 13 and m.nv == 18 and m.nq == 19
    types = [int(t) for t in m.jnt_type]
    assert types == [int(mujoco.mjtJoint.mjJNT_FREE)] + [int(mujoco.mjtJoint.mjJNT_HINGE)] * 12
    tree = TreeModel.from_mjcf(m)
    assert list(tree.body_names) == W_BODIES
    assert list(tree.joint_names) == W_JOINTS
    # W: left leg links 2..7, right 8..13 (0-based 1..6, 7..12), each a chain off link 1
    assert tree.parent.tolist() == [-1, 0, 1, 2, 3, 4, 5, 0, 7, 8, 9, 10, 11]
    assert tree.feet.tolist() == [6, 12]
    assert tree.leg.tolist() == [-1] + [0] * 6 + [1] * 6
    assert not tree.beyond_foot.any()
    # MuJoCo agrees on who is whose parent
    for k, name in enumerate(tree.body_names[1:], start=1):
        assert m.body_parentid[m.body(name).id] == m.body(tree.body_names[tree.parent[k]]).id


def test_w_initial_state_puts_soles_flat_just_above_floor(wendlandt_mj):
    m = wendlandt_mj
    d = mujoco.MjData(m)
    qpos = w_initial_qpos(m)
    # the keyframe shipped in the file is W's initial state
    np.testing.assert_allclose(m.key_qpos[m.key("wendlandt_initial").id], qpos, atol=1e-6)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    np.testing.assert_allclose(d.xipos[m.body("central_body").id], W_COM, atol=1e-9)
    for side in ("left", "right"):
        for part in ("heel", "toe"):
            gid = m.geom(f"{side}_{part}").id
            normal = d.geom_xmat[gid].reshape(3, 3)[:, 2]
            tilt = math.degrees(math.acos(min(1.0, normal[2])))
            assert tilt < 0.5, f"{side} {part} sole tilted {tilt:.3f} deg"
            bottom = sole_corners(m, d, f"{side}_{part}")[:, 2].min()
            assert 0.0 <= bottom <= 0.01, f"{side} {part} sole at {bottom:.4f} m"
    # both feet level with each other
    lf, rf = (sole_corners(m, d, f"{s}_heel")[:, 2].min() for s in ("left", "right"))
    assert abs(lf - rf) < 1e-9


def test_segment_parameters_are_de_levas(wendlandt_mj):
    m = wendlandt_mj
    mass = {m.body(i).name: m.body_mass[i] for i in range(1, m.nbody)}
    hat = (
        DE_LEVA["head"] + DE_LEVA["trunk"] + 2 * (DE_LEVA["upper_arm"] + DE_LEVA["forearm"] + DE_LEVA["hand"])
    )
    assert mass["central_body"] == pytest.approx(hat * BODY_MASS, rel=1e-5)
    for side in ("left", "right"):
        assert mass[f"{side}_thigh"] == pytest.approx(DE_LEVA_THIGH[0] * BODY_MASS, rel=1e-5)
        assert mass[f"{side}_shank"] == pytest.approx(DE_LEVA_SHANK[0] * BODY_MASS, rel=1e-5)
        assert mass[f"{side}_foot"] == pytest.approx(DE_LEVA_FOOT_MASS * BODY_MASS, rel=1e-4)
        for b in ("hip_1", "hip_2", "ankle_1"):
            assert mass[f"{side}_{b}"] == pytest.approx(INTERMEDIATE_MASS)
    # de Leva's fractions sum to one: total = body mass + the six intermediate bodies
    assert sum(mass.values()) == pytest.approx(BODY_MASS + 6 * INTERMEDIATE_MASS, rel=1e-5)
    # lengths, COM positions and radii of gyration of thigh and shank, at one common scale
    scale = None
    for seg, child, table in (("thigh", "shank", DE_LEVA_THIGH), ("shank", "ankle_1", DE_LEVA_SHANK)):
        b = m.body(f"left_{seg}").id
        length = np.linalg.norm(m.body_pos[m.body(f"left_{child}").id])
        s = length / table[1]
        scale = scale or s
        assert s == pytest.approx(scale, rel=1e-5)
        assert np.linalg.norm(m.body_ipos[b]) == pytest.approx(table[2] * length, rel=1e-5)
        r = np.sqrt(m.body_inertia[b] / m.body_mass[b]) / length  # about x, y, z
        np.testing.assert_allclose(r, [table[3], table[4], table[5]], rtol=1e-4)


def test_shipped_xml_is_generated():
    assert models.path("wendlandt").read_text() == anthropometry.build_xml()


def test_unknown_model_name_lists_valid_ones():
    with pytest.raises(ModelError, match="nope") as exc:
        models.path("nope")
    assert "'wendlandt'" in str(exc.value)


# --------------------------------------------------------------------------- TreeModel errors


def _mjcf(body: str, extra: str = "") -> str:
    return f"<mujoco><worldbody>{body}{extra}</worldbody></mujoco>"


_LEG = """<body name="{n}_1" pos="0 {y} -0.2"><joint name="{n}_j1" type="{t}" axis="1 0 0"/>
  <geom size="0.05"/><body name="{n}_foot" pos="0 0 -0.4"><joint name="{n}_j2" axis="0 1 0"/>
  <geom size="0.05"/></body></body>"""


def _biped(left_type="hinge", extra="") -> str:
    legs = _LEG.format(n="l", y=-0.1, t=left_type) + _LEG.format(n="r", y=0.1, t="hinge")
    return _mjcf(f'<body name="torso" pos="0 0 1"><freejoint/><geom size="0.1"/>{legs}</body>', extra)


def test_small_tree_builds():
    tree = TreeModel.from_mjcf(_biped(), feet=("l_foot", "r_foot"))
    assert tree.body_names == ("torso", "l_1", "l_foot", "r_1", "r_foot")
    assert tree.parent.tolist() == [-1, 0, 1, 0, 3]
    assert tree.feet.tolist() == [2, 4]


@pytest.mark.parametrize("jtype", ["slide", "ball"])
def test_slide_and_ball_joints_are_rejected(jtype):
    with pytest.raises(ModelError, match=rf"'l_1' has joints \['{jtype}'\].*hinge"):
        TreeModel.from_mjcf(_biped(left_type=jtype), feet=("l_foot", "r_foot"))


def test_unknown_foot_lists_valid_bodies():
    with pytest.raises(ModelError, match="'nope'") as exc:
        TreeModel.from_mjcf(_biped(), feet=("l_foot", "nope"))
    for name in ("'l_foot'", "'r_foot'", "'torso'"):
        assert name in str(exc.value)
    # the default feet do not exist in this model: same error, naming them
    with pytest.raises(ModelError, match="'left_foot'.*'l_foot'"):
        TreeModel.from_mjcf(_biped())


def test_same_foot_twice_and_feet_on_one_branch_are_rejected():
    with pytest.raises(ModelError, match="two different feet"):
        TreeModel.from_mjcf(_biped(), feet=("l_foot", "l_foot"))
    with pytest.raises(ModelError, match="share the link"):
        TreeModel.from_mjcf(_biped(), feet=("l_1", "l_foot"))


def test_two_floating_trees_are_rejected():
    box = '<body name="block" pos="1 0 1"><freejoint/><geom size="0.1"/></body>'
    with pytest.raises(ModelError, match=r"exactly one floating tree.*'torso', 'block'"):
        TreeModel.from_mjcf(_biped(extra=box), feet=("l_foot", "r_foot"))


def test_foot_outside_the_floating_tree_is_rejected():
    # a static body welded to the world is not part of the biped: not a valid foot
    static = '<body name="plate" pos="1 0 0"><geom size="0.1"/></body>'
    tree = TreeModel.from_mjcf(_biped(extra=static), feet=("l_foot", "r_foot"))  # scenery ignored
    assert "plate" not in tree.body_names
    with pytest.raises(ModelError, match="'plate'.*'l_foot'"):
        TreeModel.from_mjcf(_biped(extra=static), feet=("plate", "r_foot"))


def test_root_without_free_joint_and_jointless_links_are_rejected():
    hinge_root = _biped().replace("<freejoint/>", '<joint type="hinge"/>')
    with pytest.raises(ModelError, match="'torso' must have exactly one free joint"):
        TreeModel.from_mjcf(hinge_root, feet=("l_foot", "r_foot"))
    welded = _biped().replace('<joint name="l_j2" axis="0 1 0"/>', "")
    with pytest.raises(ModelError, match=r"'l_foot' has joints \[\]"):
        TreeModel.from_mjcf(welded, feet=("l_foot", "r_foot"))


def test_malformed_and_missing_files(tmp_path):
    with pytest.raises(ModelError, match="malformed MJCF"):
        TreeModel.from_mjcf("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(ModelError, match="does not exist"):
        TreeModel.from_mjcf(tmp_path / "none.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><bogus/></worldbody></mujoco>")
    with pytest.raises(ModelError, match="malformed model file"):
        TreeModel.from_mjcf(bad)
    with pytest.raises(ModelError, match="expected an MJCF path"):
        TreeModel.from_mjcf(42)
