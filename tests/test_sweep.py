"""`biped sweep` machinery: grid, aiming, one Parquet file, resume after Ctrl-C / a killed worker /
a crashed trial, local processes.

Trials here are a toy closed-form plant (:func:`toy_trial`) so that the storage and scheduling are
tested in milliseconds; the real push simulation is exercised in ``test_sweep_physics.py`` and
``test_sweep_dask.py``.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tomllib

import mujoco
import numpy as np
import pyarrow.parquet as pq
import pytest

import biped
from biped import models
from biped.errors import ScenarioError
from biped.sim.scenario import Scenario
from biped.sim.sweep import (
    AXES,
    SweepSpec,
    TrialSetup,
    aim_block,
    load,
    parse_axis,
    parts_dir,
    run_sweep,
)
from biped.sim.sweep.store import part_files, read_part

GRID = {"speed_m_s": (1.0, 3.0, 5.0), "direction_deg": (0.0, 90.0, 180.0, 270.0)}


def toy_trial(setup: TrialSetup) -> dict:
    """A closed-form stand-in for a push: the block's momentum (1 + e) m v reaches the body and
    it falls beyond 15 N s."""
    t = setup.trial
    j = 1.2 * t.block_mass_kg * t.speed_m_s
    a = math.radians(t.direction_deg)
    return {
        "recovered": j <= 15.0,
        "fell": j > 15.0,
        "impulse_n_s": j,
        "impulse_x_n_s": j * math.cos(a),
        "impulse_y_n_s": j * math.sin(a),
        "completed": True,
    }


def crashing_trial(setup: TrialSetup) -> dict:
    if setup.trial.index == 3:
        raise FloatingPointError("toy plant diverged")
    _log(setup)
    return toy_trial(setup)


def _log(setup):
    path = os.environ.get("BIPED_TEST_SWEEP_LOG")
    if path:
        with open(path, "a") as f:
            f.write(f"{setup.trial.index}\n")


def logging_trial(setup: TrialSetup) -> dict:
    _log(setup)
    return toy_trial(setup)


_calls = {"n": 0}


def interrupting_trial(setup: TrialSetup) -> dict:
    """Ctrl-C arrives during the 5th trial."""
    _calls["n"] += 1
    if _calls["n"] == 5:
        raise KeyboardInterrupt
    return toy_trial(setup)


def killing_trial(setup: TrialSetup) -> dict:
    """The worker running trial 2 dies the first time (as if OOM-killed)."""
    marker = os.environ["BIPED_TEST_SWEEP_MARKER"]
    if setup.trial.index == 2 and not os.path.exists(marker):
        open(marker, "w").close()
        os._exit(1)
    return toy_trial(setup)


def _logged(path) -> list[int]:
    return [int(x) for x in open(path).read().split()] if os.path.exists(path) else []


# ---------------------------------------------------------------------------------------------


def test_grid_is_the_product_direction_fastest_with_stable_keys():
    spec = SweepSpec(axes=GRID)
    trials = spec.trials()
    assert len(trials) == 12
    assert [(t.speed_m_s, t.direction_deg) for t in trials[:5]] == [
        (1.0, 0.0),
        (1.0, 90.0),
        (1.0, 180.0),
        (1.0, 270.0),
        (3.0, 0.0),
    ]
    assert {t.block_mass_kg for t in trials} == {1.8} and {t.height_m for t in trials} == {1.2}
    keys = [t.key for t in trials]
    assert len(set(keys)) == 12 and keys == [t.key for t in SweepSpec(axes=GRID).trials()]
    # another base scenario is another experiment: other keys
    other = SweepSpec(axes=GRID, base=Scenario(duration_s=1.0)).trials()
    assert not set(keys) & {t.key for t in other}


def test_random_sample_is_reproducible_and_within_the_ranges():
    spec = SweepSpec(axes={"speed_m_s": (1.0, 6.0), "direction_deg": (0.0, 360.0)}, samples=50, seed=3)
    a, b = spec.trials(), SweepSpec(**{**spec.__dict__, "axes": dict(spec.axes)}).trials()
    assert [t.key for t in a] == [t.key for t in b]
    speeds = np.array([t.speed_m_s for t in a])
    assert speeds.min() >= 1.0 and speeds.max() <= 6.0 and speeds.std() > 0.5


def test_axis_syntax_and_errors():
    assert parse_axis("speed_m_s", "1:3:3") == (1.0, 2.0, 3.0)
    assert parse_axis("direction_deg", "0,90") == (0.0, 90.0)
    with pytest.raises(ScenarioError, match="START:STOP:NUM"):
        parse_axis("speed_m_s", "1:2")
    with pytest.raises(ScenarioError, match="valid axes: " + ", ".join(AXES)):
        SweepSpec(axes={"sped": (1.0,)})
    with pytest.raises(ScenarioError, match="speed_m_s .* must be > 0"):
        SweepSpec(axes={"speed_m_s": (0.0, 1.0)})
    with pytest.raises(ScenarioError, match="torque_limits must be one of 'none', 'human'"):
        SweepSpec(torque_limits="robot")


def test_sweep_toml_file(tmp_path):
    f = tmp_path / "sweep.toml"
    f.write_text(
        'samples = 4\nseed = 1\ntorque_limits = "human"\n'
        "[grid]\nspeed_m_s = {start = 1.0, stop = 2.0, num = 3}\ndirection_deg = [0, 180]\n"
        '[scenario]\nduration_s = 0.5\ncontroller = "joint-pd"\n'
    )
    spec = SweepSpec.from_toml(f)
    assert dict(spec.axes)["speed_m_s"] == (1.0, 1.5, 2.0)
    assert spec.base.duration_s == 0.5 and spec.base.controller == "joint-pd"
    assert spec.samples == 4 and spec.torque_limits == "human"
    f.write_text("[grid]\nspeed = [1]\n")
    with pytest.raises(ScenarioError, match="unknown sweep axis 'speed'"):
        SweepSpec.from_toml(f)


def test_aimed_block_passes_through_the_aim_point_in_mujoco():
    """Oracle: MuJoCo integrates a free box from the start state given by aim_block; it must cross
    the aim line at the aim height."""
    target, speed, direction, height, L = (0.03, -0.02), 2.0, 135.0, 1.1, 0.5
    p0, v0 = aim_block(target, speed, direction, height, L)
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><option timestep="0.0001" gravity="0 0 -9.81"/><worldbody><body name="b">'
        '<freejoint/><geom type="box" size=".05 .05 .05" mass="1.8" contype="0" conaffinity="0"/>'
        "</body></worldbody></mujoco>"
    )
    data = mujoco.MjData(model)
    data.qpos[:3], data.qvel[:3] = p0, v0
    steps = round(L / speed / model.opt.timestep)
    mujoco.mj_step(model, data, steps)
    np.testing.assert_allclose(data.qpos[:3], [*target, height], atol=2e-4)
    u = np.array(v0[:2]) / np.hypot(*v0[:2])
    np.testing.assert_allclose(u, [math.cos(math.radians(direction)), math.sin(math.radians(direction))])


# ---------------------------------------------------------------------------------------------
# storage


def test_serial_sweep_writes_one_parquet_file_with_metadata(tmp_path):
    out = tmp_path / "s.parquet"
    spec = SweepSpec(axes=GRID, base=Scenario(duration_s=0.5))
    summary = run_sweep(spec, out, workers=1, trial_fn=toy_trial, progress=False)
    assert summary.complete and summary.ran == 12 and summary.failed == 0
    assert out.is_file() and not parts_dir(out).exists()
    pf = pq.ParquetFile(out)
    assert pf.metadata.num_rows == 12
    meta = pf.schema_arrow.metadata
    path = models.path("wendlandt")
    assert meta[b"biped.model_sha256"].decode() == hashlib.sha256(path.read_bytes()).hexdigest()
    assert meta[b"biped.version"].decode() == biped.__version__
    assert Scenario.from_dict(tomllib.loads(meta[b"biped.scenario"].decode())) == spec.base
    data = load(out)
    assert data.column("index").tolist() == list(range(12))
    np.testing.assert_allclose(data.column("impulse_n_s"), 1.2 * 1.8 * data.column("speed_m_s"))
    assert json.loads(meta[b"biped.sweep"])["grid"]["speed_m_s"] == [1.0, 3.0, 5.0]
    # a rerun of the same command has nothing to do
    again = run_sweep(spec, out, workers=1, trial_fn=toy_trial, progress=False)
    assert again.skipped == 12 and again.ran == 0 and pq.ParquetFile(out).metadata.num_rows == 12


def test_crashed_trial_is_recorded_with_its_error_and_retried_on_request(tmp_path, monkeypatch):
    log = tmp_path / "log"
    monkeypatch.setenv("BIPED_TEST_SWEEP_LOG", str(log))
    out = tmp_path / "s.parquet"
    spec = SweepSpec(axes=GRID)
    summary = run_sweep(spec, out, workers=1, trial_fn=crashing_trial, progress=False)
    assert summary.complete and summary.failed == 1
    data = load(out)
    errors = data.table.column("error").to_pylist()
    assert errors[3] == "FloatingPointError: toy plant diverged"
    assert all(e is None for i, e in enumerate(errors) if i != 3)
    assert data.table.column("recovered").to_pylist()[3] is None
    # a plain rerun skips it (it is a result), --retry-failed runs only it
    log.unlink()
    run_sweep(spec, out, workers=1, trial_fn=logging_trial, progress=False)
    assert _logged(log) == []
    run_sweep(spec, out, workers=1, trial_fn=logging_trial, progress=False, retry_failed=True)
    assert _logged(log) == [3]
    assert load(out).table.column("error").to_pylist() == [None] * 12


def test_ctrl_c_keeps_finished_trials_and_a_rerun_finishes_the_rest(tmp_path, monkeypatch):
    out = tmp_path / "s.parquet"
    spec = SweepSpec(axes=GRID)
    _calls["n"] = 0
    with pytest.raises(KeyboardInterrupt):
        run_sweep(spec, out, workers=1, trial_fn=interrupting_trial, progress=False)
    assert not out.exists()
    parts = part_files(parts_dir(out))
    assert sum(read_part(p).num_rows for p in parts) == 4
    log = tmp_path / "log"
    monkeypatch.setenv("BIPED_TEST_SWEEP_LOG", str(log))
    summary = run_sweep(spec, out, workers=1, trial_fn=logging_trial, progress=False)
    assert summary.skipped == 4 and summary.ran == 8 and summary.complete
    assert _logged(log) == list(range(4, 12))
    data = load(out)
    assert data.column("index").tolist() == list(range(12))
    assert len(set(data.table.column("trial_key").to_pylist())) == 12


def test_killed_worker_loses_no_finished_trial(tmp_path, monkeypatch):
    """Two spawned worker processes; one dies mid-trial. Finished trials are kept, the sweep says
    it is incomplete, and the same command then finishes it."""
    monkeypatch.setenv("BIPED_TEST_SWEEP_MARKER", str(tmp_path / "killed"))
    out = tmp_path / "s.parquet"
    spec = SweepSpec(axes=GRID)
    first = run_sweep(spec, out, workers=2, trial_fn=killing_trial, progress=False)
    assert not first.complete and first.lost >= 1 and not out.exists()
    assert first.ran + first.lost == 12
    second = run_sweep(spec, out, workers=1, trial_fn=killing_trial, progress=False)
    assert second.complete and second.skipped == first.ran and second.ran == first.lost
    assert load(out).column("index").tolist() == list(range(12))


def test_another_sweep_cannot_overwrite_a_file_by_accident(tmp_path):
    out = tmp_path / "s.parquet"
    run_sweep(SweepSpec(axes=GRID), out, workers=1, trial_fn=toy_trial, progress=False)
    other = SweepSpec(axes=GRID, base=Scenario(friction=0.5))
    with pytest.raises(ScenarioError, match="different sweep.*--overwrite"):
        run_sweep(other, out, workers=1, trial_fn=toy_trial, progress=False)
    s = run_sweep(other, out, workers=1, trial_fn=toy_trial, progress=False, overwrite=True)
    assert s.ran == 12 and load(out).scenario.friction == 0.5
    with pytest.raises(ScenarioError, match=r"\.parquet"):
        run_sweep(other, tmp_path / "s.csv", trial_fn=toy_trial)
