"""First-run cost of the compiled kernels (biped.sim.jit): the cache check agrees with numba's own
accounting, and the commands say "compiling ..." once, on a cold cache only.

Each case runs in a fresh interpreter with a fresh ``NUMBA_CACHE_DIR`` (numba picks its cache at
import). The oracle is numba itself: ``dispatcher.stats.cache_hits / cache_misses`` count what it
loaded from disk and what it had to compile.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

SRC = str(Path(__file__).resolve().parents[1] / "src")


def _python(code: str, cache: Path, cwd: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": os.pathsep.join([SRC, str(cwd)])}
    env.pop("NUMBA_DISABLE_JIT", None)
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code), *args],
        check=False,
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )


_KERNEL = """
from numba import njit

@njit(cache=True)
def twice(x):
    return 2.0 * x
"""

_PROBE = """
import json
import kernelmod
from biped.sim.jit import is_cached
before = is_cached(kernelmod.twice)
assert kernelmod.twice(1.5) == 3.0
stats = kernelmod.twice.stats
print(json.dumps({"before": before, "hits": sum(stats.cache_hits.values()),
                  "misses": sum(stats.cache_misses.values())}))
"""


def test_is_cached_agrees_with_numbas_cache(tmp_path):
    (tmp_path / "kernelmod.py").write_text(_KERNEL)
    cache = tmp_path / "cache"

    def probe():
        p = _python(_PROBE, cache, tmp_path)
        assert p.returncode == 0, p.stderr
        return json.loads(p.stdout.strip().splitlines()[-1])

    cold = probe()  # empty cache: numba compiles (a miss)
    assert cold == {"before": False, "hits": 0, "misses": 1}
    warm = probe()  # a new process: numba loads it (a hit, no miss)
    assert warm == {"before": True, "hits": 1, "misses": 0}
    (tmp_path / "kernelmod.py").write_text(_KERNEL.replace("2.0 * x", "x + x"))
    os.utime(tmp_path / "kernelmod.py", (1e9, 1e9))  # a different source stamp
    edited = probe()  # the source changed: numba compiles again, and is_cached knew it
    assert edited == {"before": False, "hits": 0, "misses": 1}


_PUSH = """
import sys
from biped.cli import main
assert main(["push", "--stepping", "--duration", "0.02", "--out", sys.argv[1],
             "--quiet", "--no-video", "--no-replay", "--no-figures"]) == 0
from biped.sim.contact import _contact_bits as k
print(sum(k.stats.cache_hits.values()), sum(k.stats.cache_misses.values()))
"""


@pytest.mark.slow
def test_cold_cache_says_compiling_once_then_nothing(tmp_path):
    """A fresh numba cache: ``biped sweep --stepping`` (the compiled loop, W's controller, the
    contact monitor, the response) says "compiling ..." once, in the parent before its two
    workers start, and the workers compile nothing (their trials are fast); a later stepping
    ``biped push`` in a new process says nothing and numba loads the contact monitor's kernel
    from the cache (its counters: a hit, no miss)."""
    import pyarrow.parquet as pq

    cache = tmp_path / "cache"
    out = tmp_path / "s.parquet"
    args = [
        "sweep",
        "--stepping",  # (since the compiled loop runs stepping, it compiles the loop too)
        "--speed",
        "2",
        "--direction",
        "0,180",
        "--duration",
        "0.02",
        "--workers",
        "2",
        "--quiet",
        "--out",
        str(out),
    ]
    p = _python(
        "import sys; from biped.cli import main; sys.exit(main(sys.argv[1:]))", cache, tmp_path, *args
    )
    assert p.returncode == 0, p.stderr
    lines = [ln for ln in p.stderr.splitlines() if ln.startswith("compiling")]
    assert len(lines) == 1 and "first run only" in lines[0], p.stderr
    assert "contact monitor" in lines[0] and "W's controller" in lines[0], p.stderr
    rows = pq.read_table(out).to_pylist()
    assert len(rows) == 2 and all(r["error"] is None for r in rows)
    # the workers compiled nothing (a cold kernel costs them tens of seconds, silently): each
    # 0.02 s trial takes well under the loop's compile time
    assert all(r["wall_time_s"] < 10.0 for r in rows), [r["wall_time_s"] for r in rows]
    assert len({r["worker"] for r in rows}) == 2  # two worker processes ran
    p = _python(_PUSH, cache, tmp_path, str(tmp_path / "push"))
    assert p.returncode == 0, p.stderr
    assert not any(ln.startswith("compiling") for ln in p.stderr.splitlines()), p.stderr
    hits, misses = map(int, p.stdout.split()[-2:])
    assert (hits, misses) == (1, 0)


def test_warm_up_one_line_when_cold_nothing_when_warm(monkeypatch):
    from biped.sim import jit

    compiled = []
    monkeypatch.setattr(jit, "_compile", compiled.append)
    for cold in (["controller", "qp", "contact"], ["contact"], []):
        monkeypatch.setattr(jit, "cold_kernels", lambda names, cold=cold: [n for n in names if n in cold])
        lines, compiled[:] = [], []
        jit.warm_up(jit.kernels_for("workspace", "qp"), log=lines.append)
        assert compiled == cold
        assert len(lines) == (1 if cold else 0)
        if cold:
            assert lines[0].startswith("compiling ") and "first run only" in lines[0]
            assert all(jit.KERNELS[n][0] in lines[0] for n in cold)
    assert "qp" not in jit.kernels_for("workspace")
    # every run is the compiled loop's (the joint PD's, the QP's and a stepping one's too)
    assert "loop" in jit.kernels_for("joint-pd") and "loop" in jit.kernels_for("workspace", "qp")
    # a robot's trial is robot_push's Python loop: compiling the push loop for it cost 43 s
    assert jit.kernels_for("workspace", "qp", sweep=True, robot=True) == ("controller", "qp")
    # a stepping run's swings call W's swing law (a robot's swing law is its own, in Python)
    assert "swing" in jit.kernels_for("workspace", "qp", stepping=True, sweep=True)
    assert "swing" not in jit.kernels_for("workspace", "qp", sweep=True)
    assert "swing" not in jit.kernels_for("workspace", "qp", stepping=True, robot=True)


def test_compile_runs_each_kernel():
    """_compile really runs each kernel (numba then holds compiled code for it)."""
    from biped.sim import jit

    for name in jit.KERNELS:
        jit._compile(name)
        assert jit._dispatcher(name).overloads, name
        assert jit.cold_kernels((name,)) == []


_API = """
import logging
import biped.models
from biped.control import WorkspaceController
a = WorkspaceController.from_mjcf(biped.models.path("wendlandt"))
b = WorkspaceController.from_mjcf(biped.models.path("wendlandt"))
print("built")
"""


def test_python_api_says_once_through_logging_that_it_compiles(tmp_path):
    """A cold cache: building W's controller from Python warns once, through ``logging`` (logger
    "biped", shown on stderr with no logging set up), that it compiles on first use; a second
    controller in the same process says nothing more. (Nothing is compiled here.)"""
    p = _python(_API, tmp_path / "cache", tmp_path)
    assert p.returncode == 0 and p.stdout.strip() == "built", p.stderr
    said = [ln for ln in p.stderr.splitlines() if "compiling W's controller on first use" in ln]
    assert len(said) == 1 and "~15 s" in said[0], p.stderr


def test_compile_estimate_is_measured_once_compiled_here(tmp_path, monkeypatch):
    """warm_up remembers each kernel's compile time (in numba's cache folder) and the next
    announcement quotes it; a "compile" that takes no time (a cache another process filled) is
    not remembered."""
    import time

    from biped.sim import jit

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    default = float(jit.KERNELS["controller"][1] + jit.KERNELS["contact"][1])
    assert jit.estimate_s(["controller", "contact"]) == (default, False)  # the table's defaults
    monkeypatch.setattr(jit, "_WARM", set())
    monkeypatch.setattr(jit, "cold_kernels", lambda names: list(names))
    monkeypatch.setattr(jit, "_compile", lambda n: time.sleep(0.6 if n == "contact" else 0.0))
    lines = []
    jit.warm_up(["controller", "contact"], log=lines.append)
    assert f"~{default:.0f} s" in lines[0] and "idle 2-core" in lines[0]
    assert jit.estimate_s(["contact"]) == (pytest.approx(0.6, abs=0.3), True)
    assert jit.estimate_s(["controller", "contact"])[1] is False  # the controller's not measured
    lines.clear()
    jit.warm_up(["contact"], log=lines.append)
    assert "measured on this machine" in lines[0]


def test_the_kernel_cache_folder_changes_with_the_sources_kernels_compile_in(tmp_path):
    """numba keys a kernel's cache on its own file; a constant changed in another module left a
    cached kernel stale (the QP call kept an old buffer layout). ``import biped`` puts numba's
    cache in a folder named by a hash of the sources kernels can compile in: a copy of the
    package, one constant of one such module edited, gets another folder, under its own
    ``__pycache__``; an edit of a module no kernel module imports (the envelope's table, the CLI)
    keeps the folder; the user's ``NUMBA_CACHE_DIR`` still wins."""
    import shutil

    pkg = tmp_path / "src" / "biped"
    shutil.copytree(Path(SRC) / "biped", pkg, ignore=shutil.ignore_patterns("__pycache__"))
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(tmp_path / "src")
    code = "import os, biped; print(os.environ['NUMBA_CACHE_DIR'])"

    def folder(extra=None):
        out = subprocess.run([sys.executable, "-c", code], env={**env, **(extra or {})}, capture_output=True,
                             text=True, check=True)  # fmt: skip
        return out.stdout.strip()

    first = folder()
    assert first.startswith(str(pkg / "__pycache__" / "numba")) and folder() == first
    for other in (pkg / "analysis" / "envelope_table.py", pkg / "cli" / "envelope.py"):
        other.write_text(other.read_text() + "\n_EDITED = 1\n")
    assert folder() == first
    buffers = pkg / "control" / "qp_buffers.py"
    buffers.write_text(buffers.read_text() + "\n_EDITED = 1\n")
    second = folder()
    assert second != first and Path(second).parent == Path(first).parent
    assert folder({"NUMBA_CACHE_DIR": str(tmp_path / "mine")}) == str(tmp_path / "mine")


def test_kernel_sources_hold_every_module_python_imports_with_them():
    """:func:`biped._numba_cache.kernel_sources` (read from the import statements' text) against
    Python's own imports: a fresh interpreter that imports every module of the list loads no other
    module of the package; the list holds every module that defines a kernel and leaves the
    command line, the plots and the outputs out."""
    from biped._numba_cache import PACKAGE_DIR, kernel_sources

    names = sorted(
        ".".join(p.relative_to(PACKAGE_DIR.parent).with_suffix("").parts).removesuffix(".__init__")
        for p in kernel_sources()
    )
    assert {"biped.sim.fused_kernel", "biped.control.recursions", "biped.sim.contact"} <= set(names)
    assert "biped.control.qp_buffers" in names  # no kernel; the QP call's compiles in its layout
    assert not any(n.startswith(("biped.cli", "biped.viz", "biped.outputs")) for n in names)
    code = "import importlib, sys\nfor n in sys.argv[1:]: importlib.import_module(n)\n"
    code += "print('\\n'.join(sorted(m for m in sys.modules if m == 'biped' or m.startswith('biped.'))))"
    env = {**os.environ, "PYTHONPATH": SRC, "NUMBA_DISABLE_JIT": "1"}
    out = subprocess.run(
        [sys.executable, "-c", code, *names], env=env, capture_output=True, text=True, check=True
    )
    loaded = set(out.stdout.split())
    assert loaded and loaded <= set(names), sorted(loaded - set(names))
