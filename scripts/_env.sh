# Sourced by scripts/push.sh and scripts/test.sh (not run on its own).
# Usage: ensure_env DEBIAN_PACKAGE... ; then $PY is the Python to use and $VENV its environment.
#
# - Debian packages: installed with apt-get when run as root and missing (without root, a
#   one-line note says which to install).
# - Python: the active virtual environment if there is one ($VIRTUAL_ENV, or a `python3` on PATH
#   that runs inside a venv); otherwise the project's own .venv in the repository, created on
#   first use with `python3 -m venv` (Debian 12's system Python is "externally managed", PEP 668:
#   pip refuses to install into it, so a venv is the supported way). If `python3 -m venv` fails
#   because Debian's python3-venv is missing, it is installed and the venv created again.

_apt_missing() {
  local p missing=()
  for p in "$@"; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
  echo "${missing[@]:-}"
}

apt_ensure() {
  command -v dpkg >/dev/null 2>&1 || return 0           # not Debian: nothing to do here
  local missing
  missing=$(_apt_missing "$@")
  [ -z "$missing" ] && return 0
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "installing Debian packages: $missing"
    apt-get update -qq
    # shellcheck disable=SC2086
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $missing >/dev/null
  else
    echo "note: missing Debian packages ($missing); install them as root: apt-get install $missing" >&2
  fi
}

ensure_env() {
  apt_ensure "$@"
  if ! command -v python3 >/dev/null 2>&1; then
    apt_ensure python3
  fi
  command -v python3 >/dev/null 2>&1 || { echo "error: no python3 on PATH (Python >= 3.11 needed)" >&2; exit 1; }
  if [ -n "${VIRTUAL_ENV:-}" ] && [ -x "$VIRTUAL_ENV/bin/python" ]; then
    VENV="$VIRTUAL_ENV"
  elif python3 -c 'import sys; sys.exit(sys.prefix == sys.base_prefix)' 2>/dev/null; then
    VENV=$(python3 -c 'import sys; print(sys.prefix)')
  else
    VENV="$PWD/.venv"
    if ! "$VENV/bin/python" -m pip --version >/dev/null 2>&1; then
      rm -rf "$VENV"
      echo "creating the project's virtual environment $VENV"
      if ! python3 -m venv "$VENV" >/dev/null 2>&1; then
        rm -rf "$VENV"
        apt_ensure python3-venv
        python3 -m venv "$VENV"
      fi
    fi
  fi
  PY="$VENV/bin/python"
  "$PY" -c 'import sys; sys.exit(sys.version_info < (3, 11))' || {
    echo "error: $PY is Python $("$PY" -c 'import platform; print(platform.python_version())'); biped needs >= 3.11" >&2
    exit 1
  }
  export PATH="$VENV/bin:$PATH"
  echo "using Python environment $VENV"
}
