"""Where numba keeps the package's compiled kernels: somewhere this user can write.

numba caches a ``cache=True`` function next to its source (``__pycache__``) and, when that folder
is not writable (a system-wide or read-only install), in a per-user folder; when neither is
writable it raises at import. :func:`configure` runs from ``biped/__init__.py``, before any module
that defines a kernel is imported (numba picks the folder when a function is decorated): if the
package folder is not writable and ``NUMBA_CACHE_DIR`` is unset, it points numba at
``$XDG_CACHE_HOME/biped/numba`` (default ``~/.cache/biped/numba``), or a per-user folder under the
temporary directory when that cannot be created. It imports nothing from biped.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent


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
