"""The exit statuses of docs/cli.md, as a user sees them: a separate process per command line.

0 result, 2 bad input (one line, before any work), 130 Ctrl-C and 143 SIGTERM with what was
computed written (`biped push`). `biped sweep`'s 143 is tested in test_sweep_storage.py.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

SRC = str(Path(__file__).resolve().parents[1] / "src")


def _biped(*args, cwd, **kw):
    env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.Popen(
        [sys.executable, "-m", "biped", *args],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kw,
    )


def test_exit_status_table_is_documented():
    from biped.cli import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK, EXIT_TERMINATED

    doc = (Path(__file__).resolve().parents[1] / "docs" / "cli.md").read_text(encoding="utf-8")
    for code in (EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_TERMINATED):
        assert re.search(rf"^\| `{code}` \|", doc, re.MULTILINE), f"exit status {code} not in docs/cli.md"
    for command in ("push", "walk", "posture", "sweep", "model"):
        assert f"`biped {command}`" in doc


@pytest.mark.parametrize(
    "argv",
    [
        ["push", "--duration", "0"],
        ["walk", "--speed", "0"],
        ["posture", "pendulum", "--dt", "0"],
        ["sweep", "--speed", "0"],
        ["model", "--stature", "9", "--mass", "50", "--sex", "female", "--out", "m.xml"],
        ["model", "--stature", "1.7", "--mass", "50", "--sex", "female", "--out", "/proc/no/m.xml"],
        ["push", "--no-such-option"],
        [],
    ],
)
def test_bad_input_exits_2_with_one_line_and_writes_nothing(tmp_path, argv):
    p = _biped(*argv, cwd=tmp_path)
    _out, err = p.communicate(timeout=120)
    assert p.returncode == 2, err
    assert "Traceback" not in err
    if argv:
        assert err.strip().splitlines()[-1].startswith(f"biped {argv[0]}"), err
    assert list(tmp_path.iterdir()) == []  # no folder, no file


@pytest.mark.slow
@pytest.mark.parametrize(
    ("sig", "status", "word"), [(signal.SIGTERM, 143, "interrupted"), (signal.SIGINT, 130, "interrupted")]
)
def test_a_stopped_push_writes_what_it_computed(tmp_path, sig, status, word):
    # SIGINT back to its default in the child: a shell's background job (CI, nohup ... &) starts
    # with SIGINT ignored, and Python then rightly leaves it ignored
    p = _biped(
        "push",
        "--duration",
        "60",
        "--no-video",
        "--no-replay",
        "--no-figures",
        "--out",
        "run",
        cwd=tmp_path,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    # wait until the simulation has advanced (the progress bar shows simulated time > 0.1 s)
    buf, t0 = "", time.monotonic()
    fd = p.stderr.fileno()
    os.set_blocking(fd, False)
    while time.monotonic() - t0 < 180:
        try:
            buf += os.read(fd, 65536).decode(errors="replace")
        except BlockingIOError:
            pass
        done = [float(x) for x in re.findall(r"(\d+\.\d\d)/60\.00 s sim", buf)]
        if done and max(done) > 0.1:
            break
        assert p.poll() is None, buf
        time.sleep(0.05)
    else:
        pytest.fail("the push did not start within 180 s: " + buf[-500:])
    p.send_signal(sig)
    p.wait(timeout=120)
    os.set_blocking(fd, True)
    buf += p.stderr.read()  # what it said after the signal, shown if the status is wrong
    assert p.returncode == status, buf
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary[word] is True
    assert (tmp_path / "run" / "trajectory.csv").is_file()
