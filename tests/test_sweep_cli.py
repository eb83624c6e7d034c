"""`biped sweep` on the command line, and the envelope plot."""

from __future__ import annotations

import numpy as np
import pytest

from biped.cli import main
from biped.sim.sweep import feet_in_place_bound, load


def test_cli_runs_a_tiny_sweep_and_plots_it(tmp_path, capsys):
    out, png = tmp_path / "s.parquet", tmp_path / "env.png"
    grid = tmp_path / "g.toml"
    grid.write_text('[grid]\nspeed_m_s = [3.0]\ndirection_deg = [0, 120, 240]\n'
                    '[scenario]\nduration_s = 0.04\n')
    rc = main(["sweep", "--grid", str(grid), "--speed", "2,4", "--controller", "joint-pd",
               "--torque-limits", "human", "--workers", "1", "--quiet", "--out", str(out),
               "--task", "hold", "--plot", str(png)])
    assert rc == 0 and png.stat().st_size > 10_000
    data = load(out)
    assert data.table.num_rows == 6
    assert set(data.table.column("speed_m_s").to_pylist()) == {2.0, 4.0}
    assert set(data.table.column("torque_limits").to_pylist()) == {"human"}
    assert data.scenario.controller == "joint-pd" and data.scenario.target_com_m == (0.0, 0.0, 1.035)
    assert "6 trials" in capsys.readouterr().out


def test_cli_errors_name_what_is_valid(tmp_path, capsys):
    assert main(["sweep", "--speed", "1:2", "--out", str(tmp_path / "x.parquet")]) == 2
    assert "START:STOP:NUM" in capsys.readouterr().err
    assert main(["sweep", "--compare", "a.parquet"]) == 2
    assert "--compare needs --plot" in capsys.readouterr().err


def test_envelope_plot_draws_hofs_bound(tmp_path):
    """The dashed line of the impulse plot is J_max(direction) of feet_in_place_bound."""
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    from biped.viz.envelope import plot_envelope

    out = tmp_path / "s.parquet"
    assert main(["sweep", "--speed", "3", "--direction", "0,180", "--duration", "0.02",
                 "--controller", "joint-pd", "--workers", "1", "--quiet", "--out", str(out)]) == 0
    ax = plot_envelope(out, by="impulse_n_s")
    (line,) = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
    theta, r = line.get_data()
    b = feet_in_place_bound(np.degrees(theta[:-1]), load(out).scenario)
    np.testing.assert_allclose(r[:-1], b.j_max_n_s)


@pytest.mark.parametrize("argv, grid, physics, step", [
    ([], None, "fast", 0.001),                                           # the sweep's default
    (["--physics", "faithful"], None, "faithful", 0.0005),
    (["--set", "physics_timestep_s=0.00025"], None, "faithful", 0.00025),  # explicit step kept
    ([], "physics_timestep_s = 0.0005\n", "faithful", 0.0005),         # ... also from the file
    ([], 'physics = "faithful"\n', "faithful", 0.0005),
    (["--physics", "fast"], 'physics = "faithful"\n', "fast", 0.001),  # the flag wins
])
def test_sweep_physics_preset_defaults_to_fast_unless_physics_is_given(tmp_path, argv, grid,
                                                                       physics, step):
    from biped.cli import build_parser
    from biped.cli.sweep import build_spec

    if grid is not None:
        (tmp_path / "g.toml").write_text("[grid]\nspeed_m_s = [3.0]\n[scenario]\n" + grid)
        argv = [*argv, "--grid", str(tmp_path / "g.toml")]
    spec = build_spec(build_parser().parse_args(["sweep", "--speed", "2", *argv]))
    assert (spec.base.physics, spec.base.physics_timestep_s) == (physics, step)
