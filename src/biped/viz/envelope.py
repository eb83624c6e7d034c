"""Polar maps of push-recovery envelopes (plotting only; the numbers come from
:mod:`biped.analysis`).

Usage (needs the sweeps' Parquet files, so not a doctest)::

    from biped.viz.envelope import plot_envelope, plot_comparison
    fig = plot_envelope("runs/sweep-workspace-none.parquet", by="impulse_n_s")
    fig = plot_comparison(["runs/sweep-workspace-none.parquet", "runs/sweep-joint-pd-none.parquet"],
                          out="docs/sweep_envelopes.png")

Each trial is a dot at (direction the block travels, speed or impulse): filled green if the biped
survived, red cross if not. The line is the envelope (per direction, the largest value below
which every trial survived) and the dashed line Hof's feet-in-place bound J_max = m omega_0 d
(:class:`biped.analysis.FeetInPlaceBound`), converted to block speed with the head-on impact
law ``v = J / ((1 + e) m_block)`` when the radius is the speed. The radial scale reaches all of
the bound when that does not squash the trials (a factor 2.5 at most), else its nearest point,
so the bound is always drawn; its legend entry gives its range. Angles: 0 deg = +x,
counter-clockwise toward +y. The biped faces -x (180 deg), its left side toward -y: a block
travelling at 180 deg (W's throw) hits its back.
"""

from __future__ import annotations

import os
import textwrap
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np

from biped import files
from biped.analysis import envelope, feet_in_place_bound, survived, sweep_data
from biped.analysis.envelope import horizontal_impulse_n_s
from biped.errors import ScenarioError

LABELS = {
    "speed_m_s": "block speed [m/s]",
    "impulse_n_s": "horizontal impulse to the body [N s]",
    "impulse_horizontal_n_s": "horizontal impulse [N s]",
    "magnitude": "the perturbation's size",  # + its unit, from the sweep (paradigm_unit)
    "horizontal_impulse_n_s": "the perturbation's horizontal impulse [N s]",
}


def _label(cols: dict, by: str) -> str:
    """The radius's label; the paradigm's own unit for ``magnitude``."""
    if by == "magnitude":
        units = [u for u in cols.get("paradigm_unit", []) if u]
        names = [p for p in cols.get("paradigm", []) if p]
        return f"{names[0] if names else 'perturbation'} size [{units[0] if units else '?'}]"
    return LABELS[by]


#: Where the radial tick labels sit [deg]: between the 0 and 45 deg spokes, clear of every
#: angle label.
RLABEL_DEG = 22.5
FACING_NOTE = (
    "angle: direction the block travels (0 deg = +x). The biped faces -x (180 deg), "
    "left side toward -y: 180 deg is W's push, from behind."
)


def _closed(theta: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.append(theta, theta[:1]), np.append(r, r[:1])


def controller_label(scenario: Any) -> str:
    """The sweep's controller as a label: ``workspace``, ``workspace (qp)`` for a distribution
    other than W's min-norm split, ``+ stepping`` when it steps; ``joint-pd``."""
    name = str(scenario.controller)
    if name == "workspace" and getattr(scenario, "distribution", "statics") != "statics":
        name += f" ({scenario.distribution})"
    if getattr(scenario, "stepping", False):
        name += " + stepping"
    return name


def _columns(data: Any) -> dict[str, list]:
    return {n: data.table.column(n).to_pylist() for n in data.table.column_names}


def _bound_radius(data: Any, cols: dict, by: str, dirs: np.ndarray) -> np.ndarray:
    b = feet_in_place_bound(dirs, data.scenario)
    if by == "speed_m_s":
        mass = float(np.median(np.array(cols["block_mass_kg"], dtype=float)))
        return b.speed_equivalent(mass, data.scenario.restitution)
    return b.j_max_n_s


#: The impulse radii: each the perturbation's horizontal impulse, as ``biped envelope``'s table's
#: (:func:`biped.analysis.envelope.horizontal_impulse_n_s`; a block's ``impulse_n_s`` column
#: holds the vertical part of its hit too, Hof's bound does not)
IMPULSE_RADII = ("impulse_n_s", "impulse_horizontal_n_s", "horizontal_impulse_n_s")


def _radius_columns(cols: dict, by: str) -> dict:
    """``cols`` with ``cols[by]`` the plot's radius: an impulse radius the horizontal impulse of
    each row (:data:`IMPULSE_RADII`), any other the column as it is."""
    if by not in IMPULSE_RADII:
        return cols
    rows = [dict(zip(cols, vals, strict=True)) for vals in zip(*cols.values(), strict=True)]
    return {**cols, by: [horizontal_impulse_n_s(r) for r in rows]}


def _values(cols: dict, by: str) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in _radius_columns(cols, by)[by]], dtype=float)


def _scale(data: Any, by: str, bound: bool) -> float:
    """A radial limit that shows every trial and Hof's bound: all of it when that costs at most
    a factor 2.5 on the trials' scale, else at least its nearest point."""
    cols = _columns(data)
    r = _values(cols, by)
    top = float(np.nanmax(r)) if np.isfinite(r).any() else 1.0
    if bound and by in ("speed_m_s", *IMPULSE_RADII):
        radius = _bound_radius(data, cols, by, np.arange(0.0, 360.0, 2.0))
        far, near = float(radius.max()), float(radius.min())
        top = max(top, far if far <= 2.5 * top else near)
    return 1.08 * max(top, 1e-9)


def _facing_arrow(ax: Any, rmax: float) -> None:
    """An arrow from the centre toward 180 deg: the way the biped faces."""
    ax.annotate(
        "",
        xy=(np.pi, 0.3 * rmax),
        xytext=(np.pi, 0.0),
        arrowprops={"arrowstyle": "-|>", "color": "0.35", "lw": 1.2},
        zorder=4,
    )
    ax.text(np.pi, 0.36 * rmax, "faces", color="0.35", fontsize=7, ha="center", va="bottom", zorder=4)


def plot_envelope(
    source: Any,
    ax: Any = None,
    *,
    by: str = "speed_m_s",
    criterion: str = "survived",
    bound: bool = True,
    title: str | None = None,
    rmax: float | None = None,
    bin_deg: float | None = None,
) -> Any:
    """Draw one sweep's envelope on a polar axes (created if None); returns the axes.

    ``by``: ``"speed_m_s"``, ``"impulse_n_s"`` (the horizontal impulse, as ``biped envelope``'s
    table's: :data:`IMPULSE_RADII`) or another of :data:`LABELS`; ``criterion``: ``"survived"`` or
    ``"recovered"`` (:func:`biped.analysis.survived`). ``rmax`` defaults to a scale that shows
    every trial and Hof's bound (at least its nearest point).
    """
    import matplotlib.pyplot as plt

    if by not in LABELS:
        raise ScenarioError(f"by must be one of {', '.join(LABELS)}; got {by!r}")
    data = sweep_data(source)
    if ax is None:
        _, ax = plt.subplots(subplot_kw={"projection": "polar"}, figsize=(5.5, 5.8))
    cols = _columns(data)
    if rmax is None:
        rmax = _scale(data, by, bound)
    ok = survived(cols, criterion)
    theta = np.radians(np.array(cols["direction_deg"], dtype=float))
    r = _values(cols, by)
    ax.scatter(theta[ok], r[ok], s=14, c="tab:green", marker="o", label=criterion, zorder=3)
    ax.scatter(theta[~ok], r[~ok], s=18, c="tab:red", marker="x", label=f"not {criterion}", zorder=3)
    env = envelope(_radius_columns(cols, by), by=by, criterion=criterion, bin_deg=bin_deg)
    if len(env.directions_deg) >= 3:
        t, v = _closed(np.radians(env.directions_deg), np.nan_to_num(env.survived_max, nan=0.0))
        ax.plot(t, v, color="tab:green", lw=2, label="envelope")
    else:
        _too_few_directions(ax, len(env.directions_deg))
    if bound and by in ("speed_m_s", *IMPULSE_RADII):  # Hof's bound is an impulse
        dirs = np.arange(0.0, 360.0, 2.0)
        radius = _bound_radius(data, cols, by, dirs)
        t, v = _closed(np.radians(dirs), radius)
        unit = LABELS[by].split("[")[-1].rstrip("]")
        ax.plot(
            t,
            v,
            color="black",
            ls="--",
            lw=1.6,
            zorder=5,
            label=f"feet-in-place bound (Hof): {radius.min():.3g}-{radius.max():.3g} {unit}",
        )
    ax.set_ylim(0, rmax)
    ax.set_theta_zero_location("E")
    ax.set_theta_direction(1)
    ax.set_rlabel_position(RLABEL_DEG)
    _facing_arrow(ax, rmax)
    ctrl = controller_label(data.scenario) if cols["controller"] else "?"
    lim = cols["torque_limits"][0] if cols["torque_limits"] else "?"
    ax.set_title(
        f"{title or f'{ctrl}, torque limits: {lim}'}\nradius: {_label(cols, by)}", pad=14, fontsize=10
    )
    return ax


def plot_comparison(
    sources: Any,
    *,
    labels: Any = None,
    by: str = "speed_m_s",
    criterion: str = "survived",
    out: str | os.PathLike | None = None,
    bin_deg: float | None = None,
) -> Any:
    """Polar envelopes of one or more sweeps side by side (same radial scale) and, for two or
    more, an overlay of their envelope lines; a note says which way the biped faces. Saved (PNG,
    SVG, PDF by suffix) if ``out`` is given. Returns the figure."""
    if out is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    datas = [sweep_data(s) for s in sources]
    if not datas:
        raise ScenarioError("plot_comparison needs at least one sweep file")
    labels = labels or [None] * len(datas)
    rmax = max(_scale(d, by, True) for d in datas)
    n = len(datas)
    panels = n + 1 if n > 1 else 1
    fig, axes = plt.subplots(
        1, panels, subplot_kw={"projection": "polar"}, figsize=(4.6 * panels + 0.6, 6.0), squeeze=False
    )
    axes = axes[0]
    for ax, d, lab in zip(axes, datas, labels, strict=False):
        plot_envelope(d, ax, by=by, criterion=criterion, title=lab, rmax=rmax, bin_deg=bin_deg)
    handles, labs = axes[0].get_legend_handles_labels()
    if n > 1:
        ax = axes[-1]
        colors = ["tab:blue", "tab:orange", "tab:purple", "tab:brown"]
        fewest = min(
            len(
                envelope(
                    _radius_columns(_columns(d), by), by=by, criterion=criterion, bin_deg=bin_deg
                ).directions_deg
            )
            for d in datas
        )
        if fewest < 3:
            _too_few_directions(ax, fewest)
        for k, (d, lab) in enumerate(zip(datas, labels, strict=True)):
            env = envelope(_radius_columns(_columns(d), by), by=by, criterion=criterion, bin_deg=bin_deg)
            if len(env.directions_deg) < 3:
                continue
            t, v = _closed(np.radians(env.directions_deg), np.nan_to_num(env.survived_max, nan=0.0))
            name = lab or controller_label(d.scenario)
            ax.plot(t, v, color=colors[k % len(colors)], lw=2, label=name)
            ax.fill(t, v, color=colors[k % len(colors)], alpha=0.12)
        ax.set_ylim(0, rmax)
        ax.set_theta_zero_location("E")
        ax.set_rlabel_position(RLABEL_DEG)
        _facing_arrow(ax, rmax)
        ax.set_title(f"envelopes overlaid\nradius: {_label(_columns(datas[0]), by)}", pad=14, fontsize=10)
        h2, l2 = ax.get_legend_handles_labels()
        handles, labs = handles + h2, labs + l2
    fig.legend(
        handles,
        labs,
        loc="lower center",
        ncol=min(2 * panels, len(labs), 6),
        fontsize=8,
        frameon=False,
        bbox_to_anchor=(0.5, 0.06),
    )
    note = FACING_NOTE if by == "speed_m_s" or by.startswith("impulse") else PARADIGM_NOTE
    note = textwrap.fill(note, width=int(95 * min(panels, 2) / 2 + 10 * (panels > 1)))
    fig.text(0.5, 0.01, note, ha="center", va="bottom", fontsize=8)
    fig.tight_layout(rect=(0, 0.17, 1, 0.93))
    if out is not None:
        out = Path(out)
        out.parent.mkdir(parents=True, exist_ok=True)
        files.write_via(out, lambda tmp: fig.savefig(tmp, dpi=80))
    return fig


def _too_few_directions(ax, n: int) -> None:
    """Say in the panel why it has no envelope line (it joins three or more directions)."""
    ax.text(
        0.5,
        0.5,
        f"no envelope line:\n{n} direction{'s' if n != 1 else ''} swept\n(it needs 3 or more)",
        transform=ax.transAxes,
        ha="center",
        va="center",
        fontsize=9,
        color="0.3",
        bbox={"boxstyle": "round", "fc": "white", "ec": "0.7", "alpha": 0.9},
        zorder=6,
    )


#: the angle's note for a paradigm's envelope (docs/perturbations.md)
PARADIGM_NOTE = (
    "angle: the way the perturbation pushes the body (0 deg = +x). The biped faces -x (180 deg), "
    "left side toward -y: 180 deg pushes it forward."
)

__all__ = ["FACING_NOTE", "PARADIGM_NOTE", "plot_comparison", "plot_envelope"]
