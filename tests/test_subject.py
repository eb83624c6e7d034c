"""Your own subject: ``biped model`` and ``--model`` on push, sweep and walk.

References: de Leva (1996) Table 4 printed numbers (typed here from the paper, both sexes),
MuJoCo's masses and forward kinematics of the written files, W section 4's printed initial state
and set point, the shipped file (the male path must reproduce it).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from biped import models
from biped.cli import main
from biped.errors import BipedError, ModelError
from biped.model import TreeModel
from biped.models import anthropometry
from biped.models.subject import check_biped, subject_state
from biped.sim import Scenario, build_scene

# de Leva (1996) Table 4, females: segment length [m] at 1.735 m, mass fraction, CM from the
# proximal end (fraction of length), radii of gyration (sagittal, transverse, longitudinal).
FEMALE = {
    "head": (0.2437, 0.0668),
    "trunk": (0.6148, 0.4257),
    "upper_arm": (0.2751, 0.0255),
    "forearm": (0.2643, 0.0138),
    "hand": (0.0780, 0.0056),
}
FEMALE_THIGH = (0.3685, 0.1478, 0.3612, 0.369, 0.364, 0.162)
FEMALE_SHANK = (0.4323, 0.0481, 0.4416, 0.271, 0.267, 0.093)
FEMALE_FOOT = (0.2283, 0.0129)
FEMALE_STATURE = 1.735
PRINTED_SUM = 0.9999  # the female fractions as printed (rounding)
MALE_FRACTIONS = (0.0694, 0.4346, 0.0271, 0.0162, 0.0061, 0.1416, 0.0433, 0.0137)
INTERMEDIATE = 6 * 0.01  # kg

W_ANGLES_DEG = (0.0, 40.0, 0.0, -77.4595, 0.0, 42.4595) * 2
W_COM, W_TARGET = (0.0, 0.0, 1.035), (-0.01, 0.0, 1.14)  # W section 4 [m]


@pytest.fixture(scope="module")
def female(tmp_path_factory):
    path = tmp_path_factory.mktemp("subject") / "f155.xml"
    assert main(["model", "--stature", "1.55", "--mass", "50", "--sex", "female", "--out", str(path)]) == 0
    return path


def _sole_bottoms(m, d):
    out = []
    for side in ("left", "right"):
        for part in ("heel", "toe"):
            g = m.geom(f"{side}_{part}").id
            R, c, s = d.geom_xmat[g].reshape(3, 3), d.geom_xpos[g], m.geom_size[g]
            out += [c + R @ (s * np.array([a, b, -1.0])) for a in (-1, 1) for b in (-1, 1)]
    return np.array(out)


# --------------------------------------------------------------------------- biped model


def test_printed_fractions_sum_to_one():
    """de Leva's printed fractions, whole body (arms and legs twice): males 1.0000, females 0.9999."""
    h, t, ua, fa, ha, th, sh, fo = MALE_FRACTIONS
    assert h + t + 2 * (ua + fa + ha + th + sh + fo) == pytest.approx(1.0, abs=1e-12)
    f = sum(v[1] for k, v in FEMALE.items() if k in ("head", "trunk")) + 2 * (
        sum(v[1] for k, v in FEMALE.items() if k not in ("head", "trunk"))
        + FEMALE_THIGH[1]
        + FEMALE_SHANK[1]
        + FEMALE_FOOT[1]
    )
    assert f == pytest.approx(PRINTED_SUM, abs=1e-12)
    fr = anthropometry.mass_fractions("female")
    total = sum(anthropometry._COUNT[k] * v for k, v in fr.items())
    assert total == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize(
    "stature,mass,sex", [(1.55, 50.0, "female"), (1.85, 90.0, "male"), (1.70, 62.0, "female")]
)
def test_total_mass_is_the_given_mass(stature, mass, sex):
    m = mujoco.MjModel.from_xml_string(anthropometry.build_xml(anthropometry.Subject(stature, mass, sex)))
    assert float(m.body_mass.sum()) == pytest.approx(mass, abs=2e-4)  # 6 printed digits


@pytest.mark.parametrize("stature,mass,sex", [(1.55, 50.0, "female"), (1.95, 100.0, "male")])
def test_keyframe_puts_both_soles_flat_5mm_up(stature, mass, sex):
    """MuJoCo's forward kinematics of the keyframe: every bottom corner of the four sole boxes
    5 mm above the floor (to the file's 6 digits), W's tilt and angles in the keyframe."""
    m = mujoco.MjModel.from_xml_string(anthropometry.build_xml(anthropometry.Subject(stature, mass, sex)))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("wendlandt_initial").id)
    mujoco.mj_kinematics(m, d)
    z = _sole_bottoms(m, d)[:, 2]
    assert np.all(np.abs(z - 0.005) < 2e-5), z
    q = d.qpos[3:7]
    assert math.degrees(2 * math.acos(q[0])) == pytest.approx(5.0, abs=1e-4)
    assert q[2] < 0  # about -y
    for name, a in zip(anthropometry_joints(), W_ANGLES_DEG, strict=True):
        assert math.degrees(d.qpos[m.joint(name).qposadr[0]]) == pytest.approx(a, abs=1e-6)


def anthropometry_joints():
    return [f"{s}_{j}" for s in ("left", "right") for j, _ in anthropometry.JOINTS]


def test_female_segments_match_de_leva(female):
    """Segment masses = printed fraction / 0.9999 x (50 kg - the 6 x 0.01 kg intermediate bodies);
    lengths = printed length x 1.55 / 1.735; thigh inertia from the printed radii of gyration."""
    m = mujoco.MjModel.from_xml_path(str(female))
    M = (50.0 - INTERMEDIATE) / PRINTED_SUM
    k = 1.55 / FEMALE_STATURE
    hat = (
        FEMALE["head"][1]
        + FEMALE["trunk"][1]
        + 2 * sum(FEMALE[s][1] for s in ("upper_arm", "forearm", "hand"))
    )
    expect = {"central_body": hat, "thigh": FEMALE_THIGH[1], "shank": FEMALE_SHANK[1], "foot": FEMALE_FOOT[1]}
    for body, frac in expect.items():
        names = [body] if body == "central_body" else [f"left_{body}", f"right_{body}"]
        for n in names:
            assert m.body(n).mass[0] == pytest.approx(frac * M, rel=1e-5), n
    assert -m.body("left_shank").pos[2] == pytest.approx(FEMALE_THIGH[0] * k, abs=2e-6)
    assert -m.body("left_ankle_1").pos[2] == pytest.approx(FEMALE_SHANK[0] * k, abs=2e-6)
    L, mt = FEMALE_THIGH[0] * k, FEMALE_THIGH[1] * M
    thigh = m.body("left_thigh")
    assert thigh.ipos[2] == pytest.approx(-FEMALE_THIGH[2] * L, abs=2e-6)
    assert sorted(thigh.inertia) == pytest.approx(
        sorted(
            [
                mt * (FEMALE_THIGH[3] * L) ** 2,
                mt * (FEMALE_THIGH[4] * L) ** 2,
                mt * (FEMALE_THIGH[5] * L) ** 2,
            ]
        ),
        rel=1e-5,
    )


def test_male_path_reproduces_the_shipped_file(tmp_path):
    """W's subject through the CLI (full-precision stature, 73.0 kg + the 0.06 kg intermediate
    bodies) writes the shipped file byte for byte."""
    w = anthropometry.w_subject()
    out = tmp_path / "w.xml"
    assert (
        main(["model", "--stature", repr(w.stature_m), "--mass", "73.06", "--sex", "male", "--out", str(out)])
        == 0
    )
    assert out.read_bytes() == models.path("wendlandt").read_bytes()


def test_same_structure_as_the_shipped_biped(female):
    a = mujoco.MjModel.from_xml_path(str(female))
    b = mujoco.MjModel.from_xml_path(str(models.path("wendlandt")))
    for kind, n in (("body", "nbody"), ("joint", "njnt"), ("actuator", "nu"), ("geom", "ngeom")):
        assert [getattr(a, kind)(i).name for i in range(getattr(a, n))] == [
            getattr(b, kind)(i).name for i in range(getattr(b, n))
        ]
    assert np.array_equal(a.jnt_axis, b.jnt_axis) and np.array_equal(a.body_parentid, b.body_parentid)


@pytest.mark.parametrize(
    "argv,msg",
    [
        (["--stature", "2.5", "--mass", "60"], "stature must be in [1.4, 2.1] m"),
        (["--stature", "1.7", "--mass", "20"], "mass must be in [35, 150] kg"),
        (["--stature", "1.5", "--mass", "140"], "outside [15, 45] kg/m^2"),
        (["--stature", "nan", "--mass", "60"], "stature must be in"),
    ],
)
def test_model_cli_rejects_out_of_range(tmp_path, capsys, argv, msg):
    assert main(["model", *argv, "--sex", "female", "--out", str(tmp_path / "x.xml")]) == 2
    err = capsys.readouterr().err
    assert msg in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x.xml").exists()


def test_model_cli_refuses_to_clobber(tmp_path, capsys):
    notes = tmp_path / "notes.txt"
    notes.write_text("keep me")
    base = ["model", "--stature", "1.6", "--mass", "55", "--sex", "female"]
    assert main([*base, "--out", str(notes)]) == 2
    assert "must name an .xml file" in capsys.readouterr().err
    fake = tmp_path / "data.xml"
    fake.write_text("not xml at all")
    assert main([*base, "--out", str(fake)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main([*base, "--out", str(fake), "--overwrite"]) == 2
    assert "is not an XML file" in capsys.readouterr().err
    assert notes.read_text() == "keep me" and fake.read_text() == "not xml at all"


# --------------------------------------------------------------------------- --model


def test_subject_state_on_w_biped_gives_w_numbers():
    """Moving W's experiment onto W's own biped returns W's printed initial COM and set point."""
    st = subject_state(
        models.path("wendlandt"),
        initial_tilt_deg=5.0,
        joint_angles_deg=W_ANGLES_DEG,
        target_com_m=W_TARGET,
        target_tilt_deg=15.0,
        reference_com_m=W_COM,
    )
    assert st.initial_com_m == pytest.approx(W_COM, abs=2e-6)
    assert st.target_com_m == pytest.approx(W_TARGET, abs=2e-6)
    assert st.height_ratio == pytest.approx(1.0, abs=2e-6) and st.mass_ratio == 1.0


def test_female_set_point_keeps_the_feet_where_they_stand(female):
    """MuJoCo FK: the subject at its set point (W's 15 deg tilt, the joint angles of W's set point)
    has both feet flat, on the soles' initial place (to 1e-9 m)."""
    s = Scenario.for_model(str(female))
    m = mujoco.MjModel.from_xml_path(str(female))
    d = mujoco.MjData(m)
    q0 = m.key("wendlandt_initial").qpos.copy()
    assert s.initial_com_m == pytest.approx(tuple(q0[:3]), abs=1e-6)  # keyframe (6 digits)
    q0[:3] = s.initial_com_m  # the file's keyframe has 6 digits: W's exact tilt and angles here
    q0[3:7] = (math.cos(math.radians(2.5)), 0.0, -math.sin(math.radians(2.5)), 0.0)
    for name, a in zip(anthropometry_joints(), W_ANGLES_DEG, strict=True):
        q0[m.joint(name).qposadr[0]] = math.radians(a)
    d.qpos[:] = q0
    mujoco.mj_kinematics(m, d)
    before = _sole_bottoms(m, d)
    st = subject_state(
        female,
        initial_tilt_deg=5.0,
        joint_angles_deg=W_ANGLES_DEG,
        target_com_m=W_TARGET,
        target_tilt_deg=15.0,
        reference_com_m=W_COM,
    )
    q = q0.copy()
    q[:3] = s.target_com_m
    h = math.radians(15.0) / 2
    q[3:7] = (math.cos(h), 0.0, -math.sin(h), 0.0)
    hip, knee, ankle = st.target_joint_angles_deg
    for side in ("left", "right"):
        for j, a in (("hip_flexion", hip), ("knee", knee), ("ankle_dorsiflexion", ankle)):
            q[m.joint(f"{side}_{j}").qposadr[0]] = math.radians(a)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    assert np.max(np.abs(_sole_bottoms(m, d) - before)) < 1e-9
    assert np.all(np.abs(before[:, 2] - 0.005) < 1e-12)
    assert s.target_com_m[2] > s.initial_com_m[2] + 0.05  # she rises, as W's biped does


def test_scenario_scene_and_controller_read_the_same_file(female):
    s = Scenario.for_model(str(female), duration_s=0.1)
    assert s.model == str(female.resolve())
    assert s.block_mass_kg == pytest.approx(1.8 * 50.0 / 73.06, rel=1e-5)
    scene = build_scene(s)
    biped_mass = sum(scene.model.body_mass[b] for b in range(1, scene.model.nbody) if b != scene.block_body)
    assert biped_mass == pytest.approx(50.0, abs=2e-4)
    assert TreeModel.from_mjcf(s.model).mass.sum() == pytest.approx(50.0, abs=2e-4)


def test_scenario_toml_round_trip_keeps_the_model(female, tmp_path):
    s = Scenario.for_model(str(female))
    (tmp_path / "s.toml").write_text(s.to_toml())
    assert Scenario.from_toml(tmp_path / "s.toml") == s


def _broken(tmp_path, female, old, new):
    p = tmp_path / "broken.xml"
    p.write_text(female.read_text().replace(old, new))
    return str(p)


@pytest.mark.parametrize(
    "case,msg",
    [
        ("missing", "not found"),
        ("text", "is not XML"),
        ("notmjcf", "not MJCF (root element <robot>"),
        ("renamed", "joints ['left_knee2'] are not W's 13"),
        ("nomotor", "hinges without a motor: ['right_knee']"),
        ("ball", "are not W's 13"),
    ],
)
def test_bad_model_files_are_named_up_front(tmp_path, female, capsys, case, msg):
    path = {
        "missing": lambda: str(tmp_path / "nope.xml"),
        "text": lambda: _broken(tmp_path, female, "<mujoco", "mujoco"),
        "notmjcf": lambda: (tmp_path / "r.urdf").write_text("<robot name='r'/>") and str(tmp_path / "r.urdf"),
        "renamed": lambda: _broken(tmp_path, female, '"left_knee"', '"left_knee2"'),
        "nomotor": lambda: _broken(tmp_path, female, '<motor name="right_knee" joint="right_knee"/>', ""),
        "ball": lambda: _broken(
            tmp_path, female, '<joint name="left_hip_rotation"', '<joint type="ball" name="left_hip_rotation"'
        ),
    }[case]()
    with pytest.raises(
        ModelError, match=msg.replace("[", r"\[").replace("]", r"\]").replace("(", r"\(").replace(")", r"\)")
    ):
        check_biped(path)
    for cmd in (
        ["push", "--quiet", "--no-video", "--no-replay", "--no-figures", "--out", str(tmp_path / "run")],
        ["sweep", "--quiet", "--out", str(tmp_path / "s.parquet")],
        ["walk", "--quiet", "--out", str(tmp_path / "walk")],
    ):
        assert main([*cmd, "--model", path]) == 2, cmd
        err = capsys.readouterr().err
        assert msg.split("(")[0].strip() in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "run").exists() and not (tmp_path / "s.parquet").exists()


def test_sweep_records_the_model_and_aims_at_her_height(female):
    from biped.cli import build_parser
    from biped.cli.sweep import build_spec

    args = build_parser().parse_args(["sweep", "--model", str(female), "--speed", "3", "--direction", "180"])
    spec = build_spec(args)
    assert spec.base.model == str(female.resolve())
    assert spec.model_path == female.resolve()
    st = Scenario.for_model(str(female))
    assert dict(spec.axes)["height_m"] == (pytest.approx(st.block_position_m[2]),)
    assert spec.base.target_com_m == st.initial_com_m  # --task hold, on her body
    default = build_spec(build_parser().parse_args(["sweep", "--speed", "3", "--direction", "180"]))
    assert default.identity != spec.identity


def test_walk_figure_takes_her_legs_and_her_masses(female):
    """The figure's legs are the file's; the inverse dynamics of a walk on her body needs, on
    average over the walk, vertical ground forces equal to her weight (momentum balance over a
    motion that starts and ends at rest: mean of m c''_z is ~0)."""
    from biped.kinematic import FigureDims, step_forward
    from biped.kinematic.dynamics import inverse_dynamics, load_biped

    dims = FigureDims.from_mjcf(female)
    m = mujoco.MjModel.from_xml_path(str(female))
    assert dims.thigh == pytest.approx(-m.body("left_shank").pos[2])
    assert dims.shank == pytest.approx(-m.body("left_ankle_1").pos[2])
    motion = step_forward(dims, 2, 1.0).sample(100.0)
    res = inverse_dynamics(motion, load_biped(str(female)))
    weight = float(m.body_mass.sum()) * 9.81
    fz = res.grf[:, :, 2].sum(axis=1) + res.residual[:, 2]
    assert float(np.mean(fz)) == pytest.approx(weight, rel=0.02)
    with pytest.raises(BipedError, match="differs from the biped"):
        inverse_dynamics(
            step_forward(FigureDims.from_anthropometry(), 2, 1.0).sample(100.0), load_biped(str(female))
        )


@pytest.mark.slow
def test_push_on_a_155m_50kg_female_recovers(female):
    """W's push moved onto her body (block 1.23 kg: W's momentum per kg of body) for 1.5 s: no fall,
    no divergence, COM within 2 cm and orientation within 2 deg of her set point."""
    from biped.sim import simulate

    r = simulate(Scenario.for_model(str(female), duration_s=1.5))
    assert r.block_contact_time_s is not None and 0.05 < r.block_contact_time_s < 0.12
    assert not r.fell and r.diverged is None and r.controller_error is None
    assert r.recovered, (r.final_com_error_m, r.final_orientation_error_deg)


def test_push_and_sweep_record_the_model(female, tmp_path):
    """The run's summary.json and scenario.toml and the sweep's Parquet metadata name the file;
    a key given on the command line wins over the moved-on value (W's own 1.8 kg block)."""
    import json

    import pyarrow.parquet as pq

    out = tmp_path / "push"
    assert (
        main(
            [
                "push",
                "--model",
                str(female),
                "--duration",
                "0.02",
                "--set",
                "block_mass_kg=1.8",
                "--no-video",
                "--no-replay",
                "--no-figures",
                "--quiet",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    sc = json.loads((out / "summary.json").read_text())["scenario"]
    moved = Scenario.for_model(str(female))
    assert sc["model"] == str(female.resolve()) and sc["block_mass_kg"] == 1.8
    assert sc["initial_com_m"] == list(moved.initial_com_m)
    assert Scenario.from_toml(out / "scenario.toml").model == str(female.resolve())
    sweep = tmp_path / "s.parquet"
    assert (
        main(
            [
                "sweep",
                "--model",
                str(female),
                "--speed",
                "3",
                "--direction",
                "180",
                "--duration",
                "0.02",
                "--workers",
                "1",
                "--quiet",
                "--out",
                str(sweep),
            ]
        )
        == 0
    )
    meta = pq.read_schema(sweep).metadata
    assert meta[b"biped.model"].decode() == str(female.resolve())
    import hashlib

    assert meta[b"biped.model_sha256"].decode() == hashlib.sha256(female.read_bytes()).hexdigest()


def test_human_torque_limits_scale_with_the_subjects_mass(female):
    """`torque_limits = "human"` on a push (and a sweep's human limits) use the subject's own mass,
    as MuJoCo sums it from the file: a 50 kg subject's limits are 50/73 of W's biped's; W's
    biped's push limits are the sweep's."""
    from biped.control.limits import HUMAN_N_M_PER_KG, MODEL_MASS_KG, torque_limits
    from biped.sim.push import scenario_limits

    mass = float(mujoco.MjModel.from_xml_path(str(female)).body_mass.sum())
    assert mass == pytest.approx(50.0, abs=1e-3)
    lim = scenario_limits(Scenario(model=str(female), torque_limits="human"))
    knee_flex = HUMAN_N_M_PER_KG["knee"][0][1]  # the knee's negative-direction limit [N m/kg]
    assert lim.lower[3] == pytest.approx(-knee_flex * mass, rel=1e-12)
    w = scenario_limits(Scenario(torque_limits="human"))
    ref = torque_limits("human", body_mass_kg=MODEL_MASS_KG)
    assert np.array_equal(w.lower, ref.lower) and np.array_equal(w.upper, ref.upper)
    assert np.allclose(lim.upper / w.upper, mass / MODEL_MASS_KG, rtol=1e-12)
