"""Where MuJoCo's warnings go: never ``MUJOCO_LOG.TXT`` in the user's current directory.

MuJoCo's default warning handler prints the warning and appends it to ``MUJOCO_LOG.TXT`` in the
current directory. Importing :mod:`biped.sim` calls :func:`configure_from_env`: with no log file
chosen MuJoCo writes no file (the warning is still printed); a command that writes a run folder
calls :func:`route_to` with the run's own ``mujoco.log``, and child processes (a sweep's workers)
inherit that choice through the environment variable :data:`ENV`. Routed to a file, the warnings
are not printed (they would break a progress bar's line); the command says once, at its end, how
many there were and where (:func:`summary`).

>>> from biped.sim.mjlog import route_to
>>> route_to("runs/mine/mujoco.log")   # MuJoCo's warnings of this process and its children go there
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import mujoco

__all__ = ["ENV", "configure_from_env", "count_warnings", "current_log", "preserved", "route_to", "summary"]

#: Environment variable holding the log file MuJoCo's warnings are appended to ("" = none).
ENV = "BIPED_MUJOCO_LOG"


def _apply(path: str | None) -> None:
    cfg_cls = getattr(mujoco, "MjLogConfig", None)
    if cfg_cls is not None:  # MuJoCo >= 3.4: the log file is configurable
        cfg = cfg_cls.get()
        cfg.logto_file = bool(path)
        if hasattr(cfg, "logto_console"):
            cfg.logto_console = not path  # to the file only, when there is one
        if path:
            cfg.logfile = path
        cfg.set()
        return
    # older MuJoCo: a Python handler replaces the default one (which writes MUJOCO_LOG.TXT)

    def handler(msg: str) -> None:
        if not path:
            print(f"WARNING: {msg}")
        if path:
            flags = os.O_WRONLY | os.O_APPEND | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0)
            with os.fdopen(os.open(path, flags, 0o644), "a", encoding="utf-8") as fh:  # never a link
                fh.write(f"WARNING: {msg}\n")

    mujoco.set_mju_user_warning(handler)


def route_to(path: str | os.PathLike | None) -> None:
    """Append MuJoCo's warnings to ``path`` (None: write no log file) in this process and in
    child processes started afterwards (through :data:`ENV`)."""
    if path:
        from biped.files import check_no_link

        check_no_link(path, "the MuJoCo log")
    value = str(Path(path).resolve()) if path else ""
    os.environ[ENV] = value
    _apply(value or None)


def current_log() -> str | None:
    """The file MuJoCo's warnings go to, or None."""
    return os.environ.get(ENV) or None


def configure_from_env() -> None:
    """Apply :data:`ENV` (unset or empty: no log file) to this process's MuJoCo."""
    _apply(current_log())


@contextmanager
def preserved() -> Iterator[None]:
    """Whatever the ``with`` block routes (:func:`route_to`), the previous choice is back after it
    (a command run from Python, e.g. by the tests, leaves no routing behind)."""
    previous = current_log()
    try:
        yield
    finally:
        route_to(previous)


def count_warnings(path: str | os.PathLike | None = None) -> int:
    """How many warnings MuJoCo wrote to ``path`` (default: the current log), 0 if none."""
    path = path or current_log()
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:  # type: ignore[arg-type]
            return sum(1 for line in fh if "WARNING" in line)
    except (OSError, TypeError):
        return 0


def summary(path: str | os.PathLike | None = None, before: int = 0) -> str | None:
    """One line for the end of a command: how many warnings MuJoCo wrote to its log since
    ``before`` were counted, and where (None when there were none)."""
    path = path or current_log()
    n = count_warnings(path) - before
    if n <= 0:
        return None
    return f"MuJoCo warned {n} time{'s' if n != 1 else ''} (e.g. a diverging simulation): see {path}"
