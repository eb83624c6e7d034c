"""The 15-part frame tree of B's figure against MuJoCo, and its map onto W's biped.

Oracles: MuJoCo's forward kinematics of the generated MJCF (body frames) and of the shipped
``wendlandt`` biped (its sole boxes), and the biped MJCF's segment lengths.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from biped.errors import ModelError
from biped.kinematic import JOINT_NAMES, PARTS, FigureDims, figure_mjcf, part_poses, step_forward
from biped.kinematic.dynamics import biped_qpos, load_biped
from biped.kinematic.figure import landmarks


def test_fifteen_parts_in_a_tree():
    names = [p.name for p in PARTS]
    assert len(names) == 15 == len(set(names))
    seen = set()
    for p in PARTS:
        assert p.parent is None or p.parent in seen, f"{p.name} before its parent"
        seen.add(p.name)
    assert {"pelvis", "torso", "head"} <= seen
    for side in ("left", "right"):
        for part in ("thigh", "shank", "foot", "upper_arm", "lower_arm", "hand"):
            assert f"{side}_{part}" in seen


def test_part_poses_equal_mujoco_body_frames():
    """Random pelvis poses and joint angles: every part frame equals MuJoCo's body frame."""
    dims = FigureDims.from_anthropometry()
    m = mujoco.MjModel.from_xml_string(figure_mjcf(dims))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    T = 20
    ang = rng.uniform(-2, 2, (T, len(JOINT_NAMES)))
    pos = rng.normal(size=(T, 3))
    rot = Rotation.random(T, random_state=1)
    P = part_poses(dims, pos, rot.as_matrix(), ang)
    quat = rot.as_quat()[:, [3, 0, 1, 2]]
    for t in range(T):
        d.qpos[:3], d.qpos[3:7] = pos[t], quat[t]
        for j, n in enumerate(JOINT_NAMES):
            d.qpos[m.joint(n).qposadr[0]] = ang[t, j]
        mujoco.mj_kinematics(m, d)
        for i, p in enumerate(PARTS):
            b = m.body(p.name).id
            np.testing.assert_allclose(P.pos[t, i], d.xpos[b], atol=1e-12, err_msg=p.name)
            np.testing.assert_allclose(P.rot[t, i], d.xmat[b].reshape(3, 3), atol=1e-12, err_msg=p.name)


def test_figure_has_the_biped_legs(wendlandt_mj):
    """The figure's leg lengths are the shipped biped's (MJCF printed to 6 digits)."""
    dims = FigureDims.from_anthropometry()
    m = wendlandt_mj
    assert dims.thigh == pytest.approx(-m.body("left_shank").pos[2], abs=1e-6)
    assert dims.shank == pytest.approx(-m.body("left_ankle_1").pos[2], abs=1e-6)
    assert dims.hip_half_width == pytest.approx(-m.body("left_hip_1").pos[1], abs=1e-6)
    heel, toe = m.geom("left_heel"), m.geom("left_toe")
    assert dims.ankle_height == pytest.approx(-(heel.pos[2] - heel.size[2]), abs=1e-6)
    assert dims.heel_back == pytest.approx(heel.pos[0] + heel.size[0], abs=1e-6)
    assert dims.toe_front == pytest.approx(-(toe.pos[0] - toe.size[0]), abs=1e-6)


def test_biped_driven_by_the_figure_puts_its_soles_where_the_figure_does():
    """Over a forward walk, the biped's sole corners (MuJoCo, from its heel and toe boxes) equal
    the figure's heel and toe points: the name-based joint map and the pi turn are right."""
    motion = step_forward(steps=2).sample(50.0)
    lm = landmarks(motion.dims, motion.poses())
    m = load_biped()
    q = biped_qpos(m, (motion.pelvis_pos, motion.pelvis_rot, motion.angles))
    d = mujoco.MjData(m)
    worst = 0.0
    for t in range(q.shape[0]):
        d.qpos[:] = q[t]
        mujoco.mj_kinematics(m, d)
        for side in ("left", "right"):
            heel, toe = m.geom(f"{side}_heel"), m.geom(f"{side}_toe")
            gh, gt = heel.id, toe.id
            Rh, Rt = d.geom_xmat[gh].reshape(3, 3), d.geom_xmat[gt].reshape(3, 3)
            # biped heel is the +x (back) end of its heel box, toe the -x end of its toe box
            p_heel = d.geom_xpos[gh] + Rh @ [heel.size[0], 0.0, -heel.size[2]]
            p_toe = d.geom_xpos[gt] + Rt @ [-toe.size[0], 0.0, -toe.size[2]]
            worst = max(
                worst,
                np.max(np.abs(p_heel - lm[f"{side}_heel"][t])),
                np.max(np.abs(p_toe - lm[f"{side}_toe"][t])),
            )
    assert worst < 1e-5


def test_bad_dims_are_rejected():
    dims = FigureDims.from_anthropometry()
    with pytest.raises(ModelError, match="heel_back"):
        FigureDims(**{**dims.__dict__, "heel_back": 1.0})
    with pytest.raises(ModelError, match="thigh must be finite and positive"):
        FigureDims(**{**dims.__dict__, "thigh": -0.4})
