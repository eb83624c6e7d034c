"""Where numba keeps the package's compiled kernels: somewhere this user can write.

numba caches a ``cache=True`` function next to its source (``__pycache__``) and, when that folder
is not writable (a system-wide or read-only install), in a per-user folder; when neither is
writable it raises at import. :func:`configure` runs from ``biped/__init__.py``, before any module
that defines a kernel is imported (numba picks the folder when a function is decorated): if the
package folder is not writable and ``NUMBA_CACHE_DIR`` is unset, it points numba at
``$XDG_CACHE_HOME/biped/numba`` (default ``~/.cache/biped/numba``), or a per-user folder under the
temporary directory when that cannot be created. It imports nothing from biped.

It also tells whether a kernel's machine code is cached (:func:`is_cached`), says once through
Python's ``logging`` (logger ``"biped"``) that a kernel compiles on first use
(:func:`say_if_cold`), and remembers how long each kernel took to compile on this machine
(:func:`measured_compile_s`, :func:`record_compile_s`) so that the next announcement of a compile
gives a measured estimate.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import sys
import tempfile
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent

#: The package's logger: what it says on first use of a compiled kernel.
LOG = logging.getLogger("biped")
_SAID: set[str] = set()


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
        return True
    except OSError:
        return False


def user_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/biped/numba`` (``~/.cache/...``), else ``<tmp>/biped-numba-<user>``."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    folder = Path(base) / "biped" / "numba"
    if _writable(folder):
        return folder
    user = str(os.getuid()) if hasattr(os, "getuid") else os.environ.get("USERNAME", "user")
    return Path(tempfile.gettempdir()) / f"biped-numba-{user}"


def configure() -> str | None:
    """Set numba's cache folder when the package folder is not writable; returns the folder set,
    or None when numba's own choice (next to the sources, or ``NUMBA_CACHE_DIR``) stands."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return None
    pycache = PACKAGE_DIR / "__pycache__"
    if os.access(pycache if pycache.exists() else PACKAGE_DIR, os.W_OK):
        return None
    folder = str(user_cache_dir())
    os.environ["NUMBA_CACHE_DIR"] = folder
    config = sys.modules.get("numba.core.config")
    if config is not None:  # numba already imported: it read the environment then
        config.CACHE_DIR = folder  # type: ignore[attr-defined]
    return folder


def is_cached(dispatcher) -> bool | None:
    """True if numba's on-disk cache holds machine code of ``dispatcher`` for this CPU and this
    version of its source (what numba itself checks before it loads an entry: the source stamp
    in the index, then the code hash and the CPU in the entry's key); None if that cannot be told
    (caching off, or a numba whose cache layout differs)."""
    if getattr(dispatcher, "overloads", None):
        return True  # compiled in this process already
    cache = getattr(dispatcher, "_cache", None)
    try:
        index = cache._cache_file._load_index()  # type: ignore[union-attr]
        from numba.core.registry import cpu_target

        magic = cpu_target.target_context.codegen().magic_tuple()
        code = hashlib.sha256(dispatcher.py_func.__code__.co_code).hexdigest()
        return any(key[1] == magic and key[2][0] == code for key in index)
    except Exception:  # noqa: BLE001 - a numba without this layout, or no cache: cannot tell
        return None


def _timings_file() -> Path:
    folder = os.environ.get("NUMBA_CACHE_DIR")
    if folder:
        return Path(folder) / "biped-compile-times.json"
    pycache = PACKAGE_DIR / "__pycache__"
    if os.access(pycache if pycache.exists() else PACKAGE_DIR, os.W_OK):
        return pycache / "biped-compile-times.json"
    return user_cache_dir() / "biped-compile-times.json"


def measured_compile_s(name: str) -> float | None:
    """How long kernel ``name`` took to compile the last time on this machine [s], if known."""
    try:
        value = json.loads(_timings_file().read_text()).get(name)
        return float(value) if value is not None else None
    except (OSError, ValueError, AttributeError):
        return None


def record_compile_s(name: str, seconds: float) -> None:
    """Remember that kernel ``name`` took ``seconds`` to compile here (best effort)."""
    path = _timings_file()
    try:
        data = json.loads(path.read_text()) if path.is_file() else {}
        data[name] = round(float(seconds), 1)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(data))
    except (OSError, ValueError):
        pass


def mark_said(what: str) -> None:
    """Record that the compile of ``what`` was announced (by a command's own message)."""
    _SAID.add(what)


def say_if_cold(dispatcher, what: str, name: str, default_s: float) -> None:
    """Once per process: when ``dispatcher`` has no cached machine code, log (warning, logger
    ``"biped"``) that ``what`` compiles on its first use and about how long it takes (measured on
    this machine when it was compiled here before, else ``default_s``)."""
    if what in _SAID:
        return
    _SAID.add(what)  # said or found cached: not looked up again (it read the cache index, a trial)
    if is_cached(dispatcher):
        return
    measured = measured_compile_s(name)
    est = f"~{measured:.0f} s, measured here" if measured is not None else f"~{default_s:.0f} s"
    LOG.warning(
        "biped: compiling %s on first use (%s; once: later processes load it from numba's cache)",
        what,
        est,
    )
