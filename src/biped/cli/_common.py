"""Helpers shared by the subcommands."""

from __future__ import annotations

import datetime as _dt
from pathlib import Path

from biped.errors import ScenarioError


def run_dir(out: str | None, prefix: str, *, overwrite: bool = False) -> Path:
    """The output folder of a run: ``out`` if given (refusing one that already holds a run unless
    ``overwrite``), else a new ``runs/<prefix>-<date>-<time>[-k]`` that does not exist yet."""
    if out:
        path = Path(out)
        if (path / "summary.json").exists() and not overwrite:
            raise ScenarioError(f"--out {str(path)!r} already holds a run (summary.json); choose "
                                f"another folder or pass --overwrite")
        return path
    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    path = Path("runs") / f"{prefix}-{stamp}"
    k = 1
    while path.exists():
        k += 1
        path = Path("runs") / f"{prefix}-{stamp}-{k}"
    return path
