"""Where numba keeps the package's compiled kernels: somewhere this user can write, and never a
kernel compiled from other sources than these.

numba caches a ``cache=True`` function under a key of *its own* source file's time stamp; a
kernel that reads another module's constant or calls another module's kernel keeps its cached
machine code when only that other module changes (a ``git pull`` into an editable install, a
branch switched): it then runs with the old constant, silently (it happened here: a buffer layout
constant changed in ``control/qp_buffers.py`` and the QP call, cached, kept the old layout).
:func:`configure` runs from ``biped/__init__.py``, before any module that defines a kernel is
imported (numba picks the folder when a function is decorated), and, unless ``NUMBA_CACHE_DIR`` is
set (the user's choice stands), points numba at a folder named by :func:`source_stamp`, the hash
of the sources a kernel can compile in (:func:`kernel_sources`: every module that defines a
kernel and every package module those import, at any depth): any change to one of them compiles
every kernel afresh (the first run after it takes the first-run compile time again); a change to
another module (the CLI, outputs, plots, analyses, sweeps; once, every one) keeps the cache. The
folder is
``biped/__pycache__/numba/<stamp>`` when the package folder is writable, else
``$XDG_CACHE_HOME/biped/numba/<stamp>`` (default ``~/.cache/...``), or a per-user folder under the
temporary directory when that cannot be created; the stamps' folders of older sources there are
removed, the newest :data:`KEEP_STAMPS` kept. It imports nothing from biped.

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
import re
import sys
import tempfile
import threading
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


#: The folder :func:`configure` chose (None: the user's NUMBA_CACHE_DIR, or numba's own).
_CONFIGURED: str | None = None
#: How many stamps' cache folders (the newest) :func:`configure` keeps beside the current one's.
KEEP_STAMPS = 2


#: What marks a module that defines a compiled kernel: numba's decorators or its ``njit(...)`` call.
_KERNEL = ("@njit", "@jit", "@cfunc", "@vectorize", "@guvectorize", "njit(")
#: An import statement, anywhere in a file: ``from X import (names)`` / ``from X import names``
#: (group 1, 2) or ``import X, Y as Z`` (group 3).
_IMPORT = re.compile(
    r"^[ \t]*(?:from[ \t]+([\w.]+)[ \t]+import[ \t]+(\([^)]*\)|[^\n]*)|import[ \t]+([^\n]+))", re.M
)


def _modules(package: Path) -> dict[str, Path]:
    """``{dotted name: file}`` of the package's Python modules (a package by its ``__init__``)."""
    out = {}
    for path in package.rglob("*.py"):
        parts = path.relative_to(package.parent).with_suffix("").parts
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def _imports(text: str, name: str, is_package: bool, modules: dict[str, Path]) -> set[str]:
    """The modules of ``modules`` that source ``text`` (module ``name``) imports, with their parent
    packages. A superset, read from the text: every import statement at any depth (inside
    functions too, or a docstring's example), and every name imported from a module that is a
    module itself."""
    here = name if is_package else name.rpartition(".")[0]
    wanted: list[str] = []
    for base, names, plain in _IMPORT.findall(text):
        if plain:
            wanted += [n.split(" as ")[0].strip() for n in plain.split(",")]
            continue
        level = len(base) - len(base.lstrip("."))
        if level:  # relative: from the module's package, up level - 1
            parts = here.split(".")
            base = ".".join([*parts[: len(parts) - level + 1], base[level:]]).rstrip(".")
        wanted.append(base)
        for n in names.strip("()").split(","):
            n = n.split("#")[0].split(" as ")[0].strip()
            if n:
                wanted.append(f"{base}.{n}")
    found: set[str] = set()
    for w in wanted:
        parts = w.split(".")
        found.update(m for m in (".".join(parts[:i]) for i in range(1, len(parts) + 1)) if m in modules)
    return found


def kernel_sources(package: Path = PACKAGE_DIR) -> list[Path]:
    """The package's Python files a compiled kernel can compile in, sorted: those that define a
    kernel (:data:`_KERNEL`) and every package module they import, at any depth (:func:`_imports`:
    a kernel reads only its own module's globals, which come from its imports)."""
    modules = _modules(package)
    texts = {name: path.read_text(encoding="utf-8") for name, path in modules.items()}
    todo = [name for name, text in texts.items() if any(mark in text for mark in _KERNEL)]
    seen: set[str] = set()
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        is_package = modules[name].name == "__init__.py"
        todo += _imports(texts[name], name, is_package, modules) - seen
    return sorted(modules[name] for name in seen)


def source_stamp(package: Path = PACKAGE_DIR) -> str:
    """A hash of :func:`kernel_sources` (their paths and bytes), 16 hex digits."""
    h = hashlib.sha256()
    for path in kernel_sources(package):
        h.update(path.relative_to(package).as_posix().encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


def _prune(base: Path, keep: str) -> None:
    """Remove the stamps' folders under ``base`` but ``keep`` and the newest :data:`KEEP_STAMPS`."""
    import shutil

    try:
        old = sorted(
            (p for p in base.iterdir() if p.is_dir() and p.name != keep and len(p.name) == 16),
            key=lambda p: p.stat().st_mtime,
            reverse=True,
        )
        for p in old[KEEP_STAMPS:]:
            shutil.rmtree(p, ignore_errors=True)
    except OSError:
        pass


def configure() -> str | None:
    """Point numba's cache at the folder of this source stamp (module docstring); returns the
    folder set, or None when ``NUMBA_CACHE_DIR`` was set by the user."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return None
    stamp = source_stamp()
    pycache = PACKAGE_DIR / "__pycache__"
    if os.access(pycache if pycache.exists() else PACKAGE_DIR, os.W_OK):
        base = pycache / "numba"
    else:
        base = user_cache_dir()
    folder_path = base / stamp
    try:
        folder_path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None  # numba's own choice, and its own error if it cannot write either
    _prune(base, stamp)
    folder = str(folder_path)
    global _CONFIGURED
    _CONFIGURED = folder
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
    """Beside the stamps' folders (the compile times outlive a change of the sources)."""
    folder = os.environ.get("NUMBA_CACHE_DIR")
    if folder:  # beside the stamps' folders when configure chose it, else in the user's folder
        return (Path(folder).parent if folder == _CONFIGURED else Path(folder)) / "biped-compile-times.json"
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


def key_by_sources(dispatcher, modules) -> None:
    """Key the numba dispatcher ``dispatcher``'s cache by the source files of ``modules`` too (their
    time stamps and sizes, beside its own file's): numba keys a cached kernel by its own file only,
    so a kernel that compiles in another module's constants or kernels would load stale machine
    code when only that module changed and the cache folder is not :func:`configure`'s (a
    ``NUMBA_CACHE_DIR`` of the user's; configure's folder changes with every source). Call it right
    after the decoration, before the kernel is compiled or loaded. Uses numba's cache internals (as
    :func:`is_cached` does); without them, numba's own key stands."""
    try:
        cache_file = dispatcher._cache._cache_file
        stats = [os.stat(str(m.__file__)) for m in modules]
        extra = tuple((st.st_mtime, st.st_size) for st in stats)
        cache_file._source_stamp = (cache_file._source_stamp, extra)
    except (AttributeError, OSError, TypeError):  # pragma: no cover - another numba, or no cache
        pass


#: One lock for every kernel's one-time compile (:func:`compile_once`); re-entrant, so that a
#: compile that needs another kernel compiled in the same thread does not wait on itself.
_COMPILE_LOCK = threading.RLock()


def compile_once(kernel, signature) -> None:
    """Compile the numba dispatcher ``kernel`` for its one ``signature`` (or load it from numba's
    cache) and allow no other; a no-op once done, or when numba's JIT is disabled (a plain
    function has no ``compile``). Under a lock: two threads of one process (a Dask worker's)
    would race between the check and ``disable_compile()``, and the second one's ``compile()``
    then raises "compilation disabled"."""
    with _COMPILE_LOCK:
        if not hasattr(kernel, "compile") or kernel.signatures:
            return
        kernel.compile(signature)
        kernel.disable_compile()
