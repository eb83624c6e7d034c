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
  unless ``overwrite``.
"""

from __future__ import annotations

import fcntl
import json
import os
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from biped import __version__
from biped.errors import ScenarioError
from biped.sim.scenario import Scenario
from biped.sim.sweep.record import schema
from biped.sim.sweep.spec import AXES, SweepSpec, Trial

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
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
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
            self._sink = pa.OSFile(str(self.path), "wb")
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
        return pq.read_table(path, schema=schema())
    batches = []
    try:
        with pa.OSFile(str(path), "rb") as f:
            reader = pa.ipc.open_stream(f)
            while True:
                try:
                    batches.append(reader.read_next_batch())
                except StopIteration:
                    break
    except (pa.ArrowInvalid, OSError, EOFError):
        pass  # empty, or torn at the end: keep the complete batches
    return pa.Table.from_batches(batches, schema=schema())


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
    return {k: d[k] for k in keys}


def spec_difference(old: dict, old_model_sha256: str | None, spec: SweepSpec) -> str | None:
    """``None`` if ``spec`` is the sweep described by ``old`` (a :meth:`SweepSpec.to_dict`) or
    extends its grid (every old value of every axis is still there, so every old trial is a
    trial of ``spec``); else what differs, in words."""
    new = spec.to_dict()
    diffs = []
    old_scen, new_scen = old.get("scenario", {}), new["scenario"]
    added = _defaults_of_new_keys()
    for k in sorted(set(old_scen) | set(new_scen)):
        if k not in old_scen and k in added and new_scen.get(k) == added[k]:
            continue  # a key added since the file was written, at its default: the same experiment
        if old_scen.get(k) != new_scen.get(k):
            diffs.append(f"scenario key {k}: {old_scen.get(k)!r} in the file, {new_scen.get(k)!r} now")
    for k in ("launch_distance_m", "model", "torque_limits", "samples", "seed"):
        if old.get(k) != new[k]:
            diffs.append(f"{k}: {old.get(k)!r} in the file, {new[k]!r} now")
    if old_model_sha256 and old_model_sha256 != spec.model_sha256:
        diffs.append(
            f"the model file {spec.model!r} changed (SHA-256 {old_model_sha256[:12]}... "
            f"in the file, {spec.model_sha256[:12]}... now)"
        )
    old_grid = old.get("grid", {})
    for name in AXES:
        a, b = old_grid.get(name, []), new["grid"][name]
        if new["samples"] is not None:
            if sorted(a) != sorted(b):
                diffs.append(f"{name}: {_fmt_values(a)} in the file, {_fmt_values(b)} now")
        elif not set(a) <= set(b):
            diffs.append(
                f"{name}: {_fmt_values(a)} in the file, {_fmt_values(b)} now, which "
                f"lacks {len(set(a) - set(b))} of them"
            )
    return "; ".join(diffs) or None


def _stored_spec(out: Path) -> tuple[dict, str | None] | None:
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
    return json.loads(meta[b"biped.sweep"]), sha.decode() if sha else None


def check_same_sweep(spec: SweepSpec, out: Path) -> None:
    """Refuse (:class:`ScenarioError`) if ``out`` or its parts hold a sweep that ``spec`` neither
    repeats nor extends. Call under the lock."""
    stored = _stored_spec(out)
    if stored is not None:
        diff = spec_difference(stored[0], stored[1], spec)
        if diff:
            raise ScenarioError(
                f"--out {str(out)!r} holds a different sweep ({diff}); a rerun may only add "
                f"values to the grid. Choose another --out, or pass --overwrite to replace it"
            )
    manifest = parts_dir(out) / MANIFEST
    if manifest.exists():
        try:
            saved = json.loads(manifest.read_text())
        except (OSError, ValueError):
            saved = {}
        diff = spec_difference(saved.get("sweep", {}), saved.get("model_sha256"), spec)
        if diff:
            raise ScenarioError(
                f"{str(parts_dir(out))!r} holds the unfinished parts of a different sweep "
                f"({diff}). Finish it with its own command, choose another --out, or pass "
                f"--overwrite to discard it"
            )


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


def write_manifest(spec: SweepSpec, out: Path) -> None:
    pdir = parts_dir(out)
    pdir.mkdir(exist_ok=True)
    (pdir / MANIFEST).write_text(
        json.dumps({"sweep_id": spec.identity, "sweep": spec.to_dict(), "model_sha256": spec.model_sha256})
    )


def metadata(spec: SweepSpec) -> dict[bytes, bytes]:
    return {
        b"biped.sweep": json.dumps(spec.to_dict()).encode(),
        b"biped.scenario": spec.base.to_toml().encode(),
        b"biped.model": (spec.model if spec.base.model == "wendlandt" else spec.base.model).encode(),
        b"biped.model_sha256": spec.model_sha256.encode(),
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
    tmp = out.with_name(out.name + ".tmp")
    pq.write_table(result, tmp)
    os.replace(tmp, out)
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
        scenario=Scenario.from_dict(spec["scenario"]),
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
