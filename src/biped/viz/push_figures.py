"""W's Figs. 3-6 for a push run: joint angles, joint torques, body position, body orientation.

Plotting only: every function takes a :class:`biped.sim.push.PushResult` and draws it; events
(block hit, heel/toe lift-off and touch-down, fall) are marked as vertical lines on every panel.

Usage (needs a run's result, so not a doctest)::

    from biped.viz.push_figures import plot_push
    plot_push(result, "runs/mine/figures")     # fig3_joint_angles.png ... fig6_orientation.png

Each figure has, beside the whole run, a panel of its first :data:`ZOOM_S` = 0.5 s (where the
hit and the feet's events crowd), with the events named; Fig. 6 adds the orientation error in
degrees (roll, pitch, yaw about the set point) beside the quaternion components.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from biped import files
from biped.errors import ScenarioError
from biped.models import LEG_JOINTS as _LEG_JOINTS

_LEG_LABELS = tuple(j.replace("_", " ") for j in _LEG_JOINTS)
_FOOT_COLOURS = {"left": "tab:blue", "right": "tab:red"}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def mark_events(ax, result, *, legend: bool = False) -> None:
    """Vertical lines: block hit (black), lift-off (dashed) and touch-down (dotted) per foot
    (left blue, right red; heel thick, toe thin), fall (grey band)."""
    if result.block_contact_time_s is not None:
        ax.axvline(result.block_contact_time_s, color="k", lw=1.2, label="block hits" if legend else None)
    for e in result.events:
        ax.axvline(
            e.time_s,
            color=_FOOT_COLOURS[e.foot],
            ls="--" if e.kind == "lift_off" else ":",
            lw=1.0 if e.part == "heel" else 0.5,
            alpha=0.7,
        )
    if result.fall_time_s is not None:
        ax.axvspan(result.fall_time_s, result.times[-1] + 1e-9, color="0.8", alpha=0.5)


def _legend_events(fig):
    from matplotlib.lines import Line2D

    handles = [
        Line2D([], [], color="k", lw=1.2, label="block hits the body"),
        Line2D([], [], color="tab:blue", ls="--", label="left lift-off"),
        Line2D([], [], color="tab:blue", ls=":", label="left touch-down"),
        Line2D([], [], color="tab:red", ls="--", label="right lift-off"),
        Line2D([], [], color="tab:red", ls=":", label="right touch-down"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=5, fontsize=7, frameon=False)


#: The zoomed panels show the first ZOOM_S seconds of the run, where the hit and the feet's
#: events crowd.
ZOOM_S = 0.5


def _panels(nrows, *, height=6.5, zoom=True):
    """A figure with ``nrows`` full-length panels on the left and, if ``zoom``, beside each one
    a panel of the first :data:`ZOOM_S` s (same y axis). Returns (fig, full axes, zoom axes)."""
    plt = _pyplot()
    if not zoom:
        fig, full = plt.subplots(nrows, 1, sharex=True, figsize=(8, height), squeeze=False)
        return fig, list(full[:, 0]), []
    fig, axes = plt.subplots(
        nrows,
        2,
        sharex="col",
        sharey="row",
        figsize=(11.5, height),
        squeeze=False,
        gridspec_kw={"width_ratios": (2.2, 1.0)},
    )
    return fig, list(axes[:, 0]), list(axes[:, 1])


def _finish_zoom(result, zooms, *, labels=True):
    """x limits of the zoom panels, events marked, and (top panel) each event named."""
    if not zooms:
        return
    t0 = float(result.times[0]) if len(result.times) else 0.0
    for ax in zooms:
        mark_events(ax, result)
        ax.set_xlim(t0, t0 + ZOOM_S)
        ax.grid(alpha=0.3)
    zooms[0].set_title(f"first {ZOOM_S:g} s", fontsize=8)
    zooms[-1].set_xlabel("time [s]")
    if labels:
        top = zooms[0]
        evs = [(result.block_contact_time_s, "block")] if result.block_contact_time_s is not None else []
        evs += [
            (e.time_s, f"{e.foot[0].upper()} {e.part} {'up' if e.kind == 'lift_off' else 'down'}")
            for e in result.events
        ]
        evs = sorted((t, lab) for t, lab in evs if t0 <= t <= t0 + ZOOM_S)
        groups: list[list] = []  # events closer than 6 % of the panel share a label
        for t, lab in evs:
            if groups and t - groups[-1][0][0] < 0.06 * ZOOM_S:
                groups[-1].append((t, lab))
            else:
                groups.append([(t, lab)])
        for i, g in enumerate(groups):
            text = "\n".join(f"{t:.3f} {lab}" for t, lab in g)
            top.annotate(
                text,
                (g[0][0], 1.0),
                xycoords=("data", "axes fraction"),
                xytext=(2, -3 - 42 * (i % 2)),
                textcoords="offset points",
                fontsize=5.5,
                va="top",
                color="0.15",
                bbox={"boxstyle": "square,pad=0.1", "fc": "white", "ec": "none", "alpha": 0.7},
            )


def _layout(fig, *, top=0.9, bottom=0.13, wspace=0.06, hspace=0.11) -> None:
    """Fixed margins, as matplotlib's ``tight_layout(rect=(0, 0.04, 1, 1))`` finds them for W's run
    with a little room for wider tick labels: computing them for every figure took a third of
    the figures' time (0.2-0.3 s a figure, benchmarks/outputs.py)."""
    fig.subplots_adjust(left=0.09, right=0.977, top=top, bottom=bottom, wspace=wspace, hspace=hspace)


def _legs_figure(result, values, ylabel, title, zoom=True):
    fig, axes, zooms = _panels(2, zoom=zoom)
    names = list(result.joint_names)
    for i, side in enumerate(("left", "right")):
        for j, label in enumerate(_LEG_LABELS):
            col = names.index(f"{side}_{_LEG_JOINTS[j]}")
            for ax in [axes[i]] + zooms[i : i + 1]:
                ax.plot(result.times, values[:, col], lw=1.2, label=label if ax is axes[i] else None)
        mark_events(axes[i], result)
        axes[i].set_ylabel(f"{side} leg: {ylabel}")
        axes[i].grid(alpha=0.3)
    axes[0].legend(fontsize=7, ncol=3, loc="best")
    axes[-1].set_xlabel("time [s]")
    _finish_zoom(result, zooms)
    fig.suptitle(title)
    _legend_events(fig)
    _layout(fig)
    return fig


def fig3_joint_angles(result, zoom=True):
    """W Fig. 3: joint angles theta_2..theta_13 [deg] against time (right: the first 0.5 s), with
    the MJCF hinges' signs, which the title states: a flexed knee is negative (the crouch starts
    at -77 deg), hip flexion and ankle dorsiflexion positive."""
    return _legs_figure(
        result,
        np.degrees(result.joint_angles),
        "joint angle [deg]",
        "Joint angles (W Fig. 3); signs of the model's hinges: knee flexion is negative",
        zoom,
    )


def fig4_joint_torques(result, zoom=True):
    """W Fig. 4: joint torques [N m] against time, held over each control period (right: the
    first 0.5 s)."""
    return _legs_figure(result, result.torques, "joint torque [N m]", "Joint torques (W Fig. 4)", zoom)


def fig5_body_position(result, zoom=True):
    """W Fig. 5: central-body COM position [cm] against the set point (right: the first 0.5 s)."""
    fig, axes, zooms = _panels(3, zoom=zoom)
    for i, (ax, c) in enumerate(zip(axes, "xyz", strict=False)):
        for a in [ax] + zooms[i : i + 1]:
            a.plot(result.times, 100 * result.com[:, i], lw=1.4, label=f"COM {c}" if a is ax else None)
            a.axhline(
                100 * result.target_com[i],
                color="0.3",
                ls="-.",
                lw=1.0,
                label="set point" if a is ax else None,
            )
        mark_events(ax, result)
        ax.set_ylabel(f"{c} [cm]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    axes[-1].set_xlabel("time [s]")
    _finish_zoom(result, zooms)
    fig.suptitle("Central-body COM position (W Fig. 5)")
    _legend_events(fig)
    _layout(fig, hspace=0.13)
    return fig


def _quat_mat(q: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation matrices of unit quaternions (..., 4) in (w, x, y, z) order."""
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def orientation_error_rpy_deg(quat, target_quat) -> np.ndarray:
    """(T, 3) roll, pitch, yaw [deg] of the central body about its set point.

    The error rotation ``R_e = R_target^T R`` (the body's orientation seen from the set point's
    frame) is written as ``R_e = Rz(yaw) Ry(pitch) Rx(roll)`` (z-y-x Euler angles about the set
    point's axes: x is the biped's fore-aft axis, it faces -x; y its left-right axis, so pitch
    is a lean forward or back; z is vertical). Small errors: each angle is the rotation about
    that axis."""
    Re = np.swapaxes(_quat_mat(np.asarray(target_quat, dtype=float)), -1, -2) @ _quat_mat(
        np.asarray(quat, dtype=float)
    )
    pitch = np.arcsin(np.clip(-Re[..., 2, 0], -1.0, 1.0))
    roll = np.arctan2(Re[..., 2, 1], Re[..., 2, 2])
    yaw = np.arctan2(Re[..., 1, 0], Re[..., 0, 0])
    return np.degrees(np.stack([roll, pitch, yaw], axis=-1))


def fig6_orientation(result, zoom=True):
    """W Fig. 6: central-body orientation quaternion (w, x, y, z) against the set point (left),
    and beside it the orientation error in degrees: roll, pitch and yaw about the set point
    (:func:`orientation_error_rpy_deg`) over the whole run and over the first 0.5 s."""
    plt = _pyplot()
    fig = plt.figure(figsize=(11.5, 7.5))
    gs = fig.add_gridspec(4, 2, width_ratios=(1.6, 1.0))
    q = result.quat * np.sign(result.quat @ result.target_quat)[:, None]  # same hemisphere
    axes: list = []
    for i, c in enumerate("wxyz"):
        ax = fig.add_subplot(gs[i, 0], sharex=axes[0] if axes else None)
        ax.plot(result.times, q[:, i], lw=1.4, label=f"q_{c}")
        ax.axhline(result.target_quat[i], color="0.3", ls="-.", lw=1.0, label="set point")
        mark_events(ax, result)
        ax.set_ylabel(f"q_{c}")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
        axes.append(ax)
    axes[-1].set_xlabel("time [s]")
    rpy = orientation_error_rpy_deg(result.quat, result.target_quat)
    err_axes = [fig.add_subplot(gs[0:2, 1])]
    if zoom:
        err_axes.append(fig.add_subplot(gs[2:4, 1], sharey=err_axes[0]))
    for ax in err_axes:
        for k, (name, col) in enumerate(
            zip(("roll (x)", "pitch (y)", "yaw (z)"), ("tab:purple", "tab:green", "tab:brown"), strict=False)
        ):
            ax.plot(result.times, rpy[:, k], color=col, lw=1.3, label=name)
        ax.axhline(0.0, color="0.3", ls="-.", lw=1.0)
        mark_events(ax, result)
        ax.grid(alpha=0.3)
        ax.set_ylabel("error about the set point [deg]", fontsize=8)
    err_axes[0].legend(fontsize=7, loc="best")
    err_axes[0].set_title("orientation error, z-y-x angles", fontsize=9)
    if zoom:
        _finish_zoom(result, err_axes[1:])
        err_axes[1].set_title(f"the same, first {ZOOM_S:g} s", fontsize=8)
    else:
        err_axes[0].set_xlabel("time [s]")
    fig.suptitle("Central-body orientation (W Fig. 6): quaternion and error in degrees")
    _legend_events(fig)
    _layout(fig, top=0.91, bottom=0.12, wspace=0.13, hspace=0.52)
    return fig


FIGURES = {
    "fig3_joint_angles": fig3_joint_angles,
    "fig4_joint_torques": fig4_joint_torques,
    "fig5_body_position": fig5_body_position,
    "fig6_orientation": fig6_orientation,
}


#: The formats :func:`plot_push` can write.
FORMATS = ("png", "svg")


def plot_push(result, out_dir, formats=("png",), progress=None) -> list[Path]:
    """Write Figs. 3-6 of ``result`` into ``out_dir`` in each of ``formats`` (``"png"``, the
    default, and/or ``"svg"``); returns the paths. ``progress(n, N)`` is called after each of the
    ``N`` figures."""
    formats = tuple(formats)
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise ScenarioError(f"figure formats must be some of {', '.join(FORMATS)}, got {formats!r}")
    plt = _pyplot()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for k, (name, make) in enumerate(FIGURES.items()):
        fig = make(result)
        try:
            for ext in formats:
                p = out / f"{name}.{ext}"
                meta = {"Date": None} if ext == "svg" else None
                files.write_via(p, functools.partial(fig.savefig, dpi=120, metadata=meta))
                paths.append(p)
        finally:
            plt.close(fig)
        if progress is not None:
            progress(k + 1, len(FIGURES))
    return paths
