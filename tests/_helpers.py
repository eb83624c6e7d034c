"""Plain helpers that several test modules share (fixtures live in conftest.py).

Import them as ``from _helpers import ...``: pytest puts this folder on ``sys.path`` (the tests are
not a package), and so does a test's own child process that adds it.
"""

from __future__ import annotations

import csv
import json
import shutil
import subprocess

import mujoco
import numpy as np
import pytest


def read_csv(path) -> tuple[list[str], np.ndarray]:
    """(header, (rows, columns) float array) of a CSV file; an empty cell is NaN."""
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array([[float(x) if x else np.nan for x in r] for r in rows[1:]], dtype=float)


def strict_json(text: str):
    """``json.loads`` that refuses NaN and Infinity (not JSON, though Python writes them)."""

    def bad(name):
        raise ValueError(f"non-JSON constant {name}")

    return json.loads(text, parse_constant=bad)


def one_line_error(err: str, command: str) -> str:
    """The single line of ``err`` (stderr of ``biped COMMAND``), which must read
    ``biped COMMAND: error: ...`` with no traceback."""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert "Traceback" not in err
    assert len(lines) == 1 and lines[0].startswith(f"biped {command}: error: "), err
    return lines[0]


def random_states(m, n: int, seed: int, spread: float = 0.25, vel: float = 1.0):
    """``n`` MjData of W's biped ``m`` after ``mj_forward``: its initial keyframe with each joint
    moved uniformly within +-``spread`` [rad] and normal velocities of SD ``vel``, from ``seed``."""
    rng = np.random.default_rng(seed)
    for _ in range(n):
        d = mujoco.MjData(m)
        d.qpos[:] = m.key_qpos[m.key("wendlandt_initial").id]
        d.qpos[7:] += rng.uniform(-spread, spread, m.nq - 7)
        d.qvel[:] = rng.normal(0.0, vel, m.nv)
        mujoco.mj_forward(m, d)
        yield d


# ---------------------------------------------------------------------------------------------
# command lines of small runs


def walk_argv(
    out, *extra: str, gait: str = "forward", steps: int | None = 1, files: bool = False
) -> list[str]:
    """``biped walk`` of ``steps`` steps of ``gait`` into ``out``, quiet; ``files=False`` also
    skips the video, replay, figures and dynamics (only trajectory.csv and summary.json)."""
    argv = ["walk", "--gait", gait]
    if steps is not None:
        argv += ["--steps", str(steps)]
    argv += [*extra, "--out", str(out), "--no-video", "--quiet"]
    if not files:
        argv += ["--no-replay", "--no-figures", "--no-dynamics"]
    return argv


def paradigm_push(out, perturbation: str) -> dict:
    """``biped push --perturbation PERTURBATION`` of 0.4 s on fast physics into ``out``, quiet,
    without video, replay or figures (it must exit 0): its summary.json."""
    from biped.cli import main

    argv = ["push", "--perturbation", perturbation, "--duration", "0.4", "--set", 'physics="fast"', "--quiet"]
    assert main([*argv, "--no-video", "--no-replay", "--no-figures", "--out", str(out)]) == 0
    return json.loads((out / "summary.json").read_text())


def tiny_sweep_argv(out, *extra: str, direction: str = "0") -> list[str]:
    """``biped sweep`` of joint-PD trials at 3 m/s from ``direction`` (deg), 0.02 s each, one
    worker, quiet, into ``out``: seconds of work."""
    return [
        "sweep",
        "--speed",
        "3",
        "--direction",
        direction,
        "--duration",
        "0.02",
        "--controller",
        "joint-pd",
        "--workers",
        "1",
        "--quiet",
        "--out",
        str(out),
        *extra,
    ]


def toy_trial(setup) -> dict:
    """A closed-form stand-in for a push trial (no physics): the block's momentum 1.2 m v reaches
    the body, which falls above 4 m/s; for tests of storage, scheduling and plots."""
    t = setup.trial
    return {"impulse_n_s": 1.2 * t.block_mass_kg * t.speed_m_s, "completed": True, "fell": t.speed_m_s > 4}


# ---------------------------------------------------------------------------------------------
# headless Chromium


def chromium() -> str:
    """Path of a Chromium executable; skips the test where there is none."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        exe = shutil.which(name)
        if exe:
            return exe
    pytest.skip("Debian's chromium is not installed (apt-get install chromium); CI installs it")


def run_chromium(tmp_path, *args: str, url: str) -> str:
    """Stdout of headless Chromium (software WebGL, an 800 x 600 window, 8 s of virtual time, a
    fresh profile under ``tmp_path``) given ``args`` (e.g. ``--dump-dom``) and ``url``."""
    cmd = [
        chromium(),
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--use-angle=swiftshader",
        "--enable-unsafe-swiftshader",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        "--disable-extensions",
        f"--user-data-dir={tmp_path / 'profile'}",
        "--window-size=800,600",
        "--virtual-time-budget=8000",
        "--hide-scrollbars",
        *args,
        url,
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=90, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout


def goal_push_scenario(**changes):
    """W's goal push for stepping (issue #23; tests/test_stepping.py): a 4 kg block at 8 m/s from
    behind (32 N s; the biped faces -x), faithful physics, 4 s, the QP, stepping with the ``"qp"``
    trigger; ``changes`` other scenario keys."""
    from biped.sim import Scenario

    keys = dict(distribution="qp", block_mass_kg=4.0, block_velocity_m_s=(-8.0, 0.0, 0.2), duration_s=4.0,
                stepping=True, step_trigger="qp")  # fmt: skip
    return Scenario(**{**keys, **changes})


def qp_stepping(sc, scene, **params):
    """W's stepping controller of scenario ``sc`` on ``scene`` (``policy_config(sc)``, the
    scene's joints) with the ``"qp"`` trigger's set changed by ``params`` (SteppingConfig keys)."""
    from biped.control.stepping import SteppingController
    from biped.control.stepping_config import SteppingConfig
    from biped.sim.policies import policy_config

    return SteppingController(
        policy_config(sc), SteppingConfig.for_trigger("qp", **params), scene.joint_names
    )


def run_qp_stepping(sc, scene=None, *, on_step=None, **params):
    """``run_closed_loop`` of ``sc`` on ``scene`` (default: a fresh ``build_scene(sc)``) with
    :func:`qp_stepping`'s controller of ``params``; ``on_step`` as there."""
    from biped.sim.push import run_closed_loop
    from biped.sim.scene import build_scene

    scene = build_scene(sc) if scene is None else scene
    return run_closed_loop(sc, scene, qp_stepping(sc, scene, **params), on_step=on_step)


def leg_geoms(m, side: str) -> list[int]:
    """The geoms of one leg's bodies (thigh and below), by the body tree from ``side``_thigh."""
    top = m.body(f"{side}_thigh").id
    out = []
    for g in range(m.ngeom):
        b = int(m.geom_bodyid[g])
        while b > 0 and b != top:
            b = int(m.body_parentid[b])
        if b == top:
            out.append(g)
    return out
