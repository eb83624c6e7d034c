"""The response's rows recorded by the push loop (biped.sim.loop_measures) against MuJoCo's own
forward pass at each recorded state (biped.sim.measure.measure_rows, mj_kinematics), and the
compiled margin of stability (biped.sim.mos) against the Python rule it replaces in sweeps."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from biped.sim import Scenario, build_scene
from biped.sim.loop_measures import LIMB_BODIES, loop_rows
from biped.sim.measure import measure_rows
from biped.sim.mos import margins
from biped.sim.push import controller_policy, run_closed_loop
from biped.sim.response import _margins, _sole_corners, measure_response

RUNS = {  # a push at the pelvis (fast physics), a platform move (faithful), W's block thrown sideways
    "force": dict(
        perturbation="force", physics="fast", distribution="qp", duration_s=0.5, force_n=(-200, 0, 0)
    ),
    "platform": dict(perturbation="platform", physics="faithful", distribution="qp", duration_s=0.5),
    "block": dict(physics="fast", duration_s=0.5, block_velocity_m_s=(-5.0, 2.0, 0.3)),
}


@pytest.fixture(scope="module", params=sorted(RUNS))
def run(request):
    sc = Scenario(**RUNS[request.param])
    scene = build_scene(sc)
    result = run_closed_loop(sc, scene, controller_policy(sc, scene))
    return scene, result, measure_rows(scene, result)


def test_loop_rows_are_mujocos_forward_pass(run):
    """Whole-body COM and its velocity bit for bit MuJoCo's (mj_forward + mj_subtreeVel at the
    row's state); the feet's forces and CoP the constraint solution of the same state, which
    measure_rows solves again from another warm start: equal to the solver's tolerance."""
    scene, result, rows = run
    loop = loop_rows(scene, result)
    assert np.array_equal(loop.whole_body_com, rows.whole_body_com)
    assert np.array_equal(loop.whole_body_com_vel, rows.whole_body_com_vel)
    weight = rows.biped_mass_kg * 9.81
    assert rows.grf[:, :, 2].max() > 0.3 * weight  # the feet carry the body
    np.testing.assert_allclose(loop.grf, rows.grf, rtol=0, atol=1e-4 * weight)
    loaded = rows.grf[:, :, 2] > 0.05 * weight
    assert loaded.sum() > len(result.times)
    assert np.array_equal(np.isnan(loop.cop[loaded]), np.isnan(rows.cop[loaded]))
    np.testing.assert_allclose(loop.cop[loaded], rows.cop[loaded], rtol=0, atol=2e-5)
    # the limbs' frame origins and the trunk's axis: mj_kinematics of the recorded qpos
    m = scene.model
    d = mujoco.MjData(m)
    ids = [m.body(b).id for b in LIMB_BODIES]
    for k in range(0, len(result.times), 37):
        d.qpos[:] = result.qpos[k]
        mujoco.mj_kinematics(m, d)
        assert np.array_equal(loop.limbs[k], d.xpos[ids])
        assert np.array_equal(loop.trunk_z[k], d.xmat[scene.central_body].reshape(3, 3)[:, 2])


def test_the_response_from_the_loop_is_measure_rows_response(run):
    """Every response measure from the loop's rows equals the one from measure_rows: exactly, or
    to 1e-12 (summation order), the CoP excursion to the solver's tolerance (10 um)."""
    scene, result, rows = run
    slow = measure_response(scene, result, rows).to_dict()
    fast = measure_response(scene, result, loop_rows(scene, result)).to_dict()
    for key, want in slow.items():
        got = fast[key]
        if isinstance(want, float):
            tol = 1e-5 if key == "peak_cop_excursion_m" else 1e-12
            assert (math.isnan(want) and math.isnan(got)) or abs(got - want) <= tol, (key, got, want)
        else:
            assert got == want, (key, got, want)


def test_compiled_margins_are_the_python_rule():
    """Random feet poses (turned, lifted, one foot or none on the floor, poses repeating so that
    rows share hulls) and extrapolated COMs inside and outside: the compiled rule's margins are
    the Python rule's."""
    scene = build_scene(Scenario(physics="fast"))
    corners = _sole_corners(scene.model, scene)
    rng = np.random.default_rng(3)
    n = 400
    poses = rng.normal(size=(40, 2, 7)) * [0.15, 0.15, 0.01, 1, 0.1, 0.1, 1]
    pick = rng.integers(0, 40, n)
    feet_pos = poses[pick, :, :3] + [[0, -0.1, 0], [0, 0.1, 0]]
    quat = poses[pick, :, 3:]
    quat /= np.linalg.norm(quat, axis=2, keepdims=True)
    quat[:50] = [1.0, 0.0, 0.0, 0.0]  # MuJoCo's identity shortcut
    on = rng.random((n, 2)) > 0.2
    xi = rng.normal(size=(n, 2)) * 0.2

    class Result:
        pass

    result = Result()
    result.feet_pos, result.feet_quat = feet_pos, quat
    want = _margins(xi, (on[:, 0], on[:, 1]), result, corners, 7)
    got = margins(xi, on, feet_pos, quat, corners, 7)
    assert np.isnan(want[:7]).all() and (np.isnan(want) == np.isnan(got)).all()
    assert np.isfinite(want).sum() > 300 and (want > 0).any() and (want < 0).any()
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-11)


def test_a_block_sweep_row_carries_the_response():
    """A block trial of a sweep (early stop, the sweep's hold task) fills the response's columns,
    the numbers of measure_response on measure_rows (MuJoCo's second pass) of the same run."""
    from biped.sim.sweep import SweepSpec, hold_scenario
    from biped.sim.sweep.trial import _scene_for, make_policy, run_trial

    base = hold_scenario(Scenario(physics="fast", distribution="qp", early_stop=True, duration_s=1.0))
    spec = SweepSpec(axes={"speed_m_s": 6.0, "direction_deg": 180.0}, base=base)
    setup = spec.setup(spec.trials()[0])
    row = run_trial(setup)
    scene = _scene_for(setup.scenario)
    result = run_closed_loop(setup.scenario, scene, make_policy(setup, scene))
    want = measure_response(scene, result, measure_rows(scene, result)).to_dict()
    assert row["paradigm"] == "block" and row["strategy"] in ("ankle", "hip", "step")
    assert row["strategy"] == want["strategy"] and row["strategy_torque"] == want["strategy_torque"]
    for key in ("mos_min_m", "peak_com_excursion_m", "peak_cop_excursion_m", "peak_hip_sagittal_n_m"):
        assert math.isfinite(row[key]), key
    for key, w in want.items():
        if key in row and isinstance(w, float):
            assert (math.isnan(w) and math.isnan(row[key])) or abs(row[key] - w) <= 1e-5, (key, row[key], w)


def test_sweep_row_columns_are_the_responses():
    """sim/sweep/record.Measured takes the response's columns from sim/response.ResponseMeasures
    (one list, not a copy): Response's fields but its onset_s, with their types and defaults, in
    order, between the trial's columns and stop_reason; the sweep file's schema has them there."""
    import dataclasses

    from biped.sim.response import Response, ResponseMeasures
    from biped.sim.sweep.record import Measured, schema

    assert issubclass(Measured, ResponseMeasures)
    want = [(f.name, f.type, f.default) for f in dataclasses.fields(Response) if f.name != "onset_s"]
    assert [f.name for f in dataclasses.fields(Response)][0] == "onset_s"
    names = [f.name for f in dataclasses.fields(Measured)]
    i = names.index(want[0][0])
    got = [(f.name, f.type, f.default) for f in dataclasses.fields(Measured)[i : i + len(want)]]
    assert [g[:2] for g in got] == [w[:2] for w in want]
    assert all(g[2] == w[2] or (g[2] != g[2] and w[2] != w[2]) for g, w in zip(got, want, strict=True))
    assert names[i - 1] == "com_velocity_change_m_s" and names[i + len(want)] == "stop_reason"
    cols = schema().names
    assert cols[cols.index("strategy") : cols.index("strategy") + len(want)] == [w[0] for w in want]
