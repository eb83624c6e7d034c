"""physics = "fast": each foot collides as one box, the union of its heel and toe boxes.

Checked against MuJoCo itself: the box's corners are the outer corners of the two boxes, the
bodies' mass and inertia do not change, the standing biped touches the floor at those corners
only (4 contacts a foot instead of 8), and the box is neither drawn nor kept when the trial
steps or is not W's shipped biped. (The heel/toe classification of its contacts is checked against an independent
reference in tests/test_sim_contact.py; the presets' envelopes in docs/sweep.md.)
"""

from __future__ import annotations

import itertools

import mujoco
import numpy as np

from biped.sim import Scenario
from biped.sim.scene import biped_spec, build_scene, initial_state, sole_union


def _corners(m, d, g):
    """(8, 3) world corners of box geom ``g``."""
    signs = np.array(list(itertools.product((-1, 1), repeat=3)), dtype=float)
    return d.geom_xpos[g] + (signs * m.geom_size[g]) @ d.geom_xmat[g].reshape(3, 3).T


def _standing(physics, stepping=False):
    sc = Scenario(physics=physics, stepping=stepping)
    scene = build_scene(sc)
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = initial_state(scene, sc)
    mujoco.mj_forward(m, d)
    return scene, m, d


def test_the_box_is_the_union_of_heel_and_toe():
    scene, m, d = _standing("fast")
    assert len(scene.sole_boxes) == 2
    for g, foot, _seam, _side in scene.sole_boxes:
        foot_name = ("left", "right")[foot]
        parts = np.vstack([_corners(m, d, m.geom(f"{foot_name}_{p}").id) for p in ("heel", "toe")])
        box = _corners(m, d, g)
        R = d.geom_xmat[g].reshape(3, 3)
        lo, hi = (parts @ R).min(axis=0), (parts @ R).max(axis=0)  # the parts' extent in the box's axes
        np.testing.assert_allclose((box @ R).min(axis=0), lo, atol=1e-9)
        np.testing.assert_allclose((box @ R).max(axis=0), hi, atol=1e-9)
        assert m.geom_group[g] == 3 and m.geom_rgba[g][3] == 0.0  # not drawn (groups 0-2 are)
        for p in ("heel", "toe"):
            assert m.geom_contype[m.geom(f"{foot_name}_{p}").id] == 0  # the parts only drawn


def test_the_box_changes_no_mass_and_touches_at_its_corners():
    _, mf, df = _standing("faithful")
    scene, m, d = _standing("fast")
    np.testing.assert_array_equal(m.body_mass, mf.body_mass)
    np.testing.assert_array_equal(m.body_inertia, mf.body_inertia)
    np.testing.assert_array_equal(m.body_ipos, mf.body_ipos)
    for mm, dd in ((m, d), (mf, df)):  # W's initial state has the soles flat, 5 mm up: 1 mm into the floor
        dd.qpos[scene.biped_qpos_index[2]] -= 0.006
        mujoco.mj_forward(mm, dd)
    boxes = {g for g, *_ in scene.sole_boxes}
    on_floor = [c for c in d.contact[: d.ncon].geom if scene.floor_geom in c]
    assert len(on_floor) == 8 and all(set(c) - {scene.floor_geom} <= boxes for c in on_floor)
    assert sum(scene.floor_geom in c for c in df.contact[: df.ncon].geom) == 16  # heel + toe: 8 a foot
    # every contact at a corner of the box's bottom face (MuJoCo puts it half the depth above)
    corners = np.vstack([_corners(m, d, g) for g in boxes])
    for j in range(d.ncon):
        if scene.floor_geom in d.contact.geom[j]:
            gap = np.linalg.norm(corners[:, :2] - d.contact.pos[j][:2], axis=1).min()
            assert gap < 2e-3, gap


def test_stepping_keeps_heel_and_toe():
    scene, m, _ = _standing("fast", stepping=True)
    assert scene.sole_boxes == () and "left_sole_box" not in [m.geom(i).name for i in range(m.ngeom)]
    assert _standing("faithful")[0].sole_boxes == ()


def test_other_models_keep_heel_and_toe(tmp_path):
    """Only W's shipped biped gets the one box (a 55 kg subject's min-norm push diverged with it,
    docs/sweep.md), even the same file under another path."""
    from biped import models
    from biped.models import subject

    copy = tmp_path / "w.xml"
    copy.write_text(models.path(subject.DEFAULT).read_text())
    sc = Scenario.for_model(copy, physics="fast")
    assert not sc.sole_box and build_scene(sc).sole_boxes == ()


def test_boxes_that_are_not_flush_stay_apart():
    bm = biped_spec("wendlandt").compile()
    assert sole_union(bm, "left") is not None
    toe = bm.geom("left_toe").id
    bm.geom_pos[toe, 0] -= 0.001  # a 1 mm gap at the seam
    assert sole_union(bm, "left") is None
    bm.geom_pos[toe, 0] += 0.001
    bm.geom_size[toe, 1] *= 0.9  # a narrower toe
    assert sole_union(bm, "left") is None
