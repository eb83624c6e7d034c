"""Helpers shared by the subcommands: the one rule for output folders, range checks, and the
frame bar of a video being rendered.

Output folders (every command that writes a folder: push, walk, posture):

- ``--out DIR`` may be new, empty, or hold a previous biped run. A folder that holds another run,
  or files that are not a biped run, is refused unless ``--overwrite``.
- ``--overwrite`` removes the previous run's files (those its manifest lists, or the known output
  names of a run without one) before the new run writes, so no stale video, replay or figure
  survives; files that biped did not write are never removed.
- The folder is checked before any work: an existing file, or a place where nothing can be written,
  is a one-line error before anything is simulated.
- A run that ends in an error leaves no empty folders behind (the folders it created are removed
  again if they are still empty).
- A finished run records the files it wrote in ``.biped-run.json`` (its manifest).

``run_dir`` registers the folder; :func:`biped.cli.main` calls :func:`finish_runs` when the
command returns or fails.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import shutil
import tempfile
from pathlib import Path

from biped.errors import ScenarioError

#: The manifest a finished run leaves in its folder: the command and the files it wrote.
MANIFEST = ".biped-run.json"

#: Files and folders the commands write (for folders of runs made before manifests existed).
KNOWN_OUTPUTS = (
    "summary.json",
    "trajectory.csv",
    "figures",
    "video.mp4",
    "replay.html",
    "inverse_dynamics.csv",
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
    "run.log",
    "mujoco.log",
)
#: A folder holds a run (of a version without manifests) if it has one of these.
_RUN_MARKERS = (MANIFEST, "summary.json", "gains.json")

_OPEN: list[_RunFolder] = []


class _RunFolder:
    def __init__(self, path: Path, command: str, existing: set[str]):
        self.path = path
        self.command = command
        self.foreign = existing  # top-level entries present before the run and kept
        self.created: list[Path] = []  # folders this run created (deepest last)


def _entries(path: Path) -> set[str]:
    try:
        return {p.name for p in path.iterdir()}
    except OSError:
        return set()


def _previous_run_files(path: Path, entries: set[str]) -> set[str]:
    """Top-level entries of ``path`` that a previous biped run wrote."""
    files = set()
    if MANIFEST in entries:
        files.add(MANIFEST)
        try:
            listed = json.loads((path / MANIFEST).read_text(encoding="utf-8")).get("files", [])
            files |= {
                Path(f).parts[0]
                for f in listed
                if isinstance(f, str) and f and not Path(f).is_absolute() and ".." not in Path(f).parts
            }
        except (OSError, ValueError, AttributeError):
            pass
    files |= entries & set(KNOWN_OUTPUTS)
    return files & entries


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
    (or the nearest existing ancestor, the folders are created later) must accept a new file."""
    path = Path(path)
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
    if out is not None and str(out) != "":
        path = Path(out)
    else:
        stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
        path = Path("runs") / f"{prefix}-{stamp}"
        k = 1
        while path.exists():
            k += 1
            path = Path("runs") / f"{prefix}-{stamp}-{k}"
    _check_writable(path, flag)
    entries = _entries(path) if path.is_dir() else set()
    previous = _previous_run_files(path, entries)
    foreign = entries - previous
    if entries and not overwrite:
        if previous & set(_RUN_MARKERS):
            what = "already holds a run"
            kind = _previous_command(path)
            if kind:
                what += f" of 'biped {kind}'"
        else:
            shown = sorted(entries)[:3]
            what = (
                f"is not empty ({', '.join(shown)}{', ...' if len(entries) > 3 else ''}) and "
                f"holds no biped run"
            )
        raise ScenarioError(
            f"{flag} {str(path)!r} {what}; choose a new or empty folder, or pass "
            f"--overwrite (removes the previous run's files, keeps files biped did "
            f"not write)"
        )
    folder = _RunFolder(path, prefix, foreign)
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
    folder.created = missing[::-1]
    for name in previous:  # --overwrite: nothing of the previous run survives
        target = path / name
        try:
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target)
            else:
                target.unlink()
        except OSError as exc:
            raise ScenarioError(
                f"--overwrite: cannot remove {str(target)!r} ({exc.strerror or exc})"
            ) from None
    _OPEN.append(folder)
    return path


def _previous_command(path: Path) -> str:
    try:
        return str(json.loads((path / MANIFEST).read_text(encoding="utf-8")).get("command", ""))
    except (OSError, ValueError, AttributeError):
        return ""


def finish_runs(ok: bool, command: str = "") -> None:
    """Close the folders registered by :func:`run_dir`: on success write each one's manifest; on
    failure remove the folders the run created if they are still empty."""
    while _OPEN:
        folder = _OPEN.pop()
        if ok:
            files = sorted(
                str(p.relative_to(folder.path))
                for p in folder.path.rglob("*")
                if p.is_file()
                and p.relative_to(folder.path).parts[0] not in folder.foreign
                and p.name != MANIFEST
            )
            try:
                (folder.path / MANIFEST).write_text(
                    json.dumps({"command": command or folder.command, "files": files}, indent=1) + "\n",
                    encoding="utf-8",
                )
            except OSError:
                pass
        else:
            for p in reversed(folder.created):
                try:
                    p.rmdir()  # only if empty
                except OSError:
                    break


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
