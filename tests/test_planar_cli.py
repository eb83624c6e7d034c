"""``biped posture``: outputs and error handling (the numbers are checked in the other tests)."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from biped.cli import main
from biped.planar import analysis as an
from biped.planar import body_leg as bl


def _csv_header(path):
    with open(path) as fh:
        return next(csv.reader(fh))


def test_body_leg_outputs(tmp_path):
    out = tmp_path / "bl"
    rc = main(["posture", "body-leg", "--method", "newton-euler", "--duration", "0.3",
               "--out", str(out)])  # fmt: skip
    assert rc == 0
    summary = json.loads((out / "summary.json").read_text())
    expected = an.analyze_body_leg(bl.BodyLegParams(), (25000, 2500, 40000, 400))
    np.testing.assert_allclose(summary["eigenvalues"], expected.eigenvalue_pairs(), rtol=1e-12)
    assert summary["stable"] is True and summary["parameters"]["I"] == 100.0
    assert "lb" in summary["units"] and "ft" in summary["units"]
    header = _csv_header(out / "trajectory.csv")
    assert header[:5] == ["time", "theta1", "theta1_dot", "theta2", "theta2_dot"]
    assert {"F", "F_r"} <= set(header)
    data = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)
    assert data.shape == (31, len(header))
    for name in ("body_attitude.png", "leg_angle.png", "animation.gif"):
        assert (out / name).stat().st_size > 1000


def test_pendulum_outputs_and_compare(tmp_path):
    out = tmp_path / "p"
    assert main(["posture", "pendulum", "--method", "lagrange", "--duration", "1", "--no-animation",
                 "--out", str(out)]) == 0  # fmt: skip
    assert _csv_header(out / "trajectory.csv")[:3] == ["time", "theta", "theta_dot"]
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["eigenvalues"]) == 2 and summary["gains"] == [10000.0, 2000.0]
    out2 = tmp_path / "c"
    assert main(["posture", "body-leg", "--compare", "--duration", "0.5", "--no-animation",
                 "--out", str(out2)]) == 0  # fmt: skip
    comp = json.loads((out2 / "comparison.json").read_text())
    assert comp["max_abs_difference_vs_lagrange"]["newton-euler"]["theta2"] < 1e-10


def test_gains_outputs(tmp_path):
    out = tmp_path / "g"
    assert main(["posture", "gains", "--grid", "6", "--out", str(out)]) == 0
    res = json.loads((out / "gains.json").read_text())
    assert set(res["bediz_gains"]) == {"B eq. 3.81-3.84 (K2 = 4000)", "B eq. 5.5-5.8 (K2 = 40000)"}
    assert res["best_local_gains"]["stability_margin"] > 1.0
    A, B = np.array(res["A"]), np.array(res["B"])
    K = np.array(res["pole_placement"]["K"])
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(A + B @ K).real),
                               np.sort(res["pole_placement"]["poles"]), rtol=1e-6)  # fmt: skip
    assert np.load(out / "stability_map.npz")["margin"].shape == (6, 6)
    assert (out / "stability_map.png").exists()


def test_bad_input_gets_clear_errors(tmp_path, capsys):
    assert main(["posture", "body-leg", "--param", "mass=3", "--out", str(tmp_path)]) == 2
    assert "unknown parameter 'mass'; valid parameters: 'I', 'g', 'l', 'm', 'r'" in capsys.readouterr().err
    assert main(["posture", "pendulum", "--x0", "nan", "0", "--out", str(tmp_path)]) == 2
    assert "must be finite" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["posture", "body-leg", "--method", "kane"])
    assert exc.value.code == 2
    assert "invalid choice: 'kane'" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("argv", "shows"),
    [
        (["posture"], ["biped posture: Bediz's planar postural models"]),
        (["posture", "pendulum"], ["--x0 TH THD", "--alpha A ", "--dt S", "single-link inverted pendulum"]),
        (["posture", "body-leg"], ["--x0 T1 T1D T2 T2D", "--alpha A1 A2", "body on a massless leg"]),
        (["posture", "gains"], ["--grid N", "--k1-max K", "body-leg parameter override", "(default 60000)"]),
    ],
)
def test_posture_help_names_the_values_each_option_takes(capsys, argv, shows):
    """--help shows the overview's names for the values (TH THD, not X0 X0), a line on what each
    model is, and no reStructuredText quotes."""
    with pytest.raises(SystemExit):
        main([*argv, "--help"])
    out = capsys.readouterr().out
    assert "``" not in out
    for s in shows:
        assert s in out, (s, out)
