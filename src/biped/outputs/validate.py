"""``biped validate``'s files: validation.json, validation.md, a figure per experiment and the
trials as Parquet (trials.parquet), from :mod:`biped.analysis.validate`'s thresholds."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from biped import files
from biped.analysis.validate import (
    EXPERIMENTS,
    HUMAN,
    MEASURES,
    NOT_RUN,
    OUTCOMES,
    QUICK_STAIRCASE_FACTOR,
    Threshold,
    human_for,
)
from biped.outputs._json import write_json
from biped.viz.validate import threshold_figure

__all__ = ["table_rows", "write_validation"]


def _fmt(v, bound: str = "") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return f"{bound}{v:.3g}"


def _human(h) -> dict | None:
    return None if h is None else {"mean": h.mean, "sd": h.sd, "source": h.source, "sd_assumed": h.sd_assumed}


def _value(th: Threshold, field: str) -> tuple[float, str]:
    if field in ("lean_deg", "threshold", "displacement_m"):
        return th.value, th.bound
    if th.at is None:
        return math.nan, ""
    return float(getattr(th.at, field)), ""


def table_rows(results: dict[str, dict[str, Threshold]]) -> list[dict]:
    """One row per compared quantity: human mean, SD, source (and the older adults' where the
    paper gives them: ``human_older``, the ``older`` preset's comparison), the presets' values,
    inside +/- 2 SD."""
    rows = []
    for key, per in results.items():
        exp = EXPERIMENTS[key]
        quantities = exp.human or (f"{key}.threshold",)
        for q in quantities:
            h = HUMAN.get(q)
            exp_key, field = q.split(".", 1)
            older = HUMAN.get(f"{exp_key}_older.{field}")
            name, unit = MEASURES.get(q, (f"{exp.title}: threshold", exp.unit))
            row: dict[str, Any] = {"quantity": h.quantity if h else name, "unit": h.unit if h else unit,
                                   "human": _human(h)}  # fmt: skip
            if older is not None and "older" in per:
                row["human_older"] = _human(older)
            for preset, th in per.items():
                value, bound = _value(th, field)
                hp = human_for(q, preset) if h is not None else None
                row[preset] = {"value": value, "bound": bound,
                               "inside_2sd": None if (hp is None or bound) else hp.inside(value)}  # fmt: skip
            rows.append(row)
    for key, why in NOT_RUN.items():
        h = HUMAN.get(f"{key}.lean_deg")
        rows.append({"quantity": h.quantity if h else key, "unit": "deg", "not_run": why, "human": _human(h)})
    return rows


def _hum(h: dict | None) -> str:
    if h is None:
        return "no human number"
    return f"{h['mean']:g} +/- {h['sd']:.3g}{' (SD assumed 20 %)' if h['sd_assumed'] else ''} ({h['source']})"


def _markdown(rows: list[dict], presets: list[str], meta: dict) -> str:
    head = ["quantity", "human mean +/- SD (source)", *[f"biped {p}" for p in presets],
            *[f"{p} inside +/- 2 SD" for p in presets]]  # fmt: skip
    lines = ["# biped validate", "", meta["note"], "", "| " + " | ".join(head) + " |",
             "|" + "---|" * len(head)]  # fmt: skip
    for r in rows:
        hum = _hum(r["human"])
        if r.get("human_older"):
            hum += f"; older adults (the older preset's band): {_hum(r['human_older'])}"
        if "not_run" in r:
            cells = ["not run"] * len(presets) + ["-"] * len(presets)
            lines.append(f"| {r['quantity']} [{r['unit']}] | {hum} | " + " | ".join(cells) + " |")
            continue
        vals = [_fmt(r[p]["value"], r[p]["bound"]) if p in r else "not run" for p in presets]
        ins = []
        for p in presets:
            v = r[p]["inside_2sd"] if p in r else None
            ins.append("n/a" if v is None else ("yes" if v else "no"))
        lines.append(f"| {r['quantity']} [{r['unit']}] | {hum} | " + " | ".join(vals + ins) + " |")
    if NOT_RUN:
        lines += ["", "Not run:"] + [f"- {k}: {v}" for k, v in NOT_RUN.items()]
    mode = meta["mode"] + (", interrupted" if meta.get("interrupted") else "")
    lines += ["", f"Trials: {meta['trials']} in {meta['wall_time_s']:.1f} s ({mode})."]
    return "\n".join(lines) + "\n"


def _searches(results: dict[str, dict[str, Threshold]], quick: bool = False) -> str:
    """One line per preset and experiment: what counted, and the lowest magnitude that failed
    (an island below the threshold, if a bisection passed one)."""
    lines = [
        "",
        "Searches (the threshold; the lowest magnitude tried that failed, and what came of it: fell, "
        "diverged (MuJoCo), error (the controller), or survived/recovered short of the criterion; the "
        "highest that passed):",
    ]
    for key, per in results.items():
        exp = EXPERIMENTS[key]
        step = exp.staircase * (QUICK_STAIRCASE_FACTOR if quick else 1.0)
        how = (f"raised {step:g} {exp.unit} at a time from {exp.lo:g} until one failed, "
               + ("no halving (--quick)" if quick else "then bisected")
               if exp.staircase > 0 else "bisection on a log scale")  # fmt: skip
        for p, th in per.items():
            low, high = th.lowest_failure, th.highest_pass
            island = low is not None and not th.bound and low < th.value
            lines.append(
                f"- {key}, {p}: {exp.criterion}, {how}: {_fmt(th.value, th.bound)} {exp.unit}; lowest failed "
                f"{_fmt(low)}{f' ({th.lowest_failure_outcome})' if low is not None else ''}; highest passed "
                f"{_fmt(high)}" + (" (fails below the threshold)" if island else "")
            )
    return "\n".join(lines) + "\n"


def write_validation(out: Path, results: dict[str, dict[str, Threshold]], meta: dict) -> list[Path]:
    """Write the files into ``out``; returns their paths."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    presets = list(meta.get("presets") or next(iter(results.values())))
    rows = table_rows(results)
    written = [write_json(out / "validation.json", {"meta": meta, "rows": rows, "experiments": {
        k: {"title": EXPERIMENTS[k].title, "protocol": EXPERIMENTS[k].protocol, "unit": EXPERIMENTS[k].unit,
            "criterion": EXPERIMENTS[k].criterion, "staircase_step": EXPERIMENTS[k].staircase,
            "thresholds": {p: {"value": th.value, "bound": th.bound, "lowest_failure": th.lowest_failure,
                               "highest_pass": th.highest_pass,
                               "lowest_failure_outcome": th.lowest_failure_outcome,
                               "outcomes": {o: n for o in OUTCOMES
                                            if (n := sum(t.outcome == o for t in th.trials))}}
                           for p, th in per.items()}}
        for k, per in results.items()}})]  # fmt: skip
    md = out / "validation.md"
    files.write_text(md, _markdown(rows, presets, meta) + _searches(results, meta.get("mode") == "quick"))
    written.append(md)
    trials = [t.row() for per in results.values() for th in per.values() for t in th.trials]
    table = pa.Table.from_pylist(trials)
    files.write_via(out / "trials.parquet", lambda tmp: pq.write_table(table, tmp))
    written.append(out / "trials.parquet")
    figs = out / "figures"
    figs.mkdir(exist_ok=True)
    for key, per in results.items():
        exp = EXPERIMENTS[key]
        # the first quantity with a human number (the waist pull's % BoS, not its metres), else the threshold
        q = next((q for q in exp.human if q in HUMAN), None)
        human = HUMAN[q] if q else None
        field = q.split(".", 1)[1] if q else "threshold"
        values = {p: _value(th, field) for p, th in per.items()}
        written.append(threshold_figure(figs / f"{key}.png", exp.title, human.unit if human else exp.unit,
                                        values, human))  # fmt: skip
    return written
