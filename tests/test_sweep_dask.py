"""`biped sweep --scheduler ADDRESS`: the same sweep through a real dask.distributed cluster
(a LocalCluster on loopback), real push trials included."""

from __future__ import annotations

import pytest

from biped.sim.scenario import Scenario
from biped.sim.sweep import SweepSpec, load, run_sweep

distributed = pytest.importorskip("dask.distributed")


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(
        n_workers=1,
        threads_per_worker=2,
        processes=False,
        protocol="tcp",
        host="127.0.0.1",
        dashboard_address=None,
    ) as c:
        yield c


def test_sweep_runs_on_a_dask_cluster_by_address(cluster, tmp_path):
    """Short real trials (0.15 s of W's push scene, both controllers' code paths exercised by
    the joint-space PD here) sent to the scheduler by its tcp:// address, as from the CLI."""
    base = Scenario(
        duration_s=0.15, controller="joint-pd", target_com_m=(0.0, 0.0, 1.035), target_tilt_deg=5.0
    )
    spec = SweepSpec(axes={"speed_m_s": (3.0, 6.0), "direction_deg": (0.0, 180.0)}, base=base)
    out = tmp_path / "dask.parquet"
    assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
    summary = run_sweep(spec, out, scheduler=cluster.scheduler_address, progress=False, batch=2)
    assert summary.backend == "dask" and summary.complete and summary.ran == 4
    data = load(out)
    assert data.column("index").tolist() == [0, 1, 2, 3]
    assert all(e is None for e in data.table.column("error").to_pylist())
    # every block hit the trunk's flat front or back face by 0.15 s and pushed the body along
    # its own direction of travel with an impulse between m v (plastic) and 2 m v (elastic)
    ix, iy = data.column("impulse_x_n_s"), data.column("impulse_y_n_s")
    direction, speed = data.column("direction_deg"), data.column("speed_m_s")
    for k in range(4):
        along = ix[k] if direction[k] == 0.0 else -ix[k]
        assert 1.8 * speed[k] < along < 2 * 1.8 * speed[k]
        assert abs(iy[k]) < 1e-6
    # resuming through the cluster: nothing left to do
    again = run_sweep(spec, out, scheduler=cluster.scheduler_address, progress=False)
    assert again.skipped == 4 and again.ran == 0


def test_envelope_runs_on_a_dask_cluster_with_the_local_answer(cluster, tmp_path):
    """`biped envelope --scheduler`: the directions' searches stream trials (a closed-form plant)
    through the cluster and find the same limits as in this process."""
    from test_envelope import _spec, plant_trial

    from biped.sim.sweep.envelope import run_envelope

    here = run_envelope(_spec(), tmp_path / "here.parquet", trial_fn=plant_trial, workers=1)
    there = run_envelope(
        _spec(), tmp_path / "dask.parquet", trial_fn=plant_trial, scheduler=cluster.scheduler_address
    )
    assert there.backend == "dask" and there.complete
    assert [(d.limit, d.first_fail, d.n_trials) for d in there.directions] == [
        (d.limit, d.first_fail, d.n_trials) for d in here.directions
    ]
