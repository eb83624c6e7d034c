"""scripts/_env.sh on a machine that lacks what it needs: Debian's python3-venv, libosmesa6 and
chromium missing, no virtual environment active. Fakes stand in for dpkg, apt-get and id (the
test must not install anything); python3 is the real one, except that `python3 -m venv` fails
the way Debian's does until python3-venv is "installed". The environment it then creates is real.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

_DPKG = """#!/bin/sh
# dpkg -s PKG: installed iff listed in $FAKE_DIR/installed
[ "$1" = "-s" ] || exit 2
grep -qx "$2" "$FAKE_DIR/installed"
"""
_APT = """#!/bin/sh
echo "apt-get $*" >> "$FAKE_DIR/apt.log"
if [ "$1" = "install" ]; then
  for a in "$@"; do case "$a" in -*|install) ;; *) echo "$a" >> "$FAKE_DIR/installed";; esac; done
fi
"""
_ID = """#!/bin/sh
[ "$1" = "-u" ] && { echo 0; exit 0; }
exec /usr/bin/id "$@"
"""
_PYTHON = """#!/bin/sh
# Debian without python3-venv: `python3 -m venv DIR` leaves a broken DIR and fails
if [ "$1" = "-m" ] && [ "$2" = "venv" ] && ! grep -qx python3-venv "$FAKE_DIR/installed"; then
  mkdir -p "$3/bin"
  echo "The virtual environment was not created successfully because ensurepip is not available." >&2
  exit 1
fi
exec "{real}" "$@"
"""


def _real_python() -> str:
    """A Python outside any virtual environment (the system's), as a fresh machine has."""
    for candidate in ("/usr/bin/python3", getattr(sys, "_base_executable", ""), sys.executable):
        if candidate and Path(candidate).is_file():
            ok = subprocess.run(
                [
                    candidate,
                    "-c",
                    (
                        "import sys, venv, ensurepip; "
                        "sys.exit(sys.prefix != sys.base_prefix or sys.version_info < (3, 11))"
                    ),
                ],
                capture_output=True,
                check=False,
            )
            if ok.returncode == 0:
                return candidate
    pytest.skip("no Python >= 3.11 with venv and ensurepip outside a virtual environment")


def test_env_installs_python3_venv_and_the_debian_packages_then_makes_a_venv(tmp_path):
    real = _real_python()
    fake = tmp_path / "fake"
    fake.mkdir()
    for name, text in (
        ("dpkg", _DPKG),
        ("apt-get", _APT),
        ("id", _ID),
        ("python3", _PYTHON.replace("{real}", real)),
    ):
        (fake / name).write_text(text)
        (fake / name).chmod(0o755)
    (fake / "installed").write_text("python3\n")
    repo = tmp_path / "clone"
    (repo / "scripts").mkdir(parents=True)
    shutil.copy(ROOT / "scripts" / "_env.sh", repo / "scripts" / "_env.sh")
    script = (
        "set -euo pipefail; . scripts/_env.sh; ensure_env libosmesa6 chromium; "
        'echo "PY=$PY"; "$PY" -c "import sys; print(\'venv\', sys.prefix != sys.base_prefix)"'
    )
    env = {"HOME": str(tmp_path), "PATH": f"{fake}:/usr/bin:/bin", "FAKE_DIR": str(fake)}
    r = subprocess.run(
        ["bash", "-c", script], cwd=repo, env=env, capture_output=True, text=True, check=False, timeout=300
    )
    assert r.returncode == 0, r.stdout + r.stderr
    apt = (fake / "apt.log").read_text().splitlines()
    installs = [line.split()[1:] for line in apt if line.split()[1] == "install"]
    assert any("libosmesa6" in i and "chromium" in i for i in installs), apt
    assert any("python3-venv" in i for i in installs), apt
    assert f"PY={repo}/.venv/bin/python" in r.stdout, r.stdout
    assert "venv True" in r.stdout
    # a second run finds everything in place: no apt-get, the same environment
    (fake / "apt.log").unlink()
    r = subprocess.run(
        ["bash", "-c", script], cwd=repo, env=env, capture_output=True, text=True, check=False, timeout=120
    )
    assert r.returncode == 0 and not (fake / "apt.log").exists(), r.stdout + r.stderr
    assert f"PY={repo}/.venv/bin/python" in r.stdout


def test_env_uses_the_active_virtual_environment(tmp_path):
    if sys.prefix == sys.base_prefix:
        pytest.skip("the tests do not run in a virtual environment")
    env = {**os.environ, "VIRTUAL_ENV": sys.prefix, "PATH": f"{Path(sys.executable).parent}:/usr/bin:/bin"}
    r = subprocess.run(
        ["bash", "-c", '. scripts/_env.sh; ensure_env; echo "PY=$PY"'],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert r.returncode == 0, r.stderr
    assert f"PY={sys.prefix}/bin/python" in r.stdout
