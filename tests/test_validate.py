"""``biped validate --quick`` runs end to end and writes what it says; its table's rule is checked
against numbers it did not compute (the human band of the paper, by hand)."""

from __future__ import annotations

import json

import pyarrow.parquet as pq

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
    assert "young" in (out / "validation.md").read_text()
    assert (out / "figures" / "ankle_release.png").stat().st_size > 1000
    assert any("not_run" in r for r in data["rows"])  # the one-step release, said


def test_validate_rejects_an_unknown_experiment(tmp_path, capsys):
    assert main(["validate", "--quick", "--experiment", "stairs", "--out", str(tmp_path / "x")]) == 2
    assert "experiment" in capsys.readouterr().err
