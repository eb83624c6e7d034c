#!/usr/bin/env bash
# Installs what the tests need and runs the whole test suite; exits non-zero if any test fails
# or if no test ran.
# Debian packages: libosmesa6 and libgl1 (offscreen rendering of the videos), chromium (the
# browser tests open replay.html headless; ~130 packages with its dependencies).
# Python: the active virtual environment, else the project's own .venv (see scripts/_env.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/_env.sh
ensure_env libosmesa6 libgl1 chromium
echo "installing biped and the test dependencies (first run: a few minutes)"
"$PY" -m pip install -q -e ".[test]"
rc=0
"$PY" -m pytest -n 2 -q "$@" || rc=$?
if [ "$rc" = 5 ]; then
  echo "error: pytest collected no tests (exit 5): treated as a failure" >&2
  exit 1
fi
exit "$rc"
