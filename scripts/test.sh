#!/usr/bin/env bash
# Installs what the tests need, then runs, in order and stopping at the first failure:
#   1. ruff check   (pyflakes, pycodestyle, bugbear, isort, pyupgrade, numpy rules; pyproject.toml)
#   2. mypy         (src/biped, configured in pyproject.toml)
#   3. the doctests (every `>>>` example in src/biped)
#   4. the documentation site (mkdocs build --strict: no broken link, anchor or reference)
#   5. the test suite (pytest -n 2); extra arguments go to this step.
# Exits non-zero if any step fails or if no test ran.
# Debian packages: libosmesa6 and libgl1 (offscreen rendering of the videos), chromium (the
# browser tests open replay.html headless; ~130 packages with its dependencies).
# Python: the active virtual environment, else the project's own .venv (see scripts/_env.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/_env.sh
ensure_env libosmesa6 libgl1 chromium
echo "installing biped, the test, docs and robot-model dependencies with pip (first run: a few minutes; one line a package)"
pip_install -e ".[test,docs,robots]"
DIRS=(src tests benchmarks scripts)
echo "== ruff check"
"$PY" -m ruff check "${DIRS[@]}"
echo "== ruff format --check"
"$PY" -m ruff format --check "${DIRS[@]}"
echo "== mypy"
"$PY" -m mypy
echo "== doctests"
"$PY" -m pytest -q -n 0 -p no:cacheprovider --doctest-modules src/biped
echo "== docs site (mkdocs build --strict)"
NO_MKDOCS_2_WARNING=1 "$PY" -m mkdocs build --strict --quiet
echo "== test suite"
rc=0
"$PY" -m pytest -n 2 -q "$@" || rc=$?
if [ "$rc" = 5 ]; then
  echo "error: pytest collected no tests (exit 5): treated as a failure" >&2
  exit 1
fi
exit "$rc"
