"""Every file biped writes or reads from the user, through one small set of functions.

Writing (:func:`atomic_open`, :func:`write_text`, :func:`write_bytes`, :func:`write_via`):

- the content goes to a new temporary file in the target's own folder, created with
  ``O_CREAT | O_EXCL | O_NOFOLLOW`` (never an existing file, never through a symbolic link), and
  is moved into place with ``os.replace`` only when it is complete: a write error (full disk,
  permissions) leaves the previous file as it was and no temporary file behind;
- a symbolic link where biped would write is refused (:class:`LinkError`), never followed, and so
  is a link in place of a folder biped writes into (:func:`check_no_link`);
- every path written is recorded (:func:`written`), so a run's manifest lists exactly the files
  biped wrote.

Reading (:func:`read_input`, :func:`check_input_file`): a file given on the command line (scenario,
sweep grid, model) must be a regular file no larger than a stated limit; a device (``/dev/zero``),
a fifo, a socket or a folder is refused with words that say which.
"""

from __future__ import annotations

import contextlib
import errno
import itertools
import os
import re
import secrets
import stat
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

from biped.errors import BipedError, ScenarioError

__all__ = [
    "MAX_MODEL_BYTES",
    "MAX_TEXT_BYTES",
    "LinkError",
    "WriteError",
    "atomic_open",
    "check_input_file",
    "check_no_link",
    "mark",
    "open_exclusive",
    "place",
    "stale_temps",
    "read_input",
    "temp_path",
    "write_bytes",
    "write_text",
    "write_via",
    "written",
]

#: The largest scenario or sweep file (TOML) biped reads [bytes].
MAX_TEXT_BYTES = 1 << 20
#: The largest model file (MJCF) biped reads [bytes].
MAX_MODEL_BYTES = 16 << 20

_WRITTEN: dict[Path, int] = {}  # absolute path -> when it was last written (a counter)
_CLOCK = itertools.count(1)
_TMP_TAG = ".biped-tmp"


class LinkError(ScenarioError):
    """A symbolic link where biped would write: refused, never followed."""


class WriteError(OSError):
    """A file could not be written (full disk, permissions); the previous file, if any, is kept."""


def mark() -> int:
    """The current write counter, for :func:`written`'s ``since``."""
    return next(_CLOCK)


def written(since: int = 0) -> set[Path]:
    """Absolute paths of every file written through this module in this process after
    :func:`mark` returned ``since``."""
    return {p for p, t in _WRITTEN.items() if t > since}


def check_no_link(path: str | os.PathLike, what: str = "output") -> Path:
    """``path`` if it is not a symbolic link, else :class:`LinkError`."""
    path = Path(path)
    if path.is_symlink():
        raise LinkError(
            f"{what} {str(path)!r} is a symbolic link; biped does not write through links "
            f"(remove it, or choose another place)"
        )
    return path


def _nofollow() -> int:
    return getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)


def open_exclusive(path: str | os.PathLike, mode: int = 0o644) -> int:
    """A new file at ``path`` opened for writing (``O_CREAT | O_EXCL | O_NOFOLLOW``): fails if
    anything, a link included, is there already. Returns the descriptor."""
    return os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _nofollow(), mode)


def temp_path(path: str | os.PathLike) -> tuple[int, Path]:
    """A new empty temporary file beside ``path`` (same folder, same suffix, hidden name) and its
    open descriptor."""
    path = Path(path)
    for _ in range(100):
        tmp = path.with_name(f".{path.stem}.{secrets.token_hex(4)}{_TMP_TAG}{path.suffix}")
        try:
            return open_exclusive(tmp), tmp
        except FileExistsError:
            continue
    raise FileExistsError(errno.EEXIST, "no free temporary name", str(path))  # pragma: no cover


def stale_temps(path: str | os.PathLike) -> list[Path]:
    """The temporary files of ``path`` (:func:`temp_path`'s names) left beside it by a process
    killed while writing (SIGKILL runs no cleanup); for a caller that holds ``path``'s lock."""
    path = Path(path)
    pattern = re.compile(rf"^\.{re.escape(path.stem)}\.[0-9a-f]{{8}}{re.escape(_TMP_TAG + path.suffix)}$")
    try:
        return sorted(p for p in path.parent.iterdir() if pattern.match(p.name) and not p.is_symlink())
    except OSError:
        return []


def _as_write_error(exc: OSError, path: Path) -> WriteError:
    """The error of a failed write, naming the file it was for (not the temporary one)."""
    return WriteError(exc.errno, exc.strerror or str(exc), str(path))


def place(tmp: Path, path: Path) -> None:
    """Move the finished temporary file ``tmp`` to ``path`` (refused if ``path`` is a link)."""
    check_no_link(path)
    if path.is_dir():
        raise ScenarioError(f"{str(path)!r} is a folder where biped would write a file; remove it")
    os.replace(tmp, path)
    _WRITTEN[path.absolute()] = next(_CLOCK)


@contextlib.contextmanager
def atomic_open(
    path: str | os.PathLike, mode: str = "w", *, encoding: str | None = None, newline: str | None = None
) -> Iterator[IO[Any]]:
    """``with atomic_open(path) as fh: fh.write(...)``: the file appears at ``path`` complete,
    when the block ends without an error (see the module docstring)."""
    path = check_no_link(path)
    if "b" not in mode and encoding is None:
        encoding = "utf-8"
    fd, tmp = temp_path(path)
    try:
        try:
            with os.fdopen(fd, mode, encoding=encoding, newline=newline) as fh:
                yield fh
                fh.flush()
                os.fsync(fh.fileno())
        except OSError as exc:
            raise _as_write_error(exc, path) from None
        place(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def write_text(
    path: str | os.PathLike, text: str, *, encoding: str = "utf-8", newline: str | None = None
) -> Path:
    """Write ``text`` to ``path`` atomically, never through a link."""
    with atomic_open(path, "w", encoding=encoding, newline=newline) as fh:
        fh.write(text)
    return Path(path)


def write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically, never through a link."""
    with atomic_open(path, "wb") as fh:
        fh.write(data)
    return Path(path)


def write_via(path: str | os.PathLike, make: Callable[[Path], Any]) -> Any:
    """For a library that writes a file by name (``savefig``, ``pq.write_table``, ffmpeg):
    ``make(tmp)`` writes a temporary file beside ``path`` (same suffix), which then replaces
    ``path``. An exception of ``make`` leaves ``path`` as it was. Returns what ``make`` returns."""
    path = check_no_link(path)
    fd, tmp = temp_path(path)
    os.close(fd)
    try:
        try:
            result = make(tmp)
            if not tmp.is_file() or tmp.is_symlink():
                raise WriteError(errno.EIO, "the writer left no file", str(path))
            fd = os.open(tmp, os.O_RDONLY | _nofollow())
            try:
                os.fsync(fd)  # on disk before it replaces the previous file
            finally:
                os.close(fd)
        except WriteError:
            raise
        except OSError as exc:
            raise _as_write_error(exc, path) from None
        place(tmp, path)
        return result
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


# ---------------------------------------------------------------------------------------------
# reading


def _describe(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISFIFO(mode):
        return "a fifo (named pipe)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _open_input(path: str | os.PathLike, kind: str, limit: int, error: type[BipedError]) -> tuple[int, int]:
    if str(path) == "":
        raise error(f"{kind} file: the path is empty; name a file")
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        if exc.errno == errno.EISDIR:
            raise error(f"{kind} file {str(path)!r} is a folder; name a file") from None
        raise error(f"cannot read {kind} file {str(path)!r}: {exc.strerror or exc}") from None
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        raise error(f"{kind} file {str(path)!r} is {_describe(st.st_mode)}; name a regular file")
    if st.st_size > limit:
        os.close(fd)
        raise error(
            f"{kind} file {str(path)!r} is {st.st_size / 2**20:.1f} MiB, more than the "
            f"{limit / 2**20:g} MiB a {kind} file may hold"
        )
    return fd, st.st_size


def check_input_file(
    path: str | os.PathLike, kind: str, limit: int = MAX_TEXT_BYTES, error: type[BipedError] = ScenarioError
) -> Path:
    """Raise ``error`` unless ``path`` is a regular file of at most ``limit`` bytes."""
    fd, _ = _open_input(path, kind, limit, error)
    os.close(fd)
    return Path(path)


def read_input(
    path: str | os.PathLike, kind: str, limit: int = MAX_TEXT_BYTES, error: type[BipedError] = ScenarioError
) -> bytes:
    """The bytes of the regular file ``path`` (at most ``limit``; anything else raises
    ``error`` naming the ``kind`` of file)."""
    fd, _ = _open_input(path, kind, limit, error)
    try:
        chunks, total = [], 0
        while True:
            chunk = os.read(fd, 1 << 16)
            if not chunk:
                break
            total += len(chunk)
            if total > limit:  # grew while being read
                raise error(f"{kind} file {str(path)!r} is more than {limit / 2**20:g} MiB")
            chunks.append(chunk)
        return b"".join(chunks)
    except OSError as exc:
        raise error(f"cannot read {kind} file {str(path)!r}: {exc.strerror or exc}") from None
    finally:
        os.close(fd)
