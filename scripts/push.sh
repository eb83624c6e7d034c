#!/usr/bin/env bash
# Installs biped with everything it needs and runs W's push experiment on the defaults.
# Debian packages: libosmesa6 and libgl1 (MuJoCo's offscreen rendering of video.mp4).
# Python: the active virtual environment, else the project's own .venv (see scripts/_env.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/_env.sh
ensure_env libosmesa6 libgl1
echo "installing biped and its Python dependencies with pip (first run: a few minutes; one line a package)"
pip_install -e .
exec "$PY" -m biped push "$@"
