"""`biped sweep` on the command line, and the envelope plot."""

from __future__ import annotations

import numpy as np
import pytest
from _helpers import tiny_sweep_argv, toy_trial

from biped.analysis import feet_in_place_bound
from biped.cli import main
from biped.sim.sweep import load


def test_cli_runs_a_tiny_sweep_and_plots_it(tmp_path, capsys):
    out, png = tmp_path / "s.parquet", tmp_path / "env.png"
    grid = tmp_path / "g.toml"
    grid.write_text(
        "[grid]\nspeed_m_s = [3.0]\ndirection_deg = [0, 120, 240]\n[scenario]\nduration_s = 0.04\n"
    )
    rc = main(
        [
            "sweep",
            "--grid",
            str(grid),
            "--speed",
            "2,4",
            "--controller",
            "joint-pd",
            "--torque-limits",
            "human",
            "--workers",
            "1",
            "--quiet",
            "--out",
            str(out),
            "--task",
            "hold",
            "--plot",
            str(png),
        ]
    )
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
    assert main(tiny_sweep_argv(out, direction="0,180")) == 0
    ax = plot_envelope(out, by="impulse_n_s")
    (line,) = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
    theta, r = line.get_data()
    b = feet_in_place_bound(np.degrees(theta[:-1]), load(out).scenario)
    np.testing.assert_allclose(r[:-1], b.j_max_n_s)


# ---------------------------------------------------------------------------------------------
# the envelope plot: what a reader must be able to see


def _toy_sweep(tmp_path, name, **base):
    """A sweep file of :func:`toy_trial` rows over 3 speeds x 8 directions of ``Scenario(**base)``."""
    from biped.sim.scenario import Scenario
    from biped.sim.sweep import SweepSpec, run_sweep

    out = tmp_path / name
    spec = SweepSpec(
        axes={"speed_m_s": (2.0, 4.0, 6.0), "direction_deg": tuple(range(0, 360, 45))},
        base=Scenario(**base),
    )
    run_sweep(spec, out, workers=1, trial_fn=toy_trial, progress=False)
    return out


#: the toy block's hit below the horizontal [deg]: its impulse has a vertical part
_DOWN_DEG = 30.0


def _downward_trial(setup) -> dict:
    """:func:`toy_trial`'s block, its momentum 1.2 m v delivered 30 deg below the horizontal along
    its direction of travel: the columns as the sweep's trial writes them (impulse_n_s the 3-D
    norm; horizontal_impulse_n_s the block's hypot(J_x, J_y), biped.sim.sweep.trial)."""
    import math

    t = setup.trial
    j = 1.2 * t.block_mass_kg * t.speed_m_s
    a, down = math.radians(t.direction_deg), math.radians(_DOWN_DEG)
    jx, jy, jz = j * math.cos(down) * math.cos(a), j * math.cos(down) * math.sin(a), -j * math.sin(down)
    return {**toy_trial(setup), "impulse_n_s": j, "impulse_x_n_s": jx, "impulse_y_n_s": jy,
            "impulse_z_n_s": jz, "impulse_horizontal_n_s": math.hypot(jx, jy),
            "horizontal_impulse_n_s": math.hypot(jx, jy), "paradigm": "block"}  # fmt: skip


def test_the_impulse_plot_draws_the_horizontal_impulse_of_the_envelope_table(tmp_path):
    """``--by impulse_n_s``: the radius is the horizontal impulse, as ``biped envelope``'s table's
    (one function, biped.analysis.envelope.horizontal_impulse_n_s), not the 3-D norm: for a block
    that delivers 1.2 m v 30 deg below the horizontal, every dot and the envelope line sit at
    1.2 m v cos 30 deg (closed form), the table's impulse of the same row too; a row written before
    the horizontal column has it from its components."""
    pytest.importorskip("matplotlib")
    import math

    import matplotlib

    matplotlib.use("Agg")
    from biped.analysis.envelope import horizontal_impulse_n_s
    from biped.analysis.envelope_table import _momentum
    from biped.sim.scenario import Scenario
    from biped.sim.sweep import SweepSpec, run_sweep
    from biped.viz.envelope import plot_envelope

    out = tmp_path / "down.parquet"
    speeds, mass = (2.0, 4.0, 6.0), 1.8
    spec = SweepSpec(axes={"speed_m_s": speeds, "direction_deg": tuple(range(0, 360, 45))}, base=Scenario())
    run_sweep(spec, out, workers=1, trial_fn=_downward_trial, progress=False)
    horizontal = {v: 1.2 * mass * v * math.cos(math.radians(_DOWN_DEG)) for v in speeds}
    ax = plot_envelope(out, by="impulse_n_s", bound=False)
    radii = np.concatenate([c.get_offsets()[:, 1] for c in ax.collections if len(c.get_offsets())])
    np.testing.assert_allclose(np.sort(radii), np.sort(np.repeat(list(horizontal.values()), 8)), rtol=1e-12)
    (line,) = [ln for ln in ax.get_lines() if ln.get_label() == "envelope"]
    np.testing.assert_allclose(line.get_data()[1], horizontal[4.0], rtol=1e-12)  # 6 m/s falls
    assert "horizontal" in ax.get_title()
    row = load(out).table.slice(0, 1).to_pylist()[0]
    j, _ = _momentum(row, "block", 70.0)
    assert j == pytest.approx(horizontal[row["speed_m_s"]], rel=1e-12)
    old = {k: v for k, v in row.items() if k != "horizontal_impulse_n_s"}  # a file from before the column
    assert horizontal_impulse_n_s(old) == pytest.approx(horizontal[row["speed_m_s"]], rel=1e-12)


def _boxes_overlap(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def test_envelope_plot_shows_hofs_bound_the_facing_and_no_overlapping_labels(tmp_path):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    from biped.viz.envelope import plot_comparison

    one = _toy_sweep(tmp_path, "a.parquet")
    fig = plot_comparison([one])
    assert len(fig.axes) == 1  # one sweep: no "overlaid" panel repeating it
    ax = fig.axes[0]
    (line,) = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
    theta, r = line.get_data()
    b = feet_in_place_bound(np.degrees(theta[:-1]), load(one).scenario)
    speed = b.j_max_n_s / ((1 + load(one).scenario.restitution) * 1.8)
    np.testing.assert_allclose(r[:-1], speed)
    assert speed.min() < ax.get_ylim()[1]  # drawn inside the axes, not only in the legend
    # no text of the axes overlaps an angle label (the radius's name used to sit on 225 deg)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    angles = [t for t in ax.get_xticklabels() if t.get_text()]
    assert any("225" in t.get_text() for t in angles)
    others = [t for t in [*ax.get_yticklabels(), *ax.texts, ax.title] if t.get_text()]
    for a in angles:
        for o in others:
            assert not _boxes_overlap(a.get_window_extent(renderer), o.get_window_extent(renderer)), (
                a.get_text(),
                o.get_text(),
            )
    text = " ".join(t.get_text() for t in fig.texts)
    assert "faces -x" in text and "180 deg is W's push, from behind" in text
    two = plot_comparison([one, _toy_sweep(tmp_path, "b.parquet", controller="joint-pd")])
    assert len(two.axes) == 3 and two.axes[-1].get_title().startswith("envelopes overlaid")
    assert {ln.get_label() for ln in two.axes[-1].get_lines()} == {"workspace", "joint-pd"}


@pytest.mark.parametrize(
    "argv, grid, physics, step",
    [
        ([], None, "fast", 0.001),  # the sweep's default
        (["--physics", "faithful"], None, "faithful", 0.0005),
        (["--set", "physics_timestep_s=0.00025"], None, "faithful", 0.00025),  # explicit step kept
        ([], "physics_timestep_s = 0.0005\n", "faithful", 0.0005),  # ... also from the file
        ([], 'physics = "faithful"\n', "faithful", 0.0005),
        (["--physics", "fast"], 'physics = "faithful"\n', "fast", 0.001),  # the flag wins
    ],
)
def test_sweep_physics_preset_defaults_to_fast_unless_physics_is_given(tmp_path, argv, grid, physics, step):
    from biped.cli import build_parser
    from biped.cli.sweep import build_spec

    if grid is not None:
        (tmp_path / "g.toml").write_text("[grid]\nspeed_m_s = [3.0]\n[scenario]\n" + grid)
        argv = [*argv, "--grid", str(tmp_path / "g.toml")]
    spec = build_spec(build_parser().parse_args(["sweep", "--speed", "2", *argv]))
    assert (spec.base.physics, spec.base.physics_timestep_s) == (physics, step)


def test_envelope_labels_tell_the_distributions_apart(tmp_path):
    """W's min-norm and the QP are both the workspace controller: the overlay must not call both
    "workspace" (each sweep file's scenario says which distribution it ran)."""
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    from biped.viz.envelope import plot_comparison

    fig = plot_comparison(
        [_toy_sweep(tmp_path, "a.parquet"), _toy_sweep(tmp_path, "b.parquet", distribution="qp")]
    )
    assert {ln.get_label() for ln in fig.axes[-1].get_lines()} == {"workspace", "workspace (qp)"}
    assert fig.axes[1].get_title().startswith("workspace (qp), torque limits")


def test_plot_without_a_file_goes_beside_the_results(tmp_path, capsys):
    """`--plot` alone writes the envelope plot beside the sweep file (its name, .png), so the
    default run lands in runs/ and nothing in the working directory."""
    out = tmp_path / "sub" / "s.parquet"
    assert main(tiny_sweep_argv(out, "--plot", direction="0,180")) == 0
    assert (tmp_path / "sub" / "s.png").stat().st_size > 10_000
    assert f"envelope plot: {tmp_path / 'sub' / 's.png'}" in capsys.readouterr().out
    assert main(tiny_sweep_argv(out, "--compare", str(out))) == 2  # --compare still needs --plot


def test_too_few_directions_for_an_envelope_line_are_said(tmp_path):
    """Two directions draw no envelope line (it joins three or more): each panel, the overlay
    included, says so instead of staying silently empty."""
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    from biped.sim.scenario import Scenario
    from biped.sim.sweep import SweepSpec, run_sweep
    from biped.viz.envelope import plot_comparison

    paths = []
    for name in ("a.parquet", "b.parquet"):
        spec = SweepSpec(axes={"speed_m_s": (2.0, 6.0), "direction_deg": (0.0, 180.0)}, base=Scenario())
        run_sweep(spec, tmp_path / name, workers=1, trial_fn=toy_trial, progress=False)
        paths.append(tmp_path / name)
    fig = plot_comparison(paths)
    assert len(fig.axes) == 3
    for ax in fig.axes:
        said = [t.get_text() for t in ax.texts if "no envelope line" in t.get_text()]
        assert said == ["no envelope line:\n2 directions swept\n(it needs 3 or more)"], ax.get_title()
    fig3 = plot_comparison([_toy_sweep(tmp_path, "c.parquet")])  # 8 directions: a line, no note
    assert not any("no envelope line" in t.get_text() for t in fig3.axes[0].texts)
