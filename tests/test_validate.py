"""``biped validate --quick`` runs end to end and writes what it says; its table's rule is checked
against numbers it did not compute (the human band of the paper, by hand)."""

from __future__ import annotations

import json
import math

import pyarrow.parquet as pq
import pytest

from biped.analysis.validate import HUMAN
from biped.cli import main


def test_human_band_is_mean_plus_minus_two_sd():
    h = HUMAN["ankle_release.lean_deg"]  # Robinovitch 2002: 5.9 +/- 1.1 deg
    assert h.inside(3.7) and h.inside(8.1) and not h.inside(3.6) and not h.inside(8.2)
    assert h.inside(float("nan")) is None


def test_validate_quick_writes_the_table_figures_and_trials(tmp_path, capsys):
    out = tmp_path / "v"
    assert main(["validate", "--quick", "--experiment", "ankle_release", "--out", str(out)]) == 0
    data = json.loads((out / "validation.json").read_text())
    rows = {r["quantity"]: r for r in data["rows"]}
    lean = rows["largest forward lean recovered, ankles only"]
    assert lean["human"]["mean"] == 5.9 and lean["human"]["sd"] == 1.1
    trials = pq.read_table(out / "trials.parquet").to_pylist()
    for preset in ("ideal", "young"):
        value = lean[preset]["value"]
        mine = [t for t in trials if t["neuromotor"] == preset]
        survived = [t["magnitude"] for t in mine if t["survived"]]
        fell = [t["magnitude"] for t in mine if not t["survived"]]
        # the threshold is the largest lean survived, below every lean that fell
        if lean[preset]["bound"] == "":
            assert value == max(survived) and value < min(fell)
        assert lean[preset]["inside_2sd"] in (None, abs(value - 5.9) <= 2.2)
    # each trial says what came of it; survived is exactly the recovered and survived outcomes
    assert {t["outcome"] for t in trials} <= {"recovered", "survived", "fell", "diverged", "error"}
    assert all(t["survived"] == (t["outcome"] in ("recovered", "survived")) for t in trials)
    for preset, th in data["experiments"]["ankle_release"]["thresholds"].items():
        assert sum(th["outcomes"].values()) == sum(t["neuromotor"] == preset for t in trials)
    assert "young" in (out / "validation.md").read_text()
    assert (out / "figures" / "ankle_release.png").stat().st_size > 1000
    assert not any("not_run" in r for r in data["rows"])  # every experiment of the issue runs now


def test_validate_rejects_an_unknown_experiment(tmp_path, capsys):
    assert main(["validate", "--quick", "--experiment", "stairs", "--out", str(tmp_path / "x")]) == 2
    assert "experiment" in capsys.readouterr().err


def test_a_long_trial_says_its_simulated_time_every_second(tmp_path, monkeypatch):
    """A young trial may run 10-25 s: ``biped validate`` says its simulated time on stderr a line a
    second (stderr a pipe here), so that no wait between two lines is longer than the heartbeat's
    1 s plus the wall time of a report's 50 ms of simulation; a trial that ends within 1 s adds no line. The trials
    are fakes on a fake clock (the heartbeat's wiring, not the simulation, is under test), each
    calling the CLI's ``running(t, duration)`` every 50 ms of its 4 s, as ``simulate`` does."""
    import types

    import biped._progress
    import biped.analysis.validate as av

    now = [0.0]
    lines: list[tuple[float, str]] = []  # (fake time, stderr line)

    class Stderr:
        def write(self, text):
            lines.extend((now[0], x) for x in text.splitlines() if x)

        def flush(self):
            pass

        def isatty(self):
            return False

    def fake_trial(exp, neuromotor, magnitude, running=None):
        lines.append((now[0], "<start>"))
        wall = 1 / 128 if magnitude == exp.lo else 1 / 8  # per 50 ms simulated: 0.6 s or 10 s a trial
        for k in range(1, 81):
            now[0] += wall
            running(k * 0.05, 4.0)
        return av.Trial(
            exp.key,
            neuromotor,
            magnitude,
            exp.unit,
            magnitude < 6.0,
            None,
            1.0,
            1.0,
            0.0,
            wall * 80,
            passed=magnitude < 6.0,  # the experiment's criterion (survived, for the ankle-only lean)
        )

    monkeypatch.setattr(biped._progress, "time", types.SimpleNamespace(perf_counter=lambda: now[0]))
    monkeypatch.setattr(av, "run_trial", fake_trial)
    monkeypatch.setattr("sys.stderr", Stderr())
    # one trial at a time (with --jobs 2 the trials run in another process, the heartbeat its wait's)
    argv = ["validate", "--quick", "--experiment", "ankle_release", "--neuromotor", "young", "--jobs", "1"]
    assert main([*argv, "--out", str(tmp_path / "v")]) == 0
    starts = [i for i, (_, x) in enumerate(lines) if x == "<start>"]
    assert len(starts) == 2 + 3  # the bracket's two trials and --quick's 3 halvings
    first = lines[starts[0] + 1 : starts[1]]  # the 0.25 deg trial, 0.6 s: its end line alone
    assert [x for _, x in first] == ["    ankle_release young: 0.25 deg survived (0.6 s)"]
    heartbeats = [x for _, x in lines if "s simulated" in x]
    assert len(heartbeats) >= 4 * 8  # four 10 s trials, a line a second after the first
    assert heartbeats[0] == "    ankle_release young: 16 deg: 0.45/4.00 s simulated (1.0 s)"
    times = [t for t, x in lines if not x.startswith("  ankle_release")]  # to the last trial's end
    gaps = [b - a for a, b in zip(times, times[1:], strict=False)]
    assert max(gaps) <= 1.0 + 1 / 8  # (binary fractions: exact)


def test_older_preset_is_held_against_the_older_adults_numbers():
    """Wojcik 1999: young women 30.7 deg, older women 16.2 deg (20 % SD assumed): a 17 deg
    threshold is inside the older band only, a 28 deg one inside the young band only."""
    from biped.analysis.validate import Threshold, human_for
    from biped.outputs.validate import table_rows

    assert human_for("step_release.lean_deg", "older").mean == 16.2
    assert human_for("step_release.lean_deg", "young").mean == 30.7
    assert human_for("ankle_release.lean_deg", "older").mean == 5.9  # no older number: the same
    per = {p: Threshold("step_release", p, v, "deg") for p, v in (("young", 17.0), ("older", 17.0))}
    row = table_rows({"step_release": per})[0]
    assert row["young"]["inside_2sd"] is False and row["older"]["inside_2sd"] is True
    assert row["human_older"]["mean"] == 16.2
    per = {p: Threshold("step_release", p, 28.0, "deg") for p in ("young", "older")}
    row = table_rows({"step_release": per})[0]
    assert row["young"]["inside_2sd"] is True and row["older"]["inside_2sd"] is False


def test_step_measures_agree_with_the_feet_and_the_controller():
    """The one-step release (ideal: no delay) at 13 deg: one step; its length equals the stepping
    foot's displacement between the start and the end of the run (the foot stays where it landed),
    to 1 cm; its contact time is the controller's touchdown (same sensing, no delay) to 2 periods."""
    import numpy as np

    from biped.analysis.validate import EXPERIMENTS, _step_measures
    from biped.sim import Scenario
    from biped.sim.push import simulate

    exp = EXPERIMENTS["step_release"]
    s = Scenario(neuromotor="ideal", **exp.base, **exp.magnitude(13.0))
    r = simulate(s)
    n, length, contact = _step_measures(r, s)
    st = r.extra["steps"][0]
    i = ("left", "right").index(st["foot"])
    moved = np.linalg.norm(r.feet_pos[len(r.times) - 2, i, :2] - r.feet_pos[0, i, :2])
    assert n == 1 and not r.fell and 0.25 < length < 0.5
    assert abs(length - moved) < 0.01
    assert abs(contact - 1000 * (st["touch_down_s"] - 0.1)) <= 4.0


def _initial_kinematics(s):
    """(scene, MjData after ``mj_forward`` of scenario ``s``'s initial state, the whole-body COM
    (MuJoCo's subtree COM of the biped's root, not the project's own COM code), the midpoint of
    the bodies named ``{side}_{body}`` for a body name) by MuJoCo's kinematics."""
    import mujoco
    import numpy as np

    from biped.sim import build_scene
    from biped.sim.scene import initial_state

    scene = build_scene(s)
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:], _ = initial_state(scene, s)
    mujoco.mj_forward(m, d)
    com = d.subtree_com[m.body_rootid[scene.central_body]]

    def mid(body: str):
        return np.mean([d.xpos[m.body(f"{side}_{body}").id] for side in ("left", "right")], axis=0)

    return scene, d, com, mid


def _standing_geometry(**keys):
    """(whole-body COM, hips' midpoint) ahead of the ankles' midpoint [m] at the initial state of a
    platform scenario with ``keys``, and the COM's height above the ankles, by MuJoCo's kinematics
    (subtree COM of the biped's root), not the project's own COM code."""
    from biped.sim import Scenario

    s = Scenario(perturbation="platform", platform_displacement_m=(0.01, 0.0), **keys)
    _, _, com, mid = _initial_kinematics(s)
    ankles, hips = mid("ankle_1"), mid("hip_1")
    return ankles[0] - com[0], ankles[0] - hips[0], com[2] - ankles[2]  # the biped faces -x


def test_human_stance_stands_as_people_do_and_w_crouch_does_not():
    """HUMAN_STANCE against the cited alignment of quiet stance: the line of gravity 47-58 mm
    (+/- 4-5) ahead of the ankle, the hip on it (-5 +/- 5 mm), the hip 6.2 +/- 1.3 cm ahead of the
    ankle (Woodhull et al. 1985); W's crouch puts the COM twice as far forward."""
    from biped.analysis.validate import EXPERIMENTS, HUMAN_STANCE

    com, hips, height = _standing_geometry(**HUMAN_STANCE)
    assert 0.043 <= com <= 0.063 and abs(hips - com) <= 0.01 and 0.049 <= hips <= 0.075
    assert 0.85 < height < 0.95
    w_com, _, _ = _standing_geometry()
    assert w_com > 0.09  # W's initial pose: 10.3 cm
    for key in ("platform_backward", "waist_pull"):
        base = EXPERIMENTS[key].base
        assert all(base[k] == v for k, v in HUMAN_STANCE.items())


def _release_geometry(lean_deg: float, key: str):
    """(whole-body COM minus the ankles' midpoint (3,), the hip joints' midpoint minus it (3,), the
    central body's orientation (4,), the hip and knee angles (8,) [deg], the ankle dorsiflexions
    (2,) [deg]) at the initial state of experiment ``key`` leaned ``lean_deg``, by MuJoCo's
    kinematics (subtree COM of the biped's root)."""
    import numpy as np

    from biped.analysis.validate import EXPERIMENTS
    from biped.sim import Scenario

    exp = EXPERIMENTS[key]
    scene, d, com, mid = _initial_kinematics(Scenario(**{**exp.base, **exp.magnitude(lean_deg)}))
    m = scene.model
    ankles, hips = mid("ankle_1"), mid("thigh")
    angle = {n: math.degrees(d.qpos[m.jnt_qposadr[m.joint(n).id]]) for n in scene.joint_names}
    hk = [v for n, v in angle.items() if "ankle" not in n]
    ank = [v for n, v in angle.items() if "dorsiflexion" in n]
    return com - ankles, hips - ankles, d.xquat[scene.central_body].copy(), np.array(hk), np.array(ank)


@pytest.mark.parametrize("key", ["ankle_release", "step_release"])
def test_lean_releases_lean_human_stance_straight_about_the_ankles(key):
    """Both lean-and-release experiments start from HUMAN_STANCE (Robinovitch's and Wojcik's
    subjects stood upright), MuJoCo's kinematics of the initial state: at no lean the whole-body
    COM stands 4.3-6.3 cm ahead of the ankles (the cited alignment of quiet stance, as the
    platform's); leaned 10 deg the body above the ankles has turned by 10 deg about them, straight:
    the central body's orientation by 10 deg about the lateral axis and the hip joints' line from
    the ankles by 10 deg at the same distance (1e-6 deg, 1e-9 m), the hips and knees keep
    HUMAN_STANCE's angles (1e-6 deg) and only the ankles turn, by the lean; the whole-body COM
    (with the feet, which stay) moves forward by 13-17 cm (0.89 m x sin 10 deg = 0.155 m)."""
    import numpy as np

    from biped.analysis.validate import EXPERIMENTS, HUMAN_STANCE

    base = EXPERIMENTS[key].base
    assert all(base[k] == v for k, v in HUMAN_STANCE.items())
    c0, h0, q0, hk0, ank0 = _release_geometry(0.0, key)
    assert 0.043 <= -c0[0] <= 0.063, c0  # the biped faces -x
    c1, h1, q1, hk1, ank1 = _release_geometry(10.0, key)
    turn = math.degrees(math.atan2(-h1[0], h1[2]) - math.atan2(-h0[0], h0[2]))
    assert turn == pytest.approx(10.0, abs=1e-6) and abs(h1[1] - h0[1]) < 1e-9
    assert np.linalg.norm(h1) == pytest.approx(np.linalg.norm(h0), abs=1e-9)
    dq = np.zeros(4)
    import mujoco

    mujoco.mju_mulQuat(dq, q1, np.array([q0[0], -q0[1], -q0[2], -q0[3]]))
    axis_angle = 2 * math.degrees(math.atan2(np.linalg.norm(dq[1:]), abs(dq[0])))
    assert axis_angle == pytest.approx(10.0, abs=1e-6) and abs(dq[2]) / np.linalg.norm(dq[1:]) > 1 - 1e-9
    want = [
        a for n, a in zip(_JOINTS, HUMAN_STANCE["initial_joint_angles_deg"], strict=True) if "ankle" not in n
    ]
    assert np.allclose(hk0, want, atol=1e-6) and np.allclose(hk1, want, atol=1e-6)
    assert np.allclose(np.abs(ank1 - ank0), 10.0, atol=1e-6), (ank0, ank1)
    assert 0.13 < c0[0] - c1[0] < 0.17, (c0, c1)


_JOINTS = tuple(f"{side}_{j}" for side in ("left", "right")
                for j in ("hip_abduction", "hip_flexion", "hip_rotation", "knee", "ankle_inversion",
                          "ankle_dorsiflexion"))  # fmt: skip


def test_waist_pull_measure_is_the_waist_carried_the_displacement():
    """Mille's % BoS is the waist's position ahead of the ankles: the pelvis's starting offset
    (MuJoCo kinematics of the initial state) plus the motor's travel, less the cable's stretch and
    the pelvis's lag (under 1 cm, tests/test_pull.py), over the ankle-to-toe length."""
    import mujoco
    import numpy as np

    from biped.analysis.validate import EXPERIMENTS, ankle_to_toe_m, run_trial
    from biped.sim import Scenario, build_scene
    from biped.sim.perturbations.base import pelvis_point
    from biped.sim.scene import initial_state

    exp = EXPERIMENTS["waist_pull"]
    t = run_trial(exp, "young", 0.03)
    assert t.survived
    s = Scenario(neuromotor="young", **exp.base, **exp.magnitude(0.03))
    scene = build_scene(s)
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:], _ = initial_state(scene, s)
    mujoco.mj_kinematics(m, d)
    cb = scene.central_body
    waist = d.xpos[cb] + d.xmat[cb].reshape(3, 3) @ pelvis_point(m, cb)
    ankles = np.mean([d.xpos[m.body(f"{side}_ankle_1").id] for side in ("left", "right")], axis=0)
    expected = (ankles[0] - waist[0]) + 0.03  # the pull goes -x, the way the biped faces
    measured = t.percent_bos / 100.0 * ankle_to_toe_m(s.model)
    assert expected - 0.01 < measured <= expected + 0.002


def test_step_measures_skip_a_contact_flicker_and_a_mid_swing_scuff():
    """A made-up stepping foot (500 Hz rows): released at 0.1 s, it loses the floor for 10 ms at
    0.30 s (1 cm up: a flicker), is off the floor from 0.36 s, scuffs it for 10 ms at 0.50 s and
    lands at 0.70 s, moving 1 m/s forward from 0.36 s: the landing is the 0.70 s contact, 600 ms
    after the release, 0.34 m from where the foot stood (the closed form of the made-up path)."""
    from types import SimpleNamespace

    import numpy as np

    from biped.analysis.validate import _step_measures

    t = np.arange(0.0, 1.2, 0.002)
    on = np.ones(len(t), dtype=bool)
    z = np.zeros(len(t))
    flick = (t >= 0.30 - 1e-9) & (t < 0.31 - 1e-9)
    on[flick], z[flick] = False, 0.02
    air = (t >= 0.36 - 1e-9) & (t < 0.70 - 1e-9)
    on[air], z[air] = False, 0.05
    on[(t >= 0.50 - 1e-9) & (t < 0.51 - 1e-9)] = True  # the scuff
    x = np.clip(t - 0.36, 0.0, 0.34)  # forward, m
    feet = np.zeros((len(t), 2, 3))
    feet[:, 1, 0], feet[:, 1, 2] = -x, z  # the right foot steps; the biped faces -x
    r = SimpleNamespace(times=t, feet_pos=feet, left_contact=np.ones(len(t), dtype=bool), right_contact=on,
                        extra={"steps": [{"foot": "right", "start_s": 0.2}]})  # fmt: skip
    s = SimpleNamespace(control_rate_hz=500.0, perturbation="release", release_time_s=0.1)
    n, length, contact = _step_measures(r, s)
    assert n == 1
    assert abs(contact - 600.0) < 1e-6, contact
    assert abs(length - 0.34) < 1e-9, length


def _trial_or_stop(exp, neuromotor, magnitude, running=None):
    """A stand-in trial (module level: the pool's processes unpickle it). The ankle-only lean's and
    the one-step lean's at 2 and 18 deg return at once; the one-step lean's 10 deg trial waits 3 s
    (the ankle-only searches end meanwhile in the other process), sends the run SIGTERM, as a user
    would, and runs on until the run stops it."""
    import os
    import signal
    import time

    import biped.analysis.validate as av

    if exp.key.startswith("step_release") and magnitude == 10.0:
        time.sleep(3.0)
        os.kill(os.getppid(), signal.SIGTERM)
        time.sleep(60.0)
    ok = magnitude < 6.0
    return av.Trial(exp.key, neuromotor, magnitude, exp.unit, ok, None, 1.0, 1.0, 0.0, 0.0, passed=ok)


def test_sigterm_with_two_jobs_writes_the_searches_already_finished(tmp_path, monkeypatch):
    """``--jobs 2`` runs every search at once but collects them in order: SIGTERM while the first
    (the one-step lean, still running) is waited on must still write the ankle-only lean's finished
    threshold (a run stopped never loses finished work), and say it was interrupted."""
    import biped.analysis.validate as av

    monkeypatch.setattr(av, "run_trial", _trial_or_stop)
    out = tmp_path / "v"
    argv = ["validate", "--quick", "--jobs", "2", "--neuromotor", "young", "--out", str(out)]
    code = main([*argv, "--experiment", "step_release", "--experiment", "ankle_release"])
    assert code in (130, 143)
    data = json.loads((out / "validation.json").read_text())
    assert data["meta"]["interrupted"] is True
    assert list(data["experiments"]) == ["ankle_release"]  # the one-step lean's search never ended
    lean = {r["quantity"]: r for r in data["rows"]}["largest forward lean recovered, ankles only"]
    survived = [t["magnitude"] for t in pq.read_table(out / "trials.parquet").to_pylist() if t["survived"]]
    assert lean["young"]["value"] == max(survived) < 6.0  # the stand-in survives below 6 deg
