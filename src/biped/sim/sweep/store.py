"""Where a sweep's rows live: a lock, this run's part file, one consolidated Parquet file.

- **Lock**: ``<out>.lock`` (``flock``, released by the kernel when the process dies): a second
  sweep on the same ``--out`` is refused, never interleaved.
- **Parts**: while it runs, a sweep appends every finished trial at once to its own part file
  ``<out>.parts/part-<time>-<pid>.arrows`` (an Arrow IPC stream, one record batch per write, no
  buffering in the process): a killed process loses only the trials still in flight. A torn last
  batch (killed while writing) is skipped when read.
- **Consolidation**: when every trial is done, the last row of each trial goes into ONE Parquet
  file ``<out>`` (sorted by trial index; schema metadata: the sweep, the base scenario, the model
  file's SHA-256, the package version) and the part files that were read into it are removed.
- **Same sweep or refused**: a rerun on an existing ``<out>`` must be the same sweep, or one
  whose grid extends it (more values on an axis); anything else is refused naming the difference,
  unless ``overwrite``. The model is compared as MuJoCo compiles it (included files count), grid
  values as numbers to a relative ``GRID_RTOL``.
- **No links**: the lock, the parts folder, its files and ``<out>`` are never written through a
  symbolic link (:mod:`biped.files`); ``<out>`` is replaced atomically.
"""

from __future__ import annotations

import errno
import fcntl
import json
import math
import os
import stat
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from biped import __version__
from biped import files as _files
from biped.errors import ScenarioError
from biped.sim.scenario import Scenario, stored_values
from biped.sim.sweep.record import schema
from biped.sim.sweep.spec import AXES, GRID_RTOL, SweepSpec, Trial

MANIFEST = "sweep.json"


def parts_dir(out: Path) -> Path:
    """The folder of an unfinished sweep's part files: ``<out>.parts``."""
    return out.with_name(out.name + ".parts")


def lock_path(out: Path) -> Path:
    return out.with_name(out.name + ".lock")


# ---------------------------------------------------------------------------------------------
# lock


class SweepLock:
    """An exclusive lock on ``out`` for one process (``flock`` on ``<out>.lock``, non-blocking).

    The kernel releases it when the process dies, however it dies; the file holds the owner's
    pid for the message of a refused second sweep. Use as a context manager.
    """

    def __init__(self, out: Path):
        self.out = out
        self.path = lock_path(out)
        self.fd: int | None = None

    def acquire(self) -> None:
        flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
        while True:
            _files.check_no_link(self.path, "the lock file")
            try:
                fd = os.open(self.path, flags | os.O_NONBLOCK, 0o644)
            except OSError as exc:
                if exc.errno == errno.ELOOP:  # a link planted between the check and the open
                    _files.check_no_link(self.path, "the lock file")
                raise
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                os.close(fd)
                raise ScenarioError(f"the lock file {str(self.path)!r} is not a regular file; remove it")
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                owner = os.read(fd, 64).decode(errors="replace").strip() or "?"
                os.close(fd)
                raise ScenarioError(
                    f"another sweep (pid {owner}) is writing {str(self.out)!r}; wait for it to "
                    f"finish (a rerun then skips its trials) or choose another --out"
                ) from None
            # the file may have been released and removed between our open and flock: retry
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.path))
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self.fd = fd

    def release(self) -> None:
        if self.fd is None:
            return
        try:
            os.unlink(self.path)  # while still holding it (see the samestat check above)
        except FileNotFoundError:
            pass
        os.close(self.fd)
        self.fd = None

    def __enter__(self) -> SweepLock:
        self.acquire()
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


# ---------------------------------------------------------------------------------------------
# this run's part file


class PartWriter:
    """Appends rows to this run's part file, each :meth:`write` one record batch straight to the
    operating system (an unbuffered ``pyarrow.OSFile``): once ``write`` returns, the rows survive
    the death of this process."""

    def __init__(self, directory: Path):
        self.dir = directory
        self.path = directory / f"part-{time.time_ns():020d}-{os.getpid()}.arrows"
        self._sink: Any = None
        self._writer: Any = None
        self.rows_written = 0

    def write(self, rows: list[dict]) -> None:
        if not rows:
            return
        if self._writer is None:
            check_parts_dir(self.dir)
            fd = _files.open_exclusive(self.path)  # a new file, never through a link
            self._sink = pa.PythonFile(os.fdopen(fd, "wb", buffering=0), mode="w")
            self._writer = pa.ipc.new_stream(self._sink, schema())
        self._writer.write_batch(pa.RecordBatch.from_pylist(rows, schema=schema()))
        self._sink.flush()
        self.rows_written += len(rows)

    def close(self) -> None:
        if self._writer is not None:
            self._writer.close()
            self._sink.close()
            self._writer = self._sink = None


def read_part(path: Path) -> pa.Table:
    """The rows of one part file; a torn last batch (the writer was killed mid-write) is left
    out. Reads the Parquet parts of earlier versions too."""
    if path.suffix == ".parquet":
        try:
            return pq.read_table(path, schema=schema())
        except Exception as exc:  # noqa: BLE001 - any unreadable part is refused the same way
            raise _foreign_part(path, f"not a readable Parquet file of this schema: {exc}") from None
    with open(path, "rb") as f:
        head = f.read(4)
    if head and not _STREAM_START.startswith(head):  # not torn: not an Arrow stream at all
        raise _foreign_part(path, "not an Arrow stream")
    batches = []
    try:
        with pa.OSFile(str(path), "rb") as f:
            reader = pa.ipc.open_stream(f)
            if not reader.schema.equals(schema(), check_metadata=False):
                raise _foreign_part(path, "its columns are not those of this version's sweep rows")
            while True:
                try:
                    batches.append(reader.read_next_batch())
                except StopIteration:
                    break
    except (pa.ArrowInvalid, OSError, EOFError):
        pass  # empty, or torn at the end: keep the complete batches
    return pa.Table.from_batches(batches, schema=schema())


#: The first bytes of every Arrow IPC stream (the continuation marker).
_STREAM_START = b"\xff\xff\xff\xff"


def _foreign_part(path: Path, why: str) -> ScenarioError:
    return ScenarioError(
        f"{str(path)!r} is not a part file of a biped sweep ({why}); move it out of "
        f"{str(path.parent)!r} and run again"
    )


def part_files(directory: Path) -> list[Path]:
    """Every part file in ``directory``, oldest first (later rows of a trial win)."""
    if not directory.is_dir():
        return []
    return sorted([*directory.glob("part-*.parquet"), *directory.glob("part-*.arrows")], key=lambda p: p.name)


def read_rows(out: Path) -> tuple[pa.Table, list[Path]]:
    """Every row ``out`` and its parts hold (file first, then parts oldest first), and the part
    files read."""
    files = part_files(parts_dir(out))
    tables = [pq.read_table(out, schema=schema())] if out.exists() else []
    tables += [read_part(p) for p in files]
    table = pa.concat_tables(tables) if tables else schema().empty_table()
    return table, files


# ---------------------------------------------------------------------------------------------
# same sweep, an extension, or refused


def _fmt_values(values: list[float]) -> str:
    v = sorted(values)
    shown = ", ".join(f"{x:g}" for x in v[:6]) + (", ..." if len(v) > 6 else "")
    return f"{len(v)} value{'s' * (len(v) != 1)} [{shown}]"


def _defaults_of_new_keys() -> dict:
    """The perturbation paradigms' and the nervous system's scenario keys (added after sweeps
    existed) at their defaults."""
    from biped.sim.perturbations import PARADIGMS
    from biped.sim.scenario import Scenario

    d = Scenario().to_dict()
    keys = {"perturbation", *(k for cls in PARADIGMS.values() if cls.name != "block" for k in cls.keys)}
    keys |= {"neuromotor", "feedback_delay_s", "torque_rate_limit_n_m_s", "activation_time_s", "ankle_only"}
    return {k: d[k] for k in keys if k in d}  # keys left out at their default are absent anyway


def _same(a: Any, b: Any) -> bool:
    return (
        isinstance(a, (int, float)) and isinstance(b, (int, float)) and math.isclose(a, b, rel_tol=GRID_RTOL)
    )


def _missing(old: list, new: list) -> list:
    """The values of ``old`` that ``new`` lacks (numbers compared to :data:`GRID_RTOL`)."""
    return [a for a in old if not any(_same(a, b) for b in new)]


def spec_difference(
    old: dict, old_model_sha256: str | None, spec: SweepSpec, old_compiled_sha256: str | None = None
) -> str | None:
    """``None`` if ``spec`` is the sweep described by ``old`` (a :meth:`SweepSpec.to_dict`) or
    extends its grid (every old value of every axis is still there, to a relative
    :data:`~biped.sim.sweep.spec.GRID_RTOL`, so every old trial is a trial of ``spec``); else what
    differs, in words, naming the first value that differs with all its digits. The model is
    compared compiled (``old_compiled_sha256``: included files count); a file of an earlier
    version, without that hash, by the top-level file's SHA-256."""
    new = spec.to_dict()
    diffs = []
    old_scen, new_scen = stored_values(old.get("scenario", {})), new["scenario"]
    added = _defaults_of_new_keys()
    for k in sorted(set(old_scen) | set(new_scen)):
        if k not in old_scen and k in added and new_scen.get(k) == added[k]:
            continue  # a key added since the file was written, at its default: the same experiment
        if old_scen.get(k) != new_scen.get(k):
            diffs.append(f"scenario key {k}: {old_scen.get(k)!r} in the file, {new_scen.get(k)!r} now")
    for k in ("launch_distance_m", "model", "torque_limits", "samples", "seed", "robot"):
        if old.get(k) != new.get(k):
            diffs.append(f"{k}: {old.get(k)!r} in the file, {new.get(k)!r} now")
    if old_compiled_sha256:
        now = spec.model_compiled_sha256
        if old_compiled_sha256 != now:
            diffs.append(
                f"the model {str(spec.model_path)!r} compiles differently (it or a file it includes "
                f"changed: compiled SHA-256 {old_compiled_sha256[:12]}... in the file, {now[:12]}... now)"
            )
    elif old_model_sha256 and old_model_sha256 != spec.model_sha256:
        diffs.append(
            f"the model file {spec.model!r} changed (SHA-256 {old_model_sha256[:12]}... "
            f"in the file, {spec.model_sha256[:12]}... now)"
        )
    old_grid = old.get("grid", {})
    for name in AXES:
        a, b = list(old_grid.get(name, [])), new["grid"][name]
        lacking = _missing(a, b)
        if new["samples"] is not None:
            extra = _missing(b, a)
            if lacking or extra:
                first = f"{lacking[0]!r} in the file only" if lacking else f"{extra[0]!r} now only"
                diffs.append(f"{name}: {_fmt_values(a)} in the file, {_fmt_values(b)} now ({first})")
        elif lacking:
            diffs.append(
                f"{name}: {_fmt_values(a)} in the file, {_fmt_values(b)} now, which "
                f"lacks {len(lacking)} of them (first: {lacking[0]!r})"
            )
    return "; ".join(diffs) or None


def _stored_spec(out: Path) -> tuple[dict, str | None, str | None] | None:
    if not out.exists():
        return None
    try:
        meta = pq.read_schema(out).metadata or {}
    except Exception as exc:  # noqa: BLE001 - any unreadable file is refused the same way
        raise ScenarioError(
            f"--out {str(out)!r} exists and is not a readable Parquet file "
            f"({exc}); choose another path or pass --overwrite"
        ) from None
    if b"biped.sweep" not in meta:
        raise ScenarioError(
            f"--out {str(out)!r} is not a biped sweep file; choose another path or pass --overwrite"
        )
    sha = meta.get(b"biped.model_sha256")
    compiled = meta.get(b"biped.model_compiled_sha256")
    try:
        stored = json.loads(meta[b"biped.sweep"])
    except ValueError:
        stored = None
    if not isinstance(stored, dict):
        raise ScenarioError(
            f"--out {str(out)!r} holds unreadable sweep metadata; choose another path or pass --overwrite"
        )
    return stored, sha.decode() if sha else None, compiled.decode() if compiled else None


def check_same_sweep(spec: SweepSpec, out: Path) -> None:
    """Refuse (:class:`ScenarioError`) if ``out`` or its parts hold a sweep that ``spec`` neither
    repeats nor extends. Call under the lock."""
    stored = _stored_spec(out)
    if stored is not None:
        diff = spec_difference(stored[0], stored[1], spec, stored[2])
        if diff:
            raise ScenarioError(
                f"--out {str(out)!r} holds a different sweep ({diff}); a rerun may only add "
                f"values to the grid. Choose another --out, or pass --overwrite to replace it"
            )
    manifest = parts_dir(out) / MANIFEST
    if manifest.exists():
        try:
            saved = json.loads(_files.read_input(manifest, "sweep manifest"))
        except (ValueError, ScenarioError):
            saved = None
        if not isinstance(saved, dict) or not isinstance(saved.get("sweep"), dict):
            raise ScenarioError(
                f"{str(manifest)!r} is not a biped sweep's manifest, so the parts beside it cannot "
                f"be matched to this sweep; move {str(parts_dir(out))!r} away, or pass --overwrite "
                f"to discard it"
            )
        diff = spec_difference(
            saved.get("sweep", {}), saved.get("model_sha256"), spec, saved.get("model_compiled_sha256")
        )
        if diff:
            raise ScenarioError(
                f"{str(parts_dir(out))!r} holds the unfinished parts of a different sweep "
                f"({diff}). Finish it with its own command, choose another --out, or pass "
                f"--overwrite to discard it"
            )


def remove_stale_temps(out: Path) -> None:
    """Remove the temporary files that a killed sweep on ``out`` left (of ``out`` and of the
    parts folder's manifest); call under the lock."""
    for p in [*_files.stale_temps(out), *_files.stale_temps(parts_dir(out) / MANIFEST)]:
        p.unlink(missing_ok=True)


def remove_sweep(out: Path) -> None:
    """``--overwrite``: remove ``out`` and its parts (call under the lock)."""
    if out.exists():
        out.unlink()
    pdir = parts_dir(out)
    for p in part_files(pdir):
        p.unlink()
    for p in pdir.glob("part-*.tmp") if pdir.is_dir() else ():
        p.unlink()
    (pdir / MANIFEST).unlink(missing_ok=True)
    if pdir.is_dir():
        try:
            pdir.rmdir()
        except OSError:
            raise ScenarioError(
                f"{str(pdir)!r} holds files that are not a sweep's parts; remove them yourself"
            ) from None


def check_parts_dir(pdir: Path) -> None:
    """Refuse a ``<out>.parts`` that is a link, or something other than a folder."""
    _files.check_no_link(pdir, "the parts folder")
    if pdir.exists() and not pdir.is_dir():
        raise ScenarioError(f"{str(pdir)!r} is not a folder (a sweep keeps its parts there); remove it")


def write_manifest(spec: SweepSpec, out: Path) -> None:
    pdir = parts_dir(out)
    check_parts_dir(pdir)
    pdir.mkdir(exist_ok=True)
    _files.write_text(
        pdir / MANIFEST,
        json.dumps(
            {
                "sweep_id": spec.identity,
                "sweep": spec.to_dict(),
                "model_sha256": spec.model_sha256,
                "model_compiled_sha256": spec.model_compiled_sha256,
            }
        ),
    )


def metadata(spec: SweepSpec) -> dict[bytes, bytes]:
    return {
        b"biped.sweep": json.dumps(spec.to_dict()).encode(),
        b"biped.scenario": spec.base.to_toml().encode(),
        b"biped.model": (spec.model if spec.base.model == "wendlandt" else spec.base.model).encode(),
        b"biped.model_sha256": spec.model_sha256.encode(),
        b"biped.model_compiled_sha256": spec.model_compiled_sha256.encode(),
        b"biped.version": __version__.encode(),
        b"biped.sweep_id": spec.identity.encode(),
    }


def consolidate(spec: SweepSpec, out: Path, trials: Iterable[Trial]) -> int:
    """Write every finished trial (last row of each key, its index in ``trials``) into ONE
    Parquet file sorted by index, with the sweep's metadata; then remove the part files that
    were read into it (and nothing else). Call under the lock. Returns the number of rows."""
    table, files = read_rows(out)
    index = {t.key: t.index for t in trials}
    last = {r["trial_key"]: r for r in table.to_pylist()}
    rows = []
    for key, r in last.items():
        if key in index:
            rows.append({**r, "index": index[key]})
    rows.sort(key=lambda r: r["index"])
    result = pa.Table.from_pylist(rows, schema=schema().with_metadata(metadata(spec)))
    _files.write_via(out, lambda tmp: pq.write_table(result, tmp))  # atomic, never through a link
    pdir = parts_dir(out)
    for p in files:
        p.unlink(missing_ok=True)
    (pdir / MANIFEST).unlink(missing_ok=True)
    try:
        pdir.rmdir()
    except OSError:
        pass  # absent, or holds something this sweep did not write: leave it
    return result.num_rows


# ---------------------------------------------------------------------------------------------
# reading


@dataclass(frozen=True)
class SweepData:
    """A consolidated sweep file: its table (pyarrow) and metadata."""

    table: Any
    spec: dict
    scenario: Scenario
    model_sha256: str
    version: str

    def column(self, name: str) -> np.ndarray:
        return np.asarray(self.table.column(name).to_numpy(zero_copy_only=False))


def load(path: str | os.PathLike) -> SweepData:
    """Read a sweep's Parquet file (one row per trial) and its metadata."""
    path = Path(path)
    if not path.is_file():
        raise ScenarioError(f"no sweep file at {str(path)!r}")
    try:
        table = pq.read_table(path)
    except (pa.ArrowInvalid, OSError) as exc:
        raise ScenarioError(f"{str(path)!r} is not a readable Parquet file ({exc})") from None
    meta = table.schema.metadata or {}
    if b"biped.sweep" not in meta:
        raise ScenarioError(f"{str(path)!r} is not a biped sweep file (no biped.sweep metadata)")
    spec = json.loads(meta[b"biped.sweep"])
    return SweepData(
        table=table,
        spec=spec,
        scenario=Scenario.from_dict(stored_values(spec["scenario"])),
        model_sha256=meta[b"biped.model_sha256"].decode(),
        version=meta[b"biped.version"].decode(),
    )


__all__ = [
    "PartWriter",
    "SweepData",
    "SweepLock",
    "check_same_sweep",
    "consolidate",
    "load",
    "parts_dir",
    "read_part",
    "read_rows",
    "remove_sweep",
    "spec_difference",
]
