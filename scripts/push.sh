#!/usr/bin/env bash
# Installs biped with everything it needs and runs W's push experiment on the defaults.
set -euo pipefail
cd "$(dirname "$0")/.."
if command -v apt-get >/dev/null && [ "$(id -u)" = 0 ]; then
  if ! dpkg -s libosmesa6 >/dev/null 2>&1; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libosmesa6 libgl1 >/dev/null
  fi
fi
python -m pip install -q -e .
biped push "$@"
