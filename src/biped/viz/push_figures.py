"""W's Figs. 3-6 for a push run: joint angles, joint torques, body position, body orientation.

Plotting only: every function takes a :class:`biped.sim.push.PushResult` and draws it; events
(block hit, heel/toe lift-off and touch-down, fall) are marked as vertical lines on every panel.

Usage, with ``result`` a :class:`~biped.sim.push.PushResult` (not a doctest: it takes a run)::

    from biped.viz.push_figures import plot_push
    plot_push(result, "runs/mine/figures")     # fig3_joint_angles.png/.svg ... fig6_orientation
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

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
        ax.axvline(result.block_contact_time_s, color="k", lw=1.2,
                   label="block hits" if legend else None)
    for e in result.events:
        ax.axvline(e.time_s, color=_FOOT_COLOURS[e.foot],
                   ls="--" if e.kind == "lift_off" else ":", lw=1.0 if e.part == "heel" else 0.5,
                   alpha=0.7)
    if result.fall_time_s is not None:
        ax.axvspan(result.fall_time_s, result.times[-1] + 1e-9, color="0.8", alpha=0.5)


def _legend_events(fig):
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color="k", lw=1.2, label="block hits the body"),
               Line2D([], [], color="tab:blue", ls="--", label="left lift-off"),
               Line2D([], [], color="tab:blue", ls=":", label="left touch-down"),
               Line2D([], [], color="tab:red", ls="--", label="right lift-off"),
               Line2D([], [], color="tab:red", ls=":", label="right touch-down")]
    fig.legend(handles=handles, loc="lower center", ncol=5, fontsize=7, frameon=False)


def _legs_figure(result, values, ylabel, title):
    plt = _pyplot()
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(8, 6.5))
    names = list(result.joint_names)
    for ax, side in zip(axes, ("left", "right"), strict=True):
        for j, label in enumerate(_LEG_LABELS):
            col = names.index(f"{side}_{_LEG_JOINTS[j]}")
            ax.plot(result.times, values[:, col], lw=1.2, label=label)
        mark_events(ax, result)
        ax.set_ylabel(f"{side} leg: {ylabel}")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, ncol=3, loc="best")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title)
    _legend_events(fig)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    return fig


def fig3_joint_angles(result):
    """W Fig. 3: joint angles theta_2..theta_13 [deg] against time."""
    return _legs_figure(result, np.degrees(result.joint_angles), "joint angle [deg]",
                        "Joint angles (W Fig. 3)")


def fig4_joint_torques(result):
    """W Fig. 4: joint torques [N m] against time (held over each control period)."""
    return _legs_figure(result, result.torques, "joint torque [N m]", "Joint torques (W Fig. 4)")


def fig5_body_position(result):
    """W Fig. 5: central-body COM position [cm] against the set point."""
    plt = _pyplot()
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(8, 6.5))
    for i, (ax, c) in enumerate(zip(axes, "xyz", strict=True)):
        ax.plot(result.times, 100 * result.com[:, i], lw=1.4, label=f"COM {c}")
        ax.axhline(100 * result.target_com[i], color="0.3", ls="-.", lw=1.0, label="set point")
        mark_events(ax, result)
        ax.set_ylabel(f"{c} [cm]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("Central-body COM position (W Fig. 5)")
    _legend_events(fig)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    return fig


def fig6_orientation(result):
    """W Fig. 6: central-body orientation quaternion (w, x, y, z) against the set point."""
    plt = _pyplot()
    fig, axes = plt.subplots(4, 1, sharex=True, figsize=(8, 7.5))
    q = result.quat * np.sign(result.quat @ result.target_quat)[:, None]  # same hemisphere
    for i, (ax, c) in enumerate(zip(axes, "wxyz", strict=True)):
        ax.plot(result.times, q[:, i], lw=1.4, label=f"q_{c}")
        ax.axhline(result.target_quat[i], color="0.3", ls="-.", lw=1.0, label="set point")
        mark_events(ax, result)
        ax.set_ylabel(f"q_{c}")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("Central-body orientation quaternion (W Fig. 6)")
    _legend_events(fig)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    return fig


FIGURES = {
    "fig3_joint_angles": fig3_joint_angles,
    "fig4_joint_torques": fig4_joint_torques,
    "fig5_body_position": fig5_body_position,
    "fig6_orientation": fig6_orientation,
}


def plot_push(result, out_dir) -> list[Path]:
    """Write Figs. 3-6 of ``result`` as PNG and SVG into ``out_dir``; returns the paths."""
    plt = _pyplot()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, make in FIGURES.items():
        fig = make(result)
        try:
            for ext in ("png", "svg"):
                p = out / f"{name}.{ext}"
                fig.savefig(p, dpi=120, metadata={"Date": None} if ext == "svg" else None)
                paths.append(p)
        finally:
            plt.close(fig)
    return paths
