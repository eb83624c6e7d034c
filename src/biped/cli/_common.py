"""Helpers shared by the subcommands: the one rule for output folders, range checks, and the
frame bar of a video being rendered.

Output folders (every command that writes a folder: push, walk, posture):

- ``--out DIR`` may be new, empty, or hold a previous biped run. A folder that holds another run,
  or files that are not a biped run, is refused unless ``--overwrite``.
- ``--overwrite`` removes exactly the files the folder's run marker ``.biped-run.json`` lists
  as written by the previous run (and folders that this leaves empty), after checking the
  marker: one that is not biped's (not a table of a command and a list of files), or lists a
  path outside the folder or through a symbolic link, is refused in one line and nothing is
  removed. Files the marker does not list are never removed (a folder without a marker loses
  nothing; the new run's files replace the same names).
- Every file is written to a temporary file in its folder and moved into place
  (:mod:`biped.files`); a symbolic link where a file or a subfolder of the run would go is
  refused, never followed.
- The folder is checked before any work: an existing file, or a place where nothing can be written,
  is a one-line error before anything is simulated.
- A run that ends in an error leaves no empty folders behind (the folders it created are removed
  again if they are still empty).
- A finished run records the files it wrote in ``.biped-run.json`` (its run marker): the files
  that were not there before the run and those it replaced, never a file it did not write.

``run_dir`` registers the folder; :func:`biped.cli.main` calls :func:`finish_runs` when the
command returns or fails.
"""

from __future__ import annotations

import datetime as _dt
import functools
import json
import math
import os
import re
import tempfile
from pathlib import Path, PurePosixPath

from biped import files as _files
from biped.errors import ScenarioError

#: The run marker a finished run leaves in its folder: the command and the files it wrote.
MANIFEST = ".biped-run.json"

#: Files and folders the commands write at the top of a run folder (a symbolic link at one of
#: these names is refused before the run).
KNOWN_OUTPUTS = (
    "summary.json",
    "trajectory.csv",
    "figures",
    "video.mp4",
    "replay.html",
    "scenario.toml",
    "inverse_dynamics.csv",
    "inverse_dynamics.png",
    "joint_angles.png",
    "feet.png",
    "columns.json",
    "animation.gif",
    "animation.mp4",
    "attitude.png",
    "body_attitude.png",
    "leg_angle.png",
    "comparison.json",
    "comparison.png",
    "gains.json",
    "stability_map.npz",
    "stability_map.png",
    "mujoco.log",
    MANIFEST,
)
#: A folder holds a run (of a version without run markers) if it has one of these.
_RUN_MARKERS = (MANIFEST, "summary.json", "gains.json")
#: A run marker's "command": the words of a biped subcommand ("push", "posture pendulum", ...).
_COMMAND = re.compile(r"^[a-z][a-z0-9_-]*( [a-z0-9_-]+)*$")

_OPEN: list[_RunFolder] = []


class _RunFolder:
    def __init__(self, path: Path, command: str, before: set[str]):
        self.path = path
        self.command = command
        self.before = before  # files (relative paths) present before the run and kept
        self.since = _files.mark()  # files written through biped.files after this are the run's
        self.created: list[Path] = []  # folders this run created (deepest last)


def _entries(path: Path) -> set[str]:
    try:
        return {p.name for p in path.iterdir()}
    except OSError:
        return set()


def _all_files(path: Path) -> set[str]:
    """Relative paths of every file (or link) under ``path``, not following links."""
    out = set()
    for root, dirs, names in os.walk(path):
        rel = Path(root).relative_to(path)
        out |= {str(rel / n) for n in names}
        out |= {str(rel / d) for d in dirs if (Path(root) / d).is_symlink()}
    return out


def read_marker(path: Path, flag: str = "--out") -> tuple[str, list[str]] | None:
    """``(command, files)`` of the run marker in ``path`` (None without one), checked: a marker
    that is not biped's, or lists a path outside ``path`` or through a symbolic link, raises a
    one-line :class:`ScenarioError` (and nothing is removed)."""
    marker = path / MANIFEST
    if not marker.exists() and not marker.is_symlink():
        return None

    def refuse(why: str) -> ScenarioError:
        return ScenarioError(
            f"{flag} {str(path)!r}: its run marker {MANIFEST} {why}, so biped cannot tell which "
            f"files it wrote; remove the marker yourself, or choose another folder"
        )

    if marker.is_symlink() or not marker.is_file():
        raise refuse("is not a regular file")
    try:
        data = json.loads(_files.read_input(marker, "run marker", _files.MAX_TEXT_BYTES))
    except (ValueError, ScenarioError):
        raise refuse("is not biped's (not readable JSON)") from None
    if not isinstance(data, dict) or not isinstance(data.get("files"), list):
        raise refuse("is not biped's (no list of files)")
    command = data.get("command")
    if not isinstance(command, str) or not _COMMAND.match(command):
        raise refuse(f"is not biped's (command {command!r})")
    listed = []
    for f in data["files"]:
        if not isinstance(f, str) or not f or "\x00" in f or "\\" in f:
            raise refuse(f"lists {f!r}, which is not a file name")
        parts = PurePosixPath(f).parts
        if (
            not parts
            or PurePosixPath(f).is_absolute()
            or any(p in ("..", ".") for p in parts)
            or f != str(PurePosixPath(f))
        ):
            raise refuse(f"lists {f!r}, which is outside the folder")
        if parts[0] == MANIFEST:
            raise refuse(f"lists {f!r}, the marker itself")
        p = path
        for part in parts[:-1]:
            p = p / part
            if p.is_symlink() or (p.exists() and not p.is_dir()):
                raise refuse(f"lists {f!r}, which is reached through a link or a file ({str(p)!r})")
        listed.append(f)
    return command, listed


def _remove_previous(path: Path, listed: list[str]) -> None:
    """``--overwrite``: remove the files the marker listed (never a folder, never through a
    link), the folders that leaves empty, and the marker."""
    dirs = set()
    for f in [*listed, MANIFEST]:
        target = path / f
        try:
            if target.is_symlink() or target.is_file():
                target.unlink()
            dirs |= set(list(Path(f).parents)[:-1])
        except OSError as exc:
            raise ScenarioError(
                f"--overwrite: cannot remove {str(target)!r} ({exc.strerror or exc})"
            ) from None
    for d in sorted(dirs, key=lambda d: -len(d.parts)):
        try:
            (path / d).rmdir()  # only if empty
        except OSError:
            pass


def _check_writable(path: Path, flag: str, shown: Path | None = None) -> Path | None:
    """Raise if nothing can be written at ``path``; return the nearest existing ancestor. Messages
    name ``shown`` (default ``path``)."""
    if shown is None and path.exists() and not path.is_dir():
        raise ScenarioError(
            f"{flag} {str(path)!r} is an existing file; give a folder (new, empty, or "
            f"one that holds a previous run, with --overwrite)"
        )
    probe = path
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    shown = path if shown is None else shown
    if not probe.is_dir():
        raise ScenarioError(f"{flag} {str(shown)!r}: {str(probe)!r} is a file, not a folder")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".biped-write-test-", dir=probe)
        os.close(fd)
        os.unlink(tmp)
    except OSError as exc:
        raise ScenarioError(
            f"{flag} {str(shown)!r}: cannot write in {str(probe)!r} "
            f"({exc.strerror or exc}); choose a writable folder"
        ) from None
    return probe


def check_file_writable(path: str | os.PathLike, flag: str = "--out") -> Path:
    """Raise a one-line error before any work if the file ``path`` cannot be written: its folder
    (or the nearest existing ancestor, the folders are created later) must accept a new file,
    and ``path`` must not be a symbolic link (or an empty path)."""
    if str(path) == "":
        raise ScenarioError(f"{flag} '' is an empty path; name a file")
    path = Path(path)
    _files.check_no_link(path, flag)
    if path.is_dir():
        raise ScenarioError(f"{flag} {str(path)!r} is a folder; name a file")
    _check_writable(path.parent, flag, shown=path)
    return path


def run_dir(
    out: str | os.PathLike | None, prefix: str, *, overwrite: bool = False, flag: str = "--out"
) -> Path:
    """The output folder of a run, checked before any work: ``out`` if given (see the module's
    rule), else a new ``runs/<prefix>-<date>-<time>[-k]``. Creates the folder (removed again if the
    command fails and leaves it empty); with ``overwrite`` removes the previous run's files."""
    if out is not None and str(out) == "":
        raise ScenarioError(f"{flag} '' is an empty path; name a folder (or leave {flag} out)")
    if out is not None:
        path = Path(out)
        if path.is_symlink() and path.is_dir():  # the user's own link to a folder: its target
            path = path.resolve()
    else:
        stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
        path = Path("runs") / f"{prefix}-{stamp}"
        k = 1
        while path.exists():
            k += 1
            path = Path("runs") / f"{prefix}-{stamp}-{k}"
    _check_writable(path, flag)
    entries = _entries(path) if path.is_dir() else set()
    marker = read_marker(path, flag) if entries else None
    if entries and not overwrite:
        if marker is not None or entries & set(_RUN_MARKERS):
            what = "already holds a run"
            if marker is not None:
                what += f" of 'biped {marker[0]}'"
        else:
            shown = sorted(entries)[:3]
            what = (
                f"is not empty ({', '.join(shown)}{', ...' if len(entries) > 3 else ''}) and "
                f"holds no biped run"
            )
        raise ScenarioError(
            f"{flag} {str(path)!r} {what}; choose a new or empty folder, or pass "
            f"--overwrite (removes the files the previous run's marker {MANIFEST} lists, keeps "
            f"every other file)"
        )
    linked = sorted(n for n in entries & set(KNOWN_OUTPUTS) if (path / n).is_symlink())
    if linked:
        raise _files.LinkError(
            f"{flag} {str(path)!r}: {linked[0]} is a symbolic link where biped writes; biped "
            f"does not write through links (remove it, or choose another folder)"
        )
    missing = []
    p = path
    while not p.exists():
        missing.append(p)
        p = p.parent
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ScenarioError(
            f"{flag} {str(path)!r}: cannot create the folder ({exc.strerror or exc})"
        ) from None
    if marker is not None:  # --overwrite: nothing of the previous run survives
        _remove_previous(path, marker[1])
    folder = _RunFolder(path, prefix, _all_files(path))
    folder.created = missing[::-1]
    _OPEN.append(folder)
    return path


def finish_runs(ok: bool, command: str = "") -> None:
    """Close the folders registered by :func:`run_dir`: on success write each one's run marker
    (a write error raises OSError, after every folder was closed); on failure remove the
    folders the run created if they are still empty."""
    error: OSError | None = None
    while _OPEN:
        folder = _OPEN.pop()
        if ok:
            root = folder.path.absolute()
            mine = {str(p.relative_to(root)) for p in _files.written(folder.since) if p.is_relative_to(root)}
            now = _all_files(folder.path)
            names = sorted(((now - folder.before) | (mine & now)) - {MANIFEST})
            try:
                _files.write_text(
                    folder.path / MANIFEST,
                    json.dumps({"command": command or folder.command, "files": names}, indent=1) + "\n",
                )
            except OSError as exc:
                error = error or exc
        else:
            for p in reversed(folder.created):
                try:
                    p.rmdir()  # only if empty
                except OSError:
                    break
    if error is not None:
        raise error


def check_range(flag: str, value: float, lo: float, hi: float, what: str, *, lo_open: bool = False) -> float:
    """``value`` if finite and within [lo, hi] (``(lo, hi]`` with ``lo_open``), else a ScenarioError
    naming ``flag``, the valid range and why it is bounded (``what``)."""
    ok = math.isfinite(value) and (value > lo if lo_open else value >= lo) and value <= hi
    if not ok:
        left = "(" if lo_open else "["
        raise ScenarioError(f"{flag} must be in {left}{lo:g}, {hi:g}] ({what}); got {value!r}")
    return value


def command_seconds(fallback_start: float) -> float:
    """Wall time of the command [s]: since this process started (Linux: /proc), so that the
    last line counts the start-up (imports) too; since ``fallback_start`` (a
    ``time.perf_counter()`` value taken when the command began) elsewhere, or when the process
    is older than a start-up (the command was called from a running Python, e.g. a test)."""
    import time

    elapsed = time.perf_counter() - fallback_start
    try:
        with open("/proc/self/stat") as fh:
            start_ticks = float(fh.read().rsplit(")", 1)[1].split()[19])
        with open("/proc/uptime") as fh:
            uptime = float(fh.read().split()[0])
        age = uptime - start_ticks / os.sysconf("SC_CLK_TCK")
        if elapsed <= age < elapsed + 30.0:  # start-up: seconds, not a long-lived process
            return age
    except (OSError, ValueError, IndexError):
        pass
    return elapsed


def add_folder_options(parser, default: str = "a new one under runs/") -> None:
    """``--out DIR`` and ``--overwrite`` of a command that writes a run folder (push, walk,
    posture), which :func:`run_dir` then checks; ``default`` says where a run goes without --out."""
    parser.add_argument("--out", metavar="DIR", help=f"output folder (default: {default})")
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="allow writing into a folder that already holds a run (its files are removed first)",
    )


def keeps_mujoco_log(command):
    """``command(args)`` (a command's ``run``) with MuJoCo's log routing put back after it
    (:func:`biped.sim.mjlog.preserved`): the command routes MuJoCo's warnings to its output's
    log while it runs, and one run from Python (e.g. by the tests) leaves no routing behind."""

    @functools.wraps(command)
    def run(args) -> int:
        from biped.sim.mjlog import preserved

        with preserved():
            return command(args)

    return run


def add_file_options(parser) -> None:
    """``--no-video``, ``--no-replay`` and ``--no-figures`` of a command that writes those files
    of a run (push, walk)."""
    parser.add_argument("--no-video", action="store_true", help="skip video.mp4")
    parser.add_argument("--no-replay", action="store_true", help="skip replay.html")
    parser.add_argument("--no-figures", action="store_true", help="skip figures/")


def frame_bar(**tqdm_kwargs):
    """``(on_frame, close)``: ``on_frame(done, total)`` (the video renderer's progress) draws a tqdm
    bar "rendering video.mp4" of ``total`` frames (whole lines when stderr is not a terminal,
    :func:`biped._progress.progress_bar`), made at the first report; ``close()`` ends it.
    One bar for every command that renders a video (push, walk); ``tqdm_kwargs`` go to tqdm."""
    state: dict = {}

    def on_frame(done, total=None, *_):
        from biped._progress import progress_bar

        if state.get("bar") is None:
            state["bar"] = progress_bar(total=total, desc="rendering video.mp4", unit="frame", **tqdm_kwargs)
        bar = state["bar"]
        bar.update(max(0, int(done) - bar.n))

    def close():
        if state.get("bar") is not None:
            state["bar"].close()
            state["bar"] = None

    return on_frame, close


def stopped_trials(exc: BaseException, prog: str, out: Path, again: str, *, newline: bool = False) -> int:
    """Ctrl-C or SIGTERM during a sweep or an envelope: say that every finished trial is kept
    and how to go on (``again``: "finish", "resume"); returns the exit status (130, 143).
    ``newline``: end a progress line first."""
    import sys

    from biped.sim.sweep import Terminated, parts_dir

    term = isinstance(exc, Terminated)
    what = "terminated (SIGTERM)" if term else "interrupted"
    print(
        f"{chr(10) if newline else ''}{prog}: {what}; every finished trial is kept in {parts_dir(out)}/. "
        f"Run the same command again to {again}.",
        file=sys.stderr,
    )
    return 143 if term else 130
