"""A stepping sweep with ``SteppingConfig`` fields changed, and its per-direction summary (the
variant tables of docs/sweep.md, "The stance foot's friction in single support" and "The swing
leg in the stance model").

    python benchmarks/stepping_grid.py OUT.parquet [--param field=literal ...] -- SWEEP ARGS...

e.g. ``--param stance_contact_model=True -- --speed 8:22:15 --direction 0:180:5 --distribution qp
--stepping --set duration_s=4`` (add ``--torque-limits human``, ``--physics faithful`` or
``--model SUBJECT.xml``). The sweep runs in this process (``--workers 1``; every stepping run of it
takes ``SteppingConfig.for_trigger``'s set with the fields changed), skipped when OUT exists.
Printed per direction: the strict-rule limit (the largest speed below which every push was
recovered; "+": every push of the grid), where *survived* ends, the largest stance slip of a
recovered trial (``max_stance_slip_m``) and the falls and divergences.
"""

from __future__ import annotations

import ast
import math
import sys
from pathlib import Path


def _patch(params: list[str]) -> dict:
    from biped.control.stepping_config import SteppingConfig

    kw = {}
    for p in params:
        key, _, value = p.partition("=")
        kw[key.strip()] = ast.literal_eval(value.strip())
    plain = SteppingConfig.for_trigger.__func__  # type: ignore[attr-defined]

    def for_trigger(cls, trigger, **more):
        return plain(cls, trigger, **{**more, **kw})

    SteppingConfig.for_trigger = classmethod(for_trigger)  # type: ignore[method-assign, assignment]
    return kw


def summary(path: str) -> list[str]:
    import pyarrow.parquet as pq

    t = pq.read_table(path).to_pydict()
    rows = [{k: t[k][j] for k in t} for j in range(len(t["speed_m_s"]))]
    out = []
    for dirn in sorted({r["direction_deg"] for r in rows}):
        g = sorted((r for r in rows if r["direction_deg"] == dirn), key=lambda r: r["speed_m_s"])
        strict = survived = None
        for r in g:
            if not r["recovered"] or r.get("diverged"):
                break
            strict = r["speed_m_s"]
        for r in g:
            if r["fell"] or r.get("diverged"):
                break
            survived = r["speed_m_s"]
        every = "+" if strict == g[-1]["speed_m_s"] else ""
        slips = [
            (r["max_stance_slip_m"], r["speed_m_s"])
            for r in g
            if r["recovered"] and r["max_stance_slip_m"] is not None and math.isfinite(r["max_stance_slip_m"])
        ]
        worst = f"{100 * max(slips)[0]:.1f} cm at {max(slips)[1]:g} m/s" if slips else "-"
        fell = sum(1 for r in g if r["fell"])
        div = sum(1 for r in g if r.get("diverged"))
        out.append(
            f"{dirn:5.0f} deg: strict {strict}{every} [survived {survived}], largest slip of a recovered "
            f"trial {worst}, fell {fell}, diverged {div}"
        )
    return out


def main(argv: list[str]) -> int:
    if "--" not in argv or not argv or argv[0].startswith("-"):
        print(__doc__)
        return 2
    out, sep = argv[0], argv.index("--")
    params = [a for a in argv[1:sep] if a != "--param"]
    kw = _patch(params)
    if not Path(out).exists():
        from biped.cli import main as cli

        cli(["sweep", *argv[sep + 1 :], "--workers", "1", "--out", out])
    print("SteppingConfig fields changed:", kw)
    print("\n".join(summary(out)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
