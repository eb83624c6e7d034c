#!/usr/bin/env python3
"""Compare two run folders file by file: ``python scripts/compare_outputs.py A B``.

For every file under either folder it prints one line: ``identical`` (same bytes), ``only in A``
/ ``only in B``, or what differs:

* JSON: the key paths whose values differ (a string holding the run folder's own path, e.g.
  ``outputs.video`` of ``biped walk``, is compared with that folder replaced by ``<run>``). Keys that
  measure the wall clock (``wall_time_s``,
  ``wall_time``, ``realtime_factor``) differ between any two runs; a file whose only differences
  are such keys is reported as ``same but timing`` and does not count as a difference.
* CSV: header changes, the row count, and the columns whose values differ (with the first row).
* PNG / GIF: whether the bytes differ and whether the decoded pixels do (Pillow).
* SVG: matplotlib names clip paths and markers with random ids in every run; a file whose only
  differences are those ids is reported as ``same but random svg ids``.
* video.mp4 and anything else: whether the bytes differ and the two sizes.

Exit status 0 when every file is identical or differs only in timing keys, 1 otherwise. Used to
check that a refactoring changes no output of ``biped push``, ``walk`` and ``posture``.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import re
import sys
from pathlib import Path

TIMING_KEYS = ("wall_time_s", "wall_time", "realtime_factor")


def _json_diff(a, b, path="") -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b), key=str):
            p = f"{path}.{k}" if path else str(k)
            if k not in a or k not in b:
                out.append(f"{p} (only in {'B' if k not in a else 'A'})")
            else:
                out += _json_diff(a[k], b[k], p)
        return out
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        out = []
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            out += _json_diff(x, y, f"{path}[{i}]")
        return out
    return [] if a == b else [path or "<root>"]


def _is_timing(path: str) -> bool:
    last = path.split(".")[-1].split("[")[0]
    return last in TIMING_KEYS


def _relative(obj, root: str):
    if isinstance(obj, str):
        return obj.replace(root, "<run>") if root else obj
    if isinstance(obj, list):
        return [_relative(x, root) for x in obj]
    if isinstance(obj, dict):
        return {k: _relative(v, root) for k, v in obj.items()}
    return obj


def compare_json(a: bytes, b: bytes, root_a: str = "", root_b: str = "") -> tuple[bool, str]:
    try:
        ja, jb = _relative(json.loads(a), root_a), _relative(json.loads(b), root_b)
    except ValueError as exc:
        return False, f"bytes differ; not both valid JSON ({exc})"
    diffs = _json_diff(ja, jb)
    if not diffs:
        return True, "same values (bytes differ: the run folder's path or formatting)"
    real = [d for d in diffs if not _is_timing(d)]
    if not real:
        return True, f"same but timing ({', '.join(diffs)})"
    more = f" and {len(real) - 8} more" if len(real) > 8 else ""
    return False, f"values differ at {', '.join(real[:8])}{more}"


def compare_csv(a: bytes, b: bytes) -> tuple[bool, str]:
    ra = list(csv.reader(io.StringIO(a.decode())))
    rb = list(csv.reader(io.StringIO(b.decode())))
    if not ra or not rb:
        return False, "one file is empty"
    ha, hb = ra[0], rb[0]
    notes = []
    if ha != hb:
        gone = [c for c in ha if c not in hb]
        new = [c for c in hb if c not in ha]
        notes.append(f"header differs (only in A: {gone or 'none'}; only in B: {new or 'none'})")
    if len(ra) != len(rb):
        notes.append(f"{len(ra) - 1} vs {len(rb) - 1} rows")
    common = [c for c in ha if c in hb]
    ia, ib = {c: i for i, c in enumerate(ha)}, {c: i for i, c in enumerate(hb)}
    differing = {}
    for k, (x, y) in enumerate(zip(ra[1:], rb[1:], strict=False), start=1):
        for c in common:
            if c not in differing and x[ia[c]] != y[ib[c]]:
                differing[c] = k
    if differing:
        cols = ", ".join(f"{c} (from row {k})" for c, k in list(differing.items())[:8])
        more = f" and {len(differing) - 8} more" if len(differing) > 8 else ""
        notes.append(f"values differ in {cols}{more}")
    elif common:
        notes.append(f"the {len(common)} shared columns are identical")
    return False, "; ".join(notes)


def compare_image(a: bytes, b: bytes) -> tuple[bool, str]:
    try:
        from PIL import Image, ImageSequence
    except ImportError:
        return False, f"bytes differ ({len(a)} vs {len(b)} bytes); Pillow missing, pixels not compared"
    try:
        ia, ib = Image.open(io.BytesIO(a)), Image.open(io.BytesIO(b))
        fa = [f.convert("RGBA").tobytes() for f in ImageSequence.Iterator(ia)]
        fb = [f.convert("RGBA").tobytes() for f in ImageSequence.Iterator(ib)]
    except Exception as exc:  # noqa: BLE001 - a truncated or foreign file is a difference
        return False, f"bytes differ ({len(a)} vs {len(b)} bytes); not decodable ({exc})"
    if ia.size != ib.size or len(fa) != len(fb):
        return False, f"bytes differ; size {ia.size} x {len(fa)} frames vs {ib.size} x {len(fb)}"
    same = sum(x == y for x, y in zip(fa, fb, strict=True))
    if same == len(fa):
        return False, "bytes differ, pixels identical"
    return False, f"bytes and pixels differ ({len(fa) - same} of {len(fa)} frames)"


_SVG_ID = re.compile(rb"\b[pm][0-9a-f]{10}\b")


def compare_svg(a: bytes, b: bytes) -> tuple[bool, str]:
    if _SVG_ID.sub(b"ID", a) == _SVG_ID.sub(b"ID", b):
        return True, "same but random svg ids"
    return False, f"bytes differ ({len(a)} vs {len(b)} bytes) beyond matplotlib's random ids"


def compare_file(pa: Path, pb: Path, root_a: str = "", root_b: str = "") -> tuple[bool, str]:
    a, b = pa.read_bytes(), pb.read_bytes()
    if a == b:
        return True, "identical"
    suffix = pa.suffix.lower()
    if suffix == ".json":
        return compare_json(a, b, root_a, root_b)
    if suffix == ".svg":
        return compare_svg(a, b)
    if suffix == ".csv":
        return compare_csv(a, b)
    if suffix in (".png", ".gif"):
        return compare_image(a, b)
    first = (
        next(i for i, (x, y) in enumerate(zip(a, b, strict=False)) if x != y)
        if min(len(a), len(b)) and any(x != y for x, y in zip(a, b, strict=False))
        else min(len(a), len(b))
    )
    return False, f"bytes differ ({len(a)} vs {len(b)} bytes, first at byte {first})"


def compare_dirs(a: Path, b: Path) -> list[tuple[str, bool, str]]:
    """``[(relative path, counts as same, note)]`` for every file under ``a`` or ``b``."""
    fa = {p.relative_to(a).as_posix() for p in a.rglob("*") if p.is_file()}
    fb = {p.relative_to(b).as_posix() for p in b.rglob("*") if p.is_file()}
    rows = []
    for rel in sorted(fa | fb):
        if rel not in fb:
            rows.append((rel, False, "only in A"))
        elif rel not in fa:
            rows.append((rel, False, "only in B"))
        else:
            rows.append((rel, *compare_file(a / rel, b / rel, str(a), str(b))))
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("a", type=Path)
    p.add_argument("b", type=Path)
    args = p.parse_args(argv)
    for d in (args.a, args.b):
        if not d.is_dir():
            print(f"compare_outputs: {d} is not a folder", file=sys.stderr)
            return 2
    rows = compare_dirs(args.a, args.b)
    w = max((len(r[0]) for r in rows), default=0)
    for rel, _, note in rows:
        print(f"  {rel:<{w}}  {note}")
    bad = sum(not ok for _, ok, _ in rows)
    print(
        f"{args.a} vs {args.b}: {len(rows) - bad} of {len(rows)} files the same"
        + ("" if not bad else f", {bad} differ")
    )
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
