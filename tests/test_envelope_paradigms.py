"""`biped envelope --perturbation force|platform|release|pull` (docs/envelope.md, "Other perturbations").

- End to end on real physics (a force pulse, two directions, a three-size lattice, short trials):
  the limit each direction reports lies one lattice step below a failed trial and on a survived
  one, as the Parquet file's own rows say (the bisection's invariant, read back from the file),
  and the table's momentum change is the pulse's closed form F T.
- The paradigm's lattice: its defaults, and a --max above what its scenario accepts refused in
  one line (exit 2) before any work.
"""

from __future__ import annotations

import json
import math

import pytest

from biped.analysis import survived
from biped.cli import main
from biped.errors import BipedError
from biped.sim.sweep import load
from biped.sim.sweep.envelope import paradigm_lattice


def test_force_envelope_limit_lies_between_a_survived_and_a_failed_row(tmp_path, capsys):
    out, js = tmp_path / "f.parquet", tmp_path / "f.json"
    pulse_s = 0.05  # 25 control periods at 500 Hz: the applied impulse is exactly F * 0.05
    argv = ["envelope", "--perturbation", "force", "--directions", "0,90", "--min", "50",
            "--resolution", "4000", "--max", "8050", "--checks", "0", "--duration", "0.6",
            "--set", f"force_duration_s={pulse_s}", "--distribution", "qp", "--workers", "1",
            "--quiet", "--out", str(out), "--json", str(js)]  # fmt: skip
    assert main(argv) == 0
    table = load(out).table
    ok = survived(table)
    rows = table.to_pylist()
    data = json.loads(js.read_text())
    assert data["paradigm"] == "force" and data["unit"] == "N" and data["axis"] == "magnitude"
    assert {r["paradigm_unit"] for r in rows} == {"N"}
    mass = data["body_mass_kg"]
    for d in data["directions"]:
        mine = [(r["magnitude"], bool(k)) for r, k in zip(rows, ok, strict=True)
                if r["direction_deg"] == d["direction_deg"]]  # fmt: skip
        assert d["limit"] is not None and d["first_fail"] is not None  # both ends seen
        assert (d["limit"], True) in mine  # the limit is a survived row of the file
        assert (d["first_fail"], False) in mine  # the first failure a failed one
        assert math.isclose(d["first_fail"] - d["limit"], 4000.0)  # one step apart
        assert all(k for m, k in mine if m <= d["limit"]) and not any(
            k for m, k in mine if m >= d["first_fail"]
        )
        assert math.isclose(d["impulse_n_s"], d["limit"] * pulse_s, rel_tol=1e-9)  # F T, horizontal
        assert math.isclose(d["delta_v_m_s"], d["limit"] * pulse_s / mass, rel_tol=1e-9)
    assert "[N]" in capsys.readouterr().out  # the printed table's limit column is in newtons


def test_paradigm_lattices_stay_inside_their_scenario_checks():
    from biped.sim import Scenario
    from biped.sim.perturbations import of
    from biped.sim.perturbations.platform import MAX_DISPLACEMENT_M

    for name, unit in (
        ("block", "m/s"),
        ("force", "N"),
        ("platform", "m"),
        ("release", "deg"),
        ("pull", "m"),
    ):
        lat = paradigm_lattice(name)
        assert lat.unit == unit and lat.max <= lat.limit and lat.resolution < lat.max
    assert paradigm_lattice("platform").limit == MAX_DISPLACEMENT_M
    # the pull's limit is what its scenario accepts: a motor travel of the limit passes, more fails
    pull = Scenario(perturbation="pull")
    lim = paradigm_lattice("pull").limit
    Scenario.from_dict({**pull.to_dict(), **of(pull).sized(pull, lim, 0.0)})
    with pytest.raises(BipedError, match="pull_displacement_m"):
        Scenario.from_dict({**pull.to_dict(), **of(pull).sized(pull, lim * 1.01, 0.0)})


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--perturbation", "force", "--max", "2e5"], "--max must be at most 100000 N"),
        (["--perturbation", "platform", "--max", "1.5"], "--max must be at most 1 m"),
        (["--perturbation", "release", "--max", "50"], "--max must be at most 45 deg"),
        (["--perturbation", "pull", "--max", "2.5"], "--max must be at most 2 m"),
        (["--perturbation", "platform", "--resolution", "0.03"], "whole number of --resolution steps"),
        (["--perturbation", "force", "--mass", "3"], "block_mass_kg is the block's"),
        (["--perturbation", "wind"], "invalid choice"),
        (["--perturbation", "platform", "--by", "impulse_n_s"], "--by impulse_n_s has no values"),
        (["--perturbation", "force", "--by", "speed_m_s"], "valid: magnitude, horizontal_impulse_n_s"),
    ],
)
def test_envelope_paradigm_bad_input_is_one_line_and_exit_2(tmp_path, capsys, argv, message):
    try:
        code = main(["envelope", "--dry-run", "--out", str(tmp_path / "e.parquet"), *argv])
    except SystemExit as exc:  # argparse's own choices
        code = exc.code
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert message in err
    if "invalid choice" not in message:
        assert len(err.splitlines()) == 1


def test_hofs_bound_is_the_bipeds_whatever_the_paradigm():
    """The platform's 1000 kg slab (and the parked block) are not the body: Hof's bound of a
    platform scenario is the block scenario's (same biped, same stance), its mass the biped's."""
    from biped.analysis.feet_in_place import feet_in_place_bound
    from biped.sim.sweep import hold_scenario

    base = hold_scenario().with_overrides(physics="fast")
    block = feet_in_place_bound([0.0, 90.0, 180.0], base)
    platform = feet_in_place_bound([0.0, 90.0, 180.0], base.with_overrides(perturbation="platform"))
    assert platform.mass_kg == pytest.approx(block.mass_kg) and block.mass_kg < 200.0
    assert platform.j_max_n_s == pytest.approx(block.j_max_n_s)


def test_sweep_refine_bisects_a_paradigms_magnitude(tmp_path):
    """`biped sweep --perturbation force --refine V`: the grid's two sizes, then the bisection
    between them on the V lattice of the magnitude axis; the file's rows say the refined limit
    is a survivor one step below a failure."""
    out = tmp_path / "r.parquet"
    argv = ["sweep", "--perturbation", "force", "--magnitude", "50,4050", "--direction", "90",
            "--refine", "2000", "--duration", "0.6", "--set", "force_duration_s=0.05",
            "--distribution", "qp", "--workers", "1", "--quiet", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    table = load(out).table
    got = dict(zip(table.column("magnitude").to_pylist(), (bool(v) for v in survived(table)), strict=True))
    assert set(got) <= {50.0, 2050.0, 4050.0} and {50.0, 4050.0} <= set(got)
    assert got[50.0] and not got[4050.0]  # the grid brackets the limit
    assert 2050.0 in got  # the bisection tried the size between them
