"""``biped validate``'s figures: one per experiment, each preset's threshold against the human band."""

from __future__ import annotations

import functools
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from biped import files  # noqa: E402

__all__ = ["threshold_figure"]


def threshold_figure(path: str | Path, title: str, unit: str, thresholds: dict, human=None) -> Path:
    """``thresholds``: {preset: (value, bound)}; ``human``: a HumanValue (mean +/- SD, band 2 SD)
    or None. Draws each preset's threshold as a bar and the human mean, +/- 1 and 2 SD bands."""
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    names = list(thresholds)
    values = [thresholds[n][0] for n in names]
    bars = ax.bar(names, values, color=["#7a8fa6", "#c9753d", "#6a9a5b"][: len(names)], zorder=3)
    for b, n in zip(bars, names, strict=True):
        bound = thresholds[n][1]
        label = f"{bound}{thresholds[n][0]:.3g}"
        ax.annotate(label, (b.get_x() + b.get_width() / 2, b.get_height()), ha="center", va="bottom")
    if human is not None:
        ax.axhspan(human.mean - 2 * human.sd, human.mean + 2 * human.sd, color="#2b7bb9", alpha=0.12,
                   label="human mean +/- 2 SD")  # fmt: skip
        ax.axhspan(
            human.mean - human.sd, human.mean + human.sd, color="#2b7bb9", alpha=0.22, label="+/- 1 SD"
        )
        ax.axhline(human.mean, color="#2b7bb9", lw=1.5, label=f"human mean {human.mean:g} {unit}")
        ax.legend(fontsize=7, loc="upper right")
    ax.set_ylabel(f"threshold [{unit}]")
    ax.set_title(title, fontsize=9)
    ax.grid(axis="y", alpha=0.3, zorder=0)
    fig.tight_layout()
    path = Path(path)
    files.write_via(path, functools.partial(fig.savefig, dpi=120, format=path.suffix.lstrip(".") or "png"))
    plt.close(fig)
    return path
