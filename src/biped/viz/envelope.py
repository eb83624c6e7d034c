"""Polar maps of push-recovery envelopes (plotting only; the numbers come from
:mod:`biped.sim.sweep`).

>>> from biped.viz.envelope import plot_envelope, plot_comparison
>>> fig = plot_envelope("runs/sweep-workspace-none.parquet", by="impulse_n_s")
>>> fig = plot_comparison(["runs/sweep-workspace-none.parquet", "runs/sweep-joint-pd-none.parquet"],
...                       out="docs/sweep_envelopes.png")

Each trial is a dot at (direction the block travels, speed or impulse): filled green if the biped
survived, red cross if not. The line is the envelope (per direction, the largest value below
which every trial survived) and the dashed line Hof's feet-in-place bound J_max = m omega_0 d
(:class:`biped.sim.sweep.FeetInPlaceBound`), converted to block speed with the head-on impact
law ``v = J / ((1 + e) m_block)`` when the radius is the speed. Angles: 0 deg = +x (the biped's
back: it faces -x), counter-clockwise toward +y (its right side).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from biped.errors import ScenarioError

LABELS = {"speed_m_s": "block speed [m/s]", "impulse_n_s": "impulse to the body [N s]",
          "impulse_horizontal_n_s": "horizontal impulse [N s]"}


def _data(source):
    from biped.sim.sweep import SweepData, load

    if isinstance(source, SweepData):
        return source
    return load(source)


def _closed(theta, r):
    return np.append(theta, theta[:1]), np.append(r, r[:1])


def plot_envelope(source, ax=None, *, by: str = "speed_m_s", criterion: str = "survived",
                  bound: bool = True, title: str | None = None, rmax: float | None = None,
                  bin_deg: float | None = None):
    """Draw one sweep's envelope on a polar axes (created if None); returns the axes.

    ``by``: ``"speed_m_s"`` or ``"impulse_n_s"``; ``criterion``: ``"survived"`` or
    ``"recovered"`` (:func:`biped.sim.sweep.survived`).
    """
    import matplotlib.pyplot as plt

    from biped.sim.sweep import envelope, feet_in_place_bound, survived

    if by not in LABELS:
        raise ScenarioError(f"by must be one of {', '.join(LABELS)}; got {by!r}")
    data = _data(source)
    if ax is None:
        _, ax = plt.subplots(subplot_kw={"projection": "polar"}, figsize=(5.5, 5.5))
    cols = {n: data.table.column(n).to_pylist() for n in data.table.column_names}
    ok = survived(cols, criterion)
    theta = np.radians(np.array(cols["direction_deg"], dtype=float))
    r = np.array([np.nan if v is None else v for v in cols[by]], dtype=float)
    ax.scatter(theta[ok], r[ok], s=14, c="tab:green", marker="o", label=criterion, zorder=3)
    ax.scatter(theta[~ok], r[~ok], s=18, c="tab:red", marker="x", label=f"not {criterion}",
               zorder=3)
    env = envelope(cols, by=by, criterion=criterion, bin_deg=bin_deg)
    if len(env.directions_deg) >= 3:
        t, v = _closed(np.radians(env.directions_deg), np.nan_to_num(env.survived_max, nan=0.0))
        ax.plot(t, v, color="tab:green", lw=2, label="envelope")
    if bound:
        dirs = np.arange(0.0, 360.0, 2.0)
        b = feet_in_place_bound(dirs, data.scenario)
        radius = b.j_max_n_s
        if by == "speed_m_s":
            mass = np.median(np.array(cols["block_mass_kg"], dtype=float))
            radius = b.speed_equivalent(mass, data.scenario.restitution)
        t, v = _closed(np.radians(dirs), radius)
        ax.plot(t, v, "k--", lw=1.2, label="feet-in-place bound (Hof)")
    if rmax is None:
        finite = r[np.isfinite(r)]
        rmax = 1.08 * max(finite.max() if finite.size else 1.0, 1e-9)
    ax.set_ylim(0, rmax)
    ax.set_theta_zero_location("E")
    ax.set_theta_direction(1)
    ctrl = cols["controller"][0] if cols["controller"] else "?"
    lim = cols["torque_limits"][0] if cols["torque_limits"] else "?"
    ax.set_title(title or f"{ctrl}, torque limits: {lim}", pad=14)
    ax.text(np.radians(225), rmax * 1.18, LABELS[by], fontsize=8, ha="center")
    return ax


def plot_comparison(sources, *, labels=None, by: str = "speed_m_s", criterion: str = "survived",
                    out: str | os.PathLike | None = None, bin_deg: float | None = None):
    """Side-by-side polar envelopes of several sweeps (same radial scale) plus an overlay of their
    envelope lines; saved (PNG, SVG, PDF by suffix) if ``out`` is given. Returns the figure."""
    import matplotlib

    if out is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from biped.sim.sweep import envelope

    datas = [_data(s) for s in sources]
    if not datas:
        raise ScenarioError("plot_comparison needs at least one sweep file")
    labels = labels or [None] * len(datas)
    rmax = 0.0
    for d in datas:
        v = np.array([np.nan if x is None else x for x in d.table.column(by).to_pylist()], float)
        if np.isfinite(v).any():
            rmax = max(rmax, float(np.nanmax(v)))
    rmax = 1.08 * (rmax or 1.0)
    n = len(datas)
    fig, axes = plt.subplots(1, n + 1, subplot_kw={"projection": "polar"},
                             figsize=(4.6 * (n + 1), 4.9))
    for ax, d, lab in zip(axes, datas, labels):
        plot_envelope(d, ax, by=by, criterion=criterion, title=lab, rmax=rmax, bin_deg=bin_deg)
    ax = axes[-1]
    colors = ["tab:blue", "tab:orange", "tab:purple", "tab:brown"]
    for k, (d, lab) in enumerate(zip(datas, labels)):
        env = envelope(d.table, by=by, criterion=criterion, bin_deg=bin_deg)
        if len(env.directions_deg) < 3:
            continue
        t, v = _closed(np.radians(env.directions_deg), np.nan_to_num(env.survived_max, nan=0.0))
        name = lab or d.table.column("controller")[0].as_py()
        ax.plot(t, v, color=colors[k % len(colors)], lw=2, label=name)
        ax.fill(t, v, color=colors[k % len(colors)], alpha=0.12)
    ax.set_ylim(0, rmax)
    ax.set_theta_zero_location("E")
    ax.set_title("envelopes overlaid", pad=14)
    handles, labs = axes[0].get_legend_handles_labels()
    h2, l2 = ax.get_legend_handles_labels()
    fig.legend(handles + h2, labs + l2, loc="lower center", ncol=min(6, len(labs + l2)),
               fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.07, 1, 0.94))
    if out is not None:
        out = Path(out)
        out.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(out, dpi=80)
    return fig


__all__ = ["plot_comparison", "plot_envelope"]
