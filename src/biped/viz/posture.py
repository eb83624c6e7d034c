"""Figures and animations of Bediz's planar runs (B Figs. 25, 30, 31, 36, 37) and of the gain
analysis. Every function takes results computed elsewhere (``biped.planar.runs`` /
``biped.planar.analysis``) and returns a matplotlib ``Figure`` or writes a file; nothing here
simulates. Uses the object-oriented matplotlib API (no pyplot state, no display needed).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from biped import files
from biped.errors import ScenarioError
from biped.planar import body_leg as bl
from biped.planar import pendulum as pd


def _figure(w=6.0, h=4.0) -> Figure:
    fig = Figure(figsize=(w, h), dpi=100)
    FigureCanvasAgg(fig)
    return fig


def _label(traj) -> str:
    return f"{traj.method}, {traj.integrator}, dt = {traj.dt:g} s"


def pendulum_attitude_figure(traj) -> Figure:
    """Body attitude theta(t) of the single-link pendulum (B Fig. 25)."""
    fig = _figure()
    ax = fig.add_subplot()
    ax.plot(traj.time, traj.states[:, 0], lw=1.5)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("theta [rad]")
    ax.set_title(f"Pendulum body attitude ({_label(traj)})", fontsize=10)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def body_leg_figure(traj, which: str) -> Figure:
    """Body attitude theta_2(t) (``which="body"``, B Figs. 30, 36) or leg angle theta_1(t)
    (``which="leg"``, B Figs. 31, 37) of the body-leg model."""
    col = {"body": 2, "leg": 0}.get(which)
    if col is None:
        raise ScenarioError(f"which must be 'body' or 'leg', got {which!r}")
    name = {"body": "Body attitude theta_2", "leg": "Leg angle theta_1"}[which]
    fig = _figure()
    ax = fig.add_subplot()
    ax.plot(traj.time, traj.states[:, col], lw=1.5)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"{name.split()[-1]} [rad]")
    ax.set_title(f"{name} ({_label(traj)})", fontsize=10)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


#: Line styles of :func:`comparison_figure`, drawn in this order: a wide pale line first and
#: narrower, dashed ones over it, so that forms whose curves coincide all stay visible.
_COMPARE_STYLES = (
    {"lw": 5.0, "alpha": 0.45, "ls": "-"},
    {"lw": 2.2, "ls": "-"},
    {"lw": 1.4, "ls": (0, (5, 3))},
    {"lw": 1.0, "ls": (0, (1, 2))},
)


def comparison_figure(trajs: dict, reference: str | None = None) -> Figure:
    """Overlay of several body-leg runs (name -> Trajectory): theta_2 (body) and theta_1 (leg)
    against time. Each run has its own colour and a line style from :data:`_COMPARE_STYLES`
    (wide to narrow, solid to dotted), so that runs that coincide are all seen; the legend says
    each run's largest angle difference from ``reference`` (default: ``"lagrange"`` if present,
    else the first run)."""
    fig = _figure(7.0, 5.2)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    names = list(trajs)
    if reference is None:
        reference = "lagrange" if "lagrange" in trajs else (names[0] if names else None)
    ref = trajs.get(reference)
    for k, name in enumerate(names):
        tr = trajs[name]
        style = _COMPARE_STYLES[k % len(_COMPARE_STYLES)]
        label = name
        if name != reference and ref is not None and tr.states.shape == ref.states.shape:
            d = float(np.max(np.abs(tr.states[:, [0, 2]] - ref.states[:, [0, 2]])))
            label = f"{name} (max |diff| from {reference}: {d:.1e} rad)"
        colour = f"C{k}"
        ax1.plot(tr.time, tr.states[:, 2], color=colour, label=label, zorder=2 + k, **style)
        ax2.plot(tr.time, tr.states[:, 0], color=colour, zorder=2 + k, **style)
    ax1.set_ylabel("theta_2 (body) [rad]")
    ax2.set_ylabel("theta_1 (leg) [rad]")
    ax2.set_xlabel("time [s]")
    ax1.legend(fontsize=7)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
    fig.suptitle("Body-leg model: B's equations of motion compared, same start and gains", fontsize=10)
    fig.tight_layout()
    return fig


def best_on_map(smap) -> tuple[float, float, float]:
    """(K_theta1, K_theta2, margin) of the grid point with the largest stability margin."""
    i, j = np.unravel_index(np.nanargmax(smap.margin), smap.margin.shape)
    return float(smap.k_theta1[j]), float(smap.k_theta2[i]), float(smap.margin[i, j])


def stability_map_figure(smap, marks: dict | None = None, best=None) -> Figure:
    """Stability margin -max Re(lambda) over (K_theta1, K_theta2) with the rate gains fixed;
    ``marks``: label -> (K_theta1, K_theta2) drawn as points (B's gain sets). The best grid point
    of the map (:func:`best_on_map`) is marked with a star; ``best``: the best local gains found
    by a search over all four gains (``(K1, K1D, K2, K2D)`` and its margin, e.g. a
    :class:`biped.planar.analysis.LocalGainSearch`), drawn as a diamond (its rate gains differ
    from the map's, which the label says)."""
    fig = _figure(6.5, 5.0)
    ax = fig.add_subplot()
    v = float(min(5.0, np.nanmax(np.abs(smap.margin))))
    m = np.clip(smap.margin, -v, v)
    im = ax.pcolormesh(smap.k_theta1, smap.k_theta2, m, cmap="RdYlGn", vmin=-v, vmax=v,
                       shading="nearest")  # fmt: skip
    ax.contour(smap.k_theta1, smap.k_theta2, smap.margin, levels=[0.0], colors="k", linewidths=1.2)
    fig.colorbar(im, ax=ax, label="stability margin -max Re(lambda) [1/s]")
    for label, (k1, k2) in (marks or {}).items():
        ax.plot([k1], [k2], "o", ms=7, mfc="white", mec="k")
        ax.annotate(label, (k1, k2), textcoords="offset points", xytext=(6, 6), fontsize=8)
    k1, k2, mg = best_on_map(smap)
    ax.plot(
        [k1],
        [k2],
        "*",
        ms=14,
        mfc="gold",
        mec="k",
        label=f"best on this map: K_theta1 = {k1:.4g}, K_theta2 = {k2:.4g}, margin {mg:.3g} 1/s",
    )
    if best is not None:
        gains = np.asarray(getattr(best, "gains", best), dtype=float)
        margin = getattr(best, "margin", None)
        text = (
            f"best found over all four gains: K_theta1 = {gains[0]:.4g}, K_theta2 = "
            f"{gains[2]:.4g}\n  (K_theta1dot = {gains[1]:.4g}, K_theta2dot = {gains[3]:.4g}"
            + (f", margin {margin:.3g} 1/s)" if margin is not None else ")")
        )
        ax.plot([gains[0]], [gains[2]], "D", ms=9, mfc="deepskyblue", mec="k", label=text)
    ax.legend(fontsize=6.5, loc="upper left", framealpha=0.85)
    ax.set_xlabel("K_theta1 [lb ft^2/s^2/rad]")
    ax.set_ylabel("K_theta2 [lb ft^2/s^2/rad]")
    ax.set_title(
        f"Body-leg local feedback, K_theta1dot = {smap.k_theta1_dot:g}, K_theta2dot = {smap.k_theta2_dot:g}",
        fontsize=9,
    )
    fig.tight_layout()
    return fig


def _frames(n: int, max_frames: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, max_frames)).round().astype(int))


def _write_animation(images: list, path: Path, fps: float) -> None:
    suffix = path.suffix.lower()
    if suffix == ".gif":
        from PIL import Image

        frames = [
            Image.fromarray(im[..., :3]).convert("P", palette=Image.Palette.WEB, dither=Image.Dither.NONE)
            for im in images
        ]
        files.write_via(path, lambda tmp: frames[0].save(
            tmp, save_all=True, append_images=frames[1:], duration=round(1000 / fps), loop=0))  # fmt: skip
    elif suffix == ".mp4":
        import imageio.v2 as imageio

        files.write_via(path, lambda tmp: imageio.mimsave(tmp, [im[..., :3] for im in images], fps=fps))
    else:
        raise ScenarioError(f"animation file must end in .gif or .mp4, got {path.name!r}")


def animate(traj, path, *, fps: float = 20.0, max_frames: int = 80, dpi: int = 72) -> Path:
    """Write a GIF or MP4 of the planar figure of a pendulum or body-leg Trajectory.

    The figure is drawn in B's planes: the pendulum in (x, y up) from the pivot, the body-leg in
    (y, z up) from the ankle with the body as a bar of length 2 l through its centre of mass.
    Frames are subsampled to at most ``max_frames``; playback runs at ``fps``.
    """
    path = Path(path)
    p = traj.params
    fig = _figure(4.0, 4.0)
    fig.set_dpi(dpi)
    ax = fig.add_subplot()
    ax.set_aspect("equal")
    if traj.model == "pendulum":
        reach = p.l * 1.2
        ax.set_xlim(-reach, reach)
        ax.set_ylim(-0.3 * reach, reach)
        (link,) = ax.plot([], [], "-", lw=3, color="tab:blue")
        (com,) = ax.plot([], [], "o", ms=10, color="tab:red")
    else:
        reach = (p.r + 2 * p.l) * 1.1
        ax.set_xlim(-reach, reach)
        ax.set_ylim(-0.2 * reach, reach)
        (leg,) = ax.plot([], [], "-", lw=2, color="0.3")
        (body,) = ax.plot([], [], "-", lw=6, color="tab:blue", solid_capstyle="round")
        (com,) = ax.plot([], [], "o", ms=6, color="tab:red")
    ax.axhline(0.0, color="k", lw=1)
    ax.set_xlabel("horizontal [ft]")
    ax.set_ylabel("up [ft]")
    ax.set_title(f"{traj.model} ({traj.method})", fontsize=9)
    clock = ax.text(0.02, 0.95, "", transform=ax.transAxes, fontsize=9, va="top")
    fig.tight_layout()
    dynamic = [clock, com] + ([link] if traj.model == "pendulum" else [leg, body])
    for artist in dynamic:
        artist.set_animated(True)
    canvas: Any = fig.canvas  # Agg: copy_from_bbox, restore_region, buffer_rgba
    canvas.draw()  # static background once (blitting)
    background = canvas.copy_from_bbox(fig.bbox)
    images = []
    for i in _frames(len(traj.time), max_frames):
        x = traj.states[i]
        if traj.model == "pendulum":
            c = pd.pivot_to_com(p, x[0])
            link.set_data([0.0, c[0]], [0.0, c[1]])
            com.set_data([c[0]], [c[1]])
        else:
            pts = bl.points(p, x)
            leg.set_data([0.0, pts["hip"][0]], [0.0, pts["hip"][1]])
            body.set_data([pts["hip"][0], pts["top"][0]], [pts["hip"][1], pts["top"][1]])
            com.set_data([pts["com"][0]], [pts["com"][1]])
        clock.set_text(f"t = {traj.time[i]:.2f} s")
        canvas.restore_region(background)
        for artist in dynamic:
            ax.draw_artist(artist)
        images.append(np.asarray(canvas.buffer_rgba()).copy())
    span = traj.time[-1] - traj.time[0]
    playback_fps = fps if span <= 0 else max(1.0, min(fps, len(images) / span * 1.0))
    _write_animation(images, path, playback_fps)
    return path
