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


def _docs_commands() -> dict[str, list[str]]:
    """The `dask scheduler` and `dask worker` command lines of docs/sweep.md ("On a Dask
    cluster"), as words, comments dropped."""
    import shlex
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "sweep.md").read_text(encoding="utf-8")
    section = text.split("## On a Dask cluster", 1)[1].split("\n## ", 1)[0]
    out = {}
    for line in section.splitlines():
        words = shlex.split(line.split("#", 1)[0])
        if words[:2] in (["dask", "scheduler"], ["dask", "worker"]):
            out[words[1]] = words
    return out


@pytest.mark.slow
def test_the_docs_cluster_commands_run_a_sweep(tmp_path):
    """docs/sweep.md's commands, as written but on 127.0.0.1 and a free port: `dask scheduler`,
    `dask worker` (separate processes, biped from this checkout), then `biped sweep --scheduler`
    with short joint-PD trials."""
    import os
    import socket
    import subprocess
    import sys
    import time
    from pathlib import Path

    from biped.cli import main

    cmds = _docs_commands()
    assert set(cmds) == {"scheduler", "worker"}, cmds
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    addr = f"tcp://127.0.0.1:{port}"
    dask_exe = str(Path(sys.executable).parent / "dask")

    def local(words):
        words = [w.replace("10.0.0.5", "127.0.0.1").replace("8786", str(port)) for w in words]
        return [dask_exe, *words[1:]]

    worker_cmd = local(cmds["worker"])
    worker_cmd[worker_cmd.index("--nworkers") + 1] = "1"  # one core's worth is enough here
    src = str(Path(__file__).resolve().parents[1] / "src")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([src, os.environ.get("PYTHONPATH", "")])}
    procs = []
    try:
        for cmd in (local(cmds["scheduler"]), worker_cmd):
            log = open(tmp_path / f"{cmd[1]}.log", "w")  # noqa: SIM115 - closed with the process
            procs.append((subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT), log))
            time.sleep(1.0)
        client = distributed.Client(addr, timeout=60)
        client.wait_for_workers(1, timeout=90)
        client.close()
        out = tmp_path / "docs.parquet"
        argv = ["sweep", "--speed", "3", "--direction", "0,180", "--duration", "0.02"]
        argv += ["--controller", "joint-pd", "--quiet", "--scheduler", addr, "--out", str(out)]
        assert main(argv) == 0
        data = load(out)
        assert data.table.num_rows == 2 and all(e is None for e in data.table.column("error").to_pylist())
    finally:
        for proc, log in reversed(procs):
            proc.terminate()
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
            log.close()
