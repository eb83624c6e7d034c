#!/usr/bin/env bash
# Installs what the tests need (system packages included) and runs the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
if command -v apt-get >/dev/null && [ "$(id -u)" = 0 ]; then
  if ! command -v chromium >/dev/null || ! dpkg -s libosmesa6 >/dev/null 2>&1; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium libosmesa6 libgl1 >/dev/null
  fi
fi
python -m pip install -q -e ".[test]"
python -m pytest -n 2 -q "$@"
