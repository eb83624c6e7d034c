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

# with_ticks CMD...: run CMD, printing "  ... still at work (N s)" every 2 s while it runs (a
# step that prints nothing for seconds, such as creating a venv or apt-get, is never silent);
# returns CMD's exit status.
with_ticks() {
  local pid rc t0=$SECONDS
  "$@" &
  pid=$!
  while kill -0 "$pid" 2>/dev/null; do
    sleep 1
    if kill -0 "$pid" 2>/dev/null && [ $(((SECONDS - t0) % 2)) = 0 ]; then
      echo "  ... still at work ($((SECONDS - t0)) s)" >&2
    fi
  done
  rc=0
  wait "$pid" || rc=$?
  return "$rc"
}

_quiet() { "$@" >/dev/null; }          # the command's output hidden, its errors shown
_silent() { "$@" >/dev/null 2>&1; }    # both hidden

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
    with_ticks apt-get update -qq
    # shellcheck disable=SC2086
    DEBIAN_FRONTEND=noninteractive with_ticks _quiet apt-get install -y -qq $missing
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
      if ! with_ticks _silent python3 -m venv "$VENV"; then
        rm -rf "$VENV"
        apt_ensure python3-venv
        with_ticks python3 -m venv "$VENV"
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

# pip_install ARGS...: "$PY" -m pip install ARGS, showing pip's progress one line a package
# ("Collecting numpy>=1.26", "Installing collected packages: ...", "Successfully installed ...";
# not the "Requirement already satisfied" and download lines), and, whenever pip prints nothing
# for a second or two (building, unpacking, installing), a line saying it is still at work with the elapsed
# time. Returns pip's exit status; on failure pip's whole output is shown.
pip_install() {
  local log pid rc seen=0 n last=$SECONDS t0=$SECONDS
  log=$(mktemp)
  "$PY" -m pip install --progress-bar off "$@" >"$log" 2>&1 &
  pid=$!
  while kill -0 "$pid" 2>/dev/null; do
    sleep 0.5
    n=$(wc -l <"$log")
    if [ "$n" -gt "$seen" ]; then
      sed -n "$((seen + 1)),${n}p" "$log" | _pip_lines
      seen=$n
      last=$SECONDS
    elif [ $((SECONDS - last)) -ge 1 ]; then  # bash counts whole seconds: a line every 1-2 s
      echo "  pip is still at work ($((SECONDS - t0)) s)"
      last=$SECONDS
    fi
  done
  rc=0
  wait "$pid" || rc=$?
  sed -n "$((seen + 1)),\$p" "$log" | _pip_lines
  if [ "$rc" != 0 ]; then
    echo "error: pip install $* failed (exit $rc); its output:" >&2
    cat "$log" >&2
  else
    echo "  pip done in $((SECONDS - t0)) s"
  fi
  rm -f "$log"
  return "$rc"
}

_pip_lines() {
  grep -E '^ *(Collecting|Obtaining|Building|Installing|Successfully|ERROR)' | cut -c1-160 || true
}
