"""`biped envelope` and early stop.

- The search (bracket, bisection, check trials) against synthetic oracles whose limits are known:
  every monotone limit on small lattices from every start, and non-monotone ones (a hole below
  the limit): the reported limit is never above a failure the search saw.
- The envelope runner on a closed-form plant (no physics): the limits equal the plant's, the
  trials are rows of a sweep file, a rerun reuses them, local workers give the same answer.
- Early stop on real trials: the outcome equals the full-length run's, the stop is earlier.
- The command's bad inputs: one line, exit 2, before any work.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from biped.cli import main
from biped.sim.sweep import SweepSpec, hold_scenario, load
from biped.sim.sweep.envelope import lattice, run_envelope
from biped.sim.sweep.record import row_survived
from biped.sim.sweep.search import search


def _run(n, ok, **kw):
    gen = search(n, **kw)
    i = next(gen)
    asked = []
    try:
        while True:
            asked.append(i)
            i = gen.send(ok(i))
    except StopIteration as stop:
        return stop.value, asked


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8, 13, 96])
def test_bisection_finds_every_monotone_limit_from_every_start(n):
    starts = [None, *sorted({0, n // 3, n - 1})]
    for limit in range(-1, n):
        for start in starts:
            r, asked = _run(n, lambda i, L=limit: i <= L, start=start, checks=3)
            assert (r.limit, r.first_fail, r.non_monotone) == (limit, limit + 1, False)
            assert len(asked) == len(set(asked))  # never the same size twice
            # bracket + bisection: O(log n), plus the checks
            assert len(asked) <= 2 * math.ceil(math.log2(n + 1)) + 3 + 3


def test_non_monotone_survival_is_reported_with_the_lowest_failure():
    # survives up to 40 except a hole at 37-38: the checks (38, 36, 32: 2, 4, 8 steps below 40)
    # find it at 38
    r, asked = _run(96, lambda i: i <= 40 and i not in (37, 38), checks=3)
    assert r.non_monotone and r.first_limit == 40 and r.check_failures == 1
    assert r.limit == 36 and r.first_fail == 37  # the bisection ran again below the failure
    tried_fail = [i for i, ok in r.tried.items() if not ok]
    assert r.limit < min(tried_fail)  # never above a failure it saw
    # a hole the checks miss is not claimed: the limit is the boundary the search saw
    r, _ = _run(96, lambda i: i <= 40 and i != 20, checks=3)
    assert r.limit == 40 and not r.non_monotone
    # random holes: the limit is always below every failure tried, and survived where tried
    rng = np.random.default_rng(0)
    for _ in range(200):
        n = int(rng.integers(2, 60))
        holes = set(rng.integers(0, n, 3).tolist())
        top = int(rng.integers(-1, n))
        r, _ = _run(n, lambda i, t=top, h=holes: i <= t and i not in h, checks=int(rng.integers(0, 5)))
        fails = [i for i, ok in r.tried.items() if not ok]
        assert r.first_fail == (min(fails) if fails else n)
        assert r.limit < r.first_fail
        assert r.limit == -1 or r.tried[r.limit]


def test_search_input_errors():
    with pytest.raises(ValueError, match="at least one size"):
        next(search(0))
    with pytest.raises(ValueError, match="checks"):
        next(search(5, checks=-1))


# ---------------------------------------------------------------------------------------------
# the runner on a closed-form plant


def plant_limit(direction_deg: float) -> float:
    """The closed-form plant's limit [m/s]: 4 + 2 cos(direction)."""
    return round(4.0 + 2.0 * math.cos(math.radians(direction_deg)), 9)


def plant_trial(setup) -> dict:
    t = setup.trial
    hole = t.direction_deg == 180.0 and t.speed_m_s == 1.0  # a fall inside the envelope at 180 deg
    fell = t.speed_m_s > plant_limit(t.direction_deg) or hole
    return {"impulse_n_s": 2.16 * t.speed_m_s, "completed": not fell, "fell": fell}


def _spec(dirs=(0.0, 90.0, 180.0, 270.0)):
    return SweepSpec(axes={"speed_m_s": lattice(0.5, 8.0, 0.5), "direction_deg": dirs})


def test_envelope_runner_finds_the_plant_limits_and_resumes(tmp_path):
    out = tmp_path / "env.parquet"
    run = run_envelope(_spec(), out, trial_fn=plant_trial, workers=1, checks=3)
    got = {d.direction_deg: d for d in run.directions}
    assert got[0.0].limit == 6.0 and got[0.0].first_fail == 6.5
    assert got[90.0].limit == 4.0 and got[270.0].limit == 4.0
    # 180 deg: limit 2 m/s, but the check trials find the fall at 1 m/s below it
    assert got[180.0].non_monotone and got[180.0].first_limit == 2.0
    assert got[180.0].first_fail == 1.0 and got[180.0].limit == 0.5
    data = load(out)  # a sweep file: the rows of the trials the searches ran, nothing else
    assert data.table.num_rows == run.ran == sum(d.n_trials for d in run.directions)
    assert run.ran < 4 * 16 / 2
    again = run_envelope(_spec(), out, trial_fn=plant_trial, workers=1, checks=3)
    assert again.ran == 0 and again.reused == run.ran
    assert [d.limit for d in again.directions] == [d.limit for d in run.directions]


def test_envelope_on_local_workers_gives_the_same_limits(tmp_path):
    one = run_envelope(_spec(), tmp_path / "a.parquet", trial_fn=plant_trial, workers=1)
    two = run_envelope(_spec(), tmp_path / "b.parquet", trial_fn=plant_trial, workers=2)
    assert two.backend == "processes:2"
    assert [(d.limit, d.first_fail, d.n_trials) for d in one.directions] == [
        (d.limit, d.first_fail, d.n_trials) for d in two.directions
    ]


def bouncing_block_trial(setup) -> dict:
    """The closed-form plant's outcome, its block measured as a sweep trial measures it
    (``ballistic_impulse`` of the block's velocity at 500 Hz): mass m, the trial's speed v along
    its direction, horizontal, falling; the hit at 0.05 s stops it along the floor and adds v / 2
    up. Its momentum change: m v horizontal, m v / 2 vertical."""
    from biped.sim.sweep.record import Measured
    from biped.sim.sweep.trial import ballistic_impulse

    t = setup.trial
    a = math.radians(t.direction_deg)
    times = np.arange(0.0, 0.1, 0.002)
    g = np.array([0.0, 0.0, -9.81])
    hit = times >= 0.05
    v = t.speed_m_s
    vel = np.where(hit[:, None], [0.0, 0.0, 0.5 * v], [v * math.cos(a), v * math.sin(a), 0.0]) + np.outer(
        times, g
    )
    J, _ = ballistic_impulse(times, vel, t.block_mass_kg, gravity=g)
    fell = t.speed_m_s > plant_limit(t.direction_deg)
    return Measured(
        impulse_n_s=float(np.linalg.norm(J)), horizontal_impulse_n_s=float(np.hypot(J[0], J[1])),
        completed=not fell, fell=fell,
    ).row()  # fmt: skip


def test_the_tables_impulse_is_the_horizontal_one_hofs_bound_is_on(tmp_path):
    """Hof's J_max bounds the horizontal momentum (the extrapolated COM moves in the floor's
    plane): the envelope's impulse, COM velocity change and % J_max of a block that also sends
    the body's momentum up are m v, m v / M and 100 m v / J_max (v the limit speed), not the
    whole momentum change's sqrt(5) / 2 m v."""
    from biped.analysis.envelope_table import envelope_table

    out = tmp_path / "env.parquet"
    table = envelope_table(run_envelope(_spec(), out, trial_fn=bouncing_block_trial, workers=1, checks=0))
    rows = {(r["direction_deg"], r["speed_m_s"]): r for r in load(out).table.to_pylist()}
    for r in table.rows:
        assert r.limit == plant_limit(r.direction_deg)
        limit_row = rows[(r.direction_deg, r.limit)]
        j = limit_row["block_mass_kg"] * r.limit  # the closed form
        assert limit_row["impulse_n_s"] == pytest.approx(math.sqrt(1.25) * j, rel=1e-9)  # with the vertical
        assert r.impulse_n_s == pytest.approx(j, rel=1e-9)
        assert r.delta_v_m_s == pytest.approx(j / table.body_mass_kg, rel=1e-9)
        assert r.percent_j_max == pytest.approx(100.0 * j / r.j_max_n_s, rel=1e-9)


def test_row_survived_agrees_with_the_table_rule(tmp_path):
    from biped.analysis import survived

    out = tmp_path / "env.parquet"
    run_envelope(_spec(), out, trial_fn=plant_trial, workers=1)
    table = load(out).table
    assert [row_survived(r) for r in table.to_pylist()] == survived(table).tolist()


# ---------------------------------------------------------------------------------------------
# early stop on real trials


def test_early_stop_keeps_the_outcome_of_real_trials():
    from biped.sim.sweep.trial import run_trial

    rows = {}
    for es in (False, True):
        base = hold_scenario().with_overrides(physics="fast", distribution="qp", early_stop=es)
        spec = SweepSpec(axes={"speed_m_s": (4.0, 20.0), "direction_deg": (90.0,)}, base=base)
        rows[es] = [run_trial(spec.setup(t)) for t in spec.trials()]
    for full, early in zip(rows[False], rows[True], strict=True):
        assert row_survived(full) == row_survived(early)
        assert (full["recovered"], full["fell"]) == (early["recovered"], early["fell"])
    recovered_full, recovered_early = rows[False][0], rows[True][0]
    assert recovered_full["recovered"] and recovered_full["stop_reason"] is None
    assert recovered_early["stop_reason"] == "at_rest" and recovered_early["completed"]
    assert recovered_early["stopped_at_s"] < 2.5 and recovered_full["simulated_time_s"] == 3.0
    assert recovered_early["final_com_error_m"] < 0.01  # inside half the 2 cm tolerance
    fell = rows[True][1]
    assert fell["fell"] and fell["stop_reason"] == "fell"


def test_early_stop_is_off_for_push_and_left_out_of_its_scenario():
    from biped.sim.scenario import Scenario

    assert Scenario().early_stop is False
    assert "early_stop" not in Scenario().to_dict()  # biped push's summary.json as before
    s = Scenario(early_stop=True)
    assert Scenario.from_dict(s.to_dict()) == s
    from biped.errors import ScenarioError

    with pytest.raises(ScenarioError, match="early_stop must be true or false"):
        Scenario(early_stop="yes")


# ---------------------------------------------------------------------------------------------
# the command's bad inputs


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--directions", "0,x"], "--directions must be a count"),
        (["--directions", "0"], "--directions N must be from 1"),
        (["--directions", "0,90,0"], "twice"),
        (["--resolution", "0.3", "--max", "1"], "whole number of --resolution steps"),
        (["--max", "0.1", "--min", "1"], "--max (0.1) must be >= --min"),
        (["--resolution", "-1"], "--resolution must be a number > 0"),
        (["--checks", "-1"], "--checks must be from 0 to 20"),
        (["--start", "99"], "--start must be between"),
        (["--json", "x.txt"], "--json must name a .json file"),
        (["--out", "x.csv"], "--out must name a .parquet file"),
        (["--set", "early_stop=3"], "early_stop must be true or false"),
    ],
)
def test_envelope_bad_input_is_one_line_and_exit_2(tmp_path, capsys, argv, message):
    code = main(["envelope", "--dry-run", "--out", str(tmp_path / "e.parquet"), *argv])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert message in err and len(err.splitlines()) == 1


def test_early_stop_stops_the_compiled_and_the_python_loop_at_the_same_row():
    from biped.sim.push import run_closed_loop
    from biped.sim.sweep.trial import _scene_for, make_policy

    base = hold_scenario().with_overrides(physics="fast", distribution="qp", early_stop=True)
    spec = SweepSpec(axes={"speed_m_s": (6.0,), "direction_deg": (180.0,)}, base=base)
    setup = spec.setup(spec.trials()[0])
    scene = _scene_for(setup.scenario)
    runs = [
        run_closed_loop(setup.scenario, scene, make_policy(setup, scene), compiled=c) for c in (True, False)
    ]
    assert runs[0].stop_reason == runs[1].stop_reason == "at_rest"
    assert len(runs[0].times) == len(runs[1].times) < 1501
    np.testing.assert_array_equal(runs[0].qpos, runs[1].qpos)


def test_sweep_refine_bisects_between_the_grids_survivor_and_failure(tmp_path):
    """`biped sweep --refine`: the coarse grid first (every size, every direction), then the
    bisection between each direction's last survivor and first failure on the fine lattice."""
    coarse = (1.0, 3.0, 5.0, 7.0)
    fine = lattice(1.0, 7.0, 0.25)
    spec = SweepSpec(axes={"speed_m_s": fine, "direction_deg": (0.0, 90.0, 180.0)})
    run = run_envelope(spec, tmp_path / "r.parquet", trial_fn=plant_trial, workers=1, checks=0, grid=coarse)
    got = {d.direction_deg: d for d in run.directions}
    # plant: 6 m/s at 0 deg, 4 at 90, 2 at 180 with a fall at 1 m/s (the grid's first size)
    assert (got[0.0].limit, got[0.0].first_fail) == (6.0, 6.25)
    assert (got[90.0].limit, got[90.0].first_fail) == (4.0, 4.25)
    assert math.isnan(got[180.0].limit) and got[180.0].first_fail == 1.0  # the grid's first size fell
    for d in run.directions:  # every grid size ran, then at most log2(8) bisection steps
        assert set(coarse) <= set(d.rows) and len(d.rows) <= len(coarse) + 3


def test_sweep_refine_input_errors(tmp_path, capsys):
    base = ["sweep", "--dry-run", "--out", str(tmp_path / "s.parquet"), "--direction", "0,90"]
    assert main([*base, "--speed", "1:7:4", "--refine", "0.35"]) == 2
    assert "--refine 0.35 must divide" in capsys.readouterr().err
    assert main([*base, "--speed", "1,2,4", "--refine", "0.75"]) == 2
    assert "not on the lattice" in capsys.readouterr().err
    assert main([*base, "--speed", "1:7:4", "--samples", "5", "--refine", "0.5"]) == 2
    assert "--refine needs a grid" in capsys.readouterr().err
    assert main([*base, "--speed", "1:7:4", "--refine", "0.5"]) == 0
