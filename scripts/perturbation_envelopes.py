"""The 8-direction envelope table of the perturbation paradigms (docs/perturbations.md): for each
sweep file (``biped sweep --perturbation P --magnitude ... --direction 0:315:8``, or a block sweep
with ``--speed``), per direction the largest size survived below the smallest that was not, in the
paradigm's unit and as the body's horizontal momentum change [N s] where the paradigm has one
(block: the measured impulse of that trial; force: the pulse's impulse; platform: body mass times
its peak velocity, the support's velocity change under the COM; release: none).

    python scripts/perturbation_envelopes.py runs/env-block.parquet runs/env-force.parquet ...
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pyarrow.parquet as pq

from biped import models
from biped.analysis import survived


def envelope_rows(path: str) -> tuple[str, str, dict]:
    t = pq.read_table(path)
    cols = t.to_pydict()
    ok = survived(t)
    paradigm = next((p for p in cols["paradigm"] if p), "block")
    unit = next((u for u in cols["paradigm_unit"] if u), "m/s")
    size = np.array(cols["paradigm_magnitude"], dtype=float)
    mom = np.array(cols["horizontal_impulse_n_s"], dtype=float)
    if paradigm == "platform":  # mass x the support's velocity change
        dv = np.array(cols["com_velocity_change_m_s"], dtype=float)
        mom = dv * models.total_mass_kg()  # W's biped, the sweeps' default model
    dirs = np.array(cols["direction_deg"], dtype=float)
    out = {}
    for d in sorted(set(dirs.tolist())):
        sel = np.flatnonzero(dirs == d)
        order = sel[np.argsort(size[sel])]
        best, best_mom = math.nan, math.nan
        for i in order:
            if not ok[i]:
                break
            best, best_mom = size[i], mom[i]
        out[d] = (best, best_mom)
    return paradigm, unit, out


def main(paths: list[str]) -> None:
    tables = [envelope_rows(p) for p in paths]
    dirs = sorted({d for _, _, t in tables for d in t})
    print("| paradigm | unit | " + " | ".join(f"{d:g} deg" for d in dirs) + " |")
    print("|---|---|" + "---|" * len(dirs))
    for paradigm, unit, t in tables:
        cells = []
        for d in dirs:
            s, m = t.get(d, (math.nan, math.nan))
            cell = "none" if math.isnan(s) else f"{s:g}"
            if not math.isnan(m):
                cell += f" ({m:.1f} N s)"
            cells.append(cell)
        print(f"| {paradigm} | {unit} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
