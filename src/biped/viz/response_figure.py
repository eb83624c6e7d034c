"""The response figure of a perturbation run (W's Fig. 5 style): the whole-body COM, the net
centre of pressure and Hof's extrapolated COM xi along the direction of the push, against the
front and back edges of the base of support (:func:`biped.sim.response.traces`)."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from biped import files


def plot_response(tr, out_dir, *, title: str = "", formats=("png",)) -> list[Path]:
    """Write ``response.png`` (and ``response.svg`` with ``formats=("png", "svg")``) of the
    :class:`~biped.sim.response.Traces` ``tr`` into ``out_dir``; returns the paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    t = tr.times
    ax.fill_between(t, tr.bos_back, tr.bos_front, color="0.88", label="base of support", step="post")
    ax.plot(t, tr.com, color="tab:blue", lw=1.8, label="whole-body COM")
    ax.plot(t, tr.cop, color="tab:orange", lw=1.0, label="centre of pressure")
    ax.plot(
        t, tr.xi, color="tab:red", lw=1.4, ls="--", label=f"xi = x + v / omega0 (omega0 {tr.omega0:.2f}/s)"
    )
    ax.axvline(tr.onset_s, color="k", lw=0.8, ls=":", label="onset")
    a = float(np.degrees(np.arctan2(tr.u[1], tr.u[0])) % 360)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"along the push ({a:.0f} deg) [m]")
    ax.set_title(title or "response", fontsize=10)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3, frameon=False)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for ext in formats:
        p = out / f"response.{ext}"
        meta = {"Date": None} if ext == "svg" else None
        files.write_via(p, functools.partial(fig.savefig, dpi=120, metadata=meta, format=ext))
        paths.append(p)
    plt.close(fig)
    return paths


__all__ = ["plot_response"]
