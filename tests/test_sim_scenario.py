"""Scenario input: W's defaults, TOML round trip, and clear errors before any simulation."""

from __future__ import annotations

import json

import pytest

from biped.cli import main
from biped.errors import ScenarioError
from biped.sim.scenario import Scenario, keys, parse_assignment


def test_defaults_are_w_section_4():
    """Numbers typed from W section 4 (not from the code)."""
    s = Scenario()
    assert s.duration_s == 3.0 and s.control_rate_hz == 500.0 and s.physics_timestep_s <= 0.001
    assert s.block_mass_kg == 1.8
    assert s.block_position_m == (0.50, 0.10, 1.20)
    assert s.block_velocity_m_s == (-4.50, 0.0, 0.20)
    assert s.initial_com_m == (0.0, 0.0, 1.035) and s.initial_tilt_deg == 5.0
    assert s.initial_joint_angles_deg == (0.0, 40.0, 0.0, -77.4595, 0.0, 42.4595) * 2
    assert s.target_com_m == (-0.01, 0.0, 1.14) and s.target_tilt_deg == 15.0
    assert (s.kp_com, s.kv_com) == ((50, 50, 200), (7.07, 7.07, 14.142))
    assert (s.kp_rot, s.kv_rot) == ((50, 50, 50), (7.07, 7.07, 7.07))
    assert s.friction == 0.3 and s.restitution == 0.2


def test_toml_round_trip(tmp_path):
    s = Scenario(block_mass_kg=2.5, kp_com=(60.0, 60.0, 210.0), controller="joint-pd", torque_limits=150.0)
    p = tmp_path / "s.toml"
    p.write_text(s.to_toml())
    assert Scenario.from_toml(p) == s


@pytest.mark.parametrize(
    "text, words",
    [
        ("block_mas_kg = 2.0", ["unknown scenario key 'block_mas_kg'", "block_mass_kg"]),
        ("block_position_m = [0.5, 0.1]", ["block_position_m", "3 numbers", "got 2"]),
        ("initial_joint_angles_deg = [0, 40, 0]", ["initial_joint_angles_deg", "12 numbers"]),
        ("block_mass_kg = -1.0", ["block_mass_kg", "> 0"]),
        ("friction = nan", ["friction", "finite"]),
        ("block_velocity_m_s = [-4.5, nan, 0.2]", ["block_velocity_m_s[1]", "finite"]),
        ('controller = "pid"', ["controller", "'workspace'", "'joint-pd'"]),
        ("physics_timestep_s = 0.002", ["physics_timestep_s", "0.001"]),
        ("control_rate_hz = 700.0", ["control_rate_hz", "whole number"]),
        ("restitution = 1.5", ["restitution", "[0, 0.8]"]),
        ("torque_limits = [1, 2]", ["torque_limits", "12 numbers"]),
        ("seed = -3", ["seed", ">= 0"]),
        ("[block]\nmass = 2", ["tables", "top-level"]),
        ("block_mass_kg = ", ["not valid TOML"]),
    ],
)
def test_bad_scenario_file_names_the_key(tmp_path, text, words):
    p = tmp_path / "bad.toml"
    p.write_text(text + "\n")
    with pytest.raises(ScenarioError) as err:
        Scenario.from_toml(p)
    for w in words:
        assert w in str(err.value), (w, str(err.value))


def test_a_block_started_inside_the_floor_is_refused_and_one_resting_on_it_is_not():
    # the run used to start and end 'diverged' (MuJoCo pushing the cube out of the floor)
    with pytest.raises(
        ScenarioError, match=r"block_position_m: the block starts 1.05e\+03 mm inside the floor"
    ):
        Scenario().with_overrides(block_position_m=(0.0, 0.0, -1.0))
    resting = Scenario().with_overrides(block_position_m=(1.0, 0.0, 0.05), block_velocity_m_s=(0.0, 0.0, 0.0))
    assert resting.block_position_m[2] == 0.05  # the cube's bottom on the floor: allowed


def test_unknown_key_lists_every_valid_key():
    with pytest.raises(ScenarioError) as err:
        Scenario().with_overrides(mass=1)
    for k in keys():
        assert k in str(err.value)


@pytest.mark.parametrize(
    ("key", "hint"),
    [
        ("duraton_s", " (did you mean 'duration_s'?)"),
        ("block_mas_kg", " (did you mean 'block_mass_kg'?)"),
        ("zzz", ""),
    ],
)
def test_a_misspelt_key_names_the_nearest_valid_one(key, hint):
    """A typo gets the closest key (difflib) before the full list; a word near no key gets none."""
    with pytest.raises(ScenarioError) as err:
        Scenario.from_dict({key: 1.0})
    assert str(err.value).startswith(f"unknown scenario key {key!r}{hint}; valid keys: duration_s, ")


def test_set_assignment_parses_toml_values():
    assert parse_assignment("kp_com=[60, 60, 200]") == ("kp_com", [60, 60, 200])
    assert parse_assignment("controller=joint-pd") == ("controller", "joint-pd")
    with pytest.raises(ScenarioError, match="KEY=VALUE"):
        parse_assignment("kp_com")


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--block-mass", "-1"], ["block_mass_kg", "> 0"]),
        (["--set", "frobnicate=1"], ["unknown scenario key 'frobnicate'"]),
        (["--set", "block_size_m=[0.1, 0.1]"], ["block_size_m", "3 numbers"]),
        (["--duration", "nan"], ["duration_s", "finite"]),
    ],
)
def test_cli_rejects_bad_input_before_simulating(tmp_path, capsys, argv, words):
    out = tmp_path / "run"
    code = main(["push", "--quiet", "--no-video", "--no-replay", "--out", str(out), *argv])
    assert code == 2
    err = capsys.readouterr().err
    for w in words:
        assert w in err
    assert not out.exists()  # nothing simulated, nothing written


def test_cli_refuses_to_overwrite_a_run(tmp_path, capsys):
    out = tmp_path / "run"
    out.mkdir()
    (out / "summary.json").write_text(json.dumps({"recovered": True}))
    assert main(["push", "--quiet", "--out", str(out), "--duration", "0.01"]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert json.loads((out / "summary.json").read_text()) == {"recovered": True}


def test_physics_preset_sets_step_and_contact_unless_given(tmp_path):
    """The presets' numbers (typed here from docs/sweep.md, not read from the code); an explicit
    key wins over the preset; changing the preset resets what it sets; TOML round trip."""
    assert (Scenario().physics_timestep_s, Scenario().contact_timeconst_s) == (0.0005, 0.005)
    fast = Scenario(physics="fast")
    assert (fast.physics_timestep_s, fast.contact_timeconst_s, fast.sleep) == (0.001, 0.0075, True)
    assert not Scenario().sleep
    assert Scenario(physics="fast", physics_timestep_s=0.0005).physics_timestep_s == 0.0005
    assert Scenario().with_overrides(physics="fast") == fast
    assert fast.with_overrides(physics="faithful") == Scenario()
    assert fast.with_overrides(physics="faithful", contact_timeconst_s=0.01).contact_timeconst_s == 0.01
    p = tmp_path / "fast.toml"
    p.write_text('physics = "fast"\n')
    assert Scenario.from_toml(p) == fast
    p.write_text(fast.to_toml())
    assert Scenario.from_toml(p) == fast
    with pytest.raises(ScenarioError, match="physics must be one of 'faithful', 'fast'"):
        Scenario(physics="quick")


def test_push_cli_physics_flag():
    """``biped push`` stays faithful unless --physics says otherwise; --timestep still wins."""
    from biped.cli import build_parser
    from biped.cli.push import build_scenario

    def scenario(*argv):
        return build_scenario(build_parser().parse_args(["push", *argv]))

    assert scenario().physics == "faithful" and scenario().physics_timestep_s == 0.0005
    assert scenario("--physics", "fast") == Scenario(physics="fast")
    assert scenario("--physics", "fast", "--timestep", "0.0005").physics_timestep_s == 0.0005


@pytest.mark.parametrize(("value", "shown"), [(1, "1"), (0.0, "0.0"), ("yes", "'yes'")])
def test_a_non_bool_stepping_is_shown_as_given(value, shown):
    """``--set stepping=1`` said "got 1.0": the number was made a float before the check."""
    with pytest.raises(ScenarioError) as err:
        Scenario.from_dict({"stepping": value})
    assert str(err.value) == f"stepping must be true or false; got {shown}"


def test_a_huge_block_speed_is_stated_not_inf():
    """|v| is taken with math.hypot: a 1e308 m/s block is refused as 1e+308 m/s, not inf."""
    with pytest.raises(ScenarioError, match=r"got 1e\+308 m/s$"):
        Scenario(block_velocity_m_s=(1e308, 1e300, 0.0))


@pytest.mark.parametrize("bad", ["x", {"duration_s": 1.0}, 0])
def test_simulate_refuses_what_is_not_a_scenario(bad):
    """simulate("x") raised AttributeError ('str' object has no attribute 'model')."""
    from biped.sim import simulate

    with pytest.raises(ScenarioError, match=r"^simulate takes a biped\.sim\.Scenario"):
        simulate(bad)


def test_qp_floor_friction_is_on_by_default_and_written_with_the_qp_only():
    """On by default (the QP's pyramid on the floor's axes, QPWeights); written into to_dict at
    any value whenever the QP reads it, so a stored QP scenario without it is one written while
    the default was false; left out of W's (distribution "statics") at its default, so W's
    summary.json, scenario.toml and sweep identity stay as they were."""
    from biped.sim.policies import policy_config
    from biped.sim.sweep import SweepSpec

    on = Scenario(distribution="qp")
    off = on.with_overrides(qp_floor_friction=False)
    assert on.qp_floor_friction is True and policy_config(on).qp_weights.floor_friction
    assert not policy_config(off).qp_weights.floor_friction
    assert on.to_dict()["qp_floor_friction"] is True and off.to_dict()["qp_floor_friction"] is False
    assert "qp_floor_friction" not in Scenario().to_dict()
    assert "qp_floor_friction" not in Scenario().to_toml()
    for s in (on, off, Scenario(), Scenario().with_overrides(qp_floor_friction=False)):
        assert Scenario.from_dict(s.to_dict()) == s
    assert SweepSpec(base=off).identity != SweepSpec(base=on).identity
    with pytest.raises(ScenarioError, match="qp_floor_friction must be true or false"):
        off.with_overrides(qp_floor_friction="yes")
