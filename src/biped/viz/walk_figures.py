"""Figures of a kinematic walk (``biped walk``): joint angles, feet against the ground, and the
torques and ground reaction forces its inverse dynamics asks for.

Plotting only: each function takes results of :mod:`biped.kinematic` and draws them; gait
changes (the plan's markers) are vertical lines on every panel.

>>> from biped.kinematic import demo
>>> from biped.viz.walk_figures import plot_joint_angles
>>> m = demo().sample(200.0)
>>> plot_joint_angles(m, "runs/mine/figures/joint_angles.png")     # doctest: +SKIP
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from biped import files

__all__ = ["inverse_dynamics_figure", "plot_feet", "plot_inverse_dynamics", "plot_joint_angles"]

_SIDE_COLOURS = {"left": "tab:blue", "right": "tab:red"}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def _markers(ax, markers, labels: bool = False):
    ymax = ax.get_ylim()[1]
    for m in markers:
        ax.axvline(m["time_s"], color="0.6", lw=0.6, ls="--")
        if labels:
            ax.text(
                m["time_s"], ymax, " " + m["label"], rotation=90, va="top", ha="left", fontsize=6, color="0.4"
            )


def _stance_bands(ax, times, stance):
    """Shade the intervals where each foot bears weight (left blue, right red)."""
    for j, sd in enumerate(("left", "right")):
        st = np.concatenate([[False], stance[:, j], [False]]).astype(int)
        d = np.diff(st)
        for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True):
            ax.axvspan(
                times[a],
                times[b - 1],
                ymin=0.0 if j == 0 else 0.03,
                ymax=0.03 if j == 0 else 0.06,
                color=_SIDE_COLOURS[sd],
                alpha=0.6,
                lw=0,
            )


def _save(fig, path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    files.write_via(path, lambda tmp: fig.savefig(tmp, dpi=110))
    _pyplot().close(fig)
    return path


def plot_joint_angles(motion, path) -> Path:
    """Hip, knee and ankle angles of both legs, torso roll and pitch, shoulders and elbows [deg]
    over time; stance intervals as bands at the bottom of the leg panels."""
    from biped.kinematic.figure import JOINT_NAMES

    plt = _pyplot()
    J = {n: i for i, n in enumerate(JOINT_NAMES)}
    t = motion.times
    a = np.degrees(motion.angles)
    panels = [
        ("hip flexion", "hip_flexion"),
        ("knee (+ extension)", "knee"),
        ("ankle dorsiflexion", "ankle_dorsiflexion"),
        ("shoulder flexion", "shoulder_flexion"),
        ("elbow flexion", "elbow_flexion"),
    ]
    fig, axes = plt.subplots(len(panels) + 1, 1, figsize=(10, 12), sharex=True)
    for ax, (title, j) in zip(axes, panels, strict=False):
        for sd in ("left", "right"):
            ax.plot(t, a[:, J[f"{sd}_{j}"]], color=_SIDE_COLOURS[sd], lw=1.0, label=sd)
        ax.set_ylabel(f"{title}\n[deg]", fontsize=8)
        if j in ("hip_flexion", "knee", "ankle_dorsiflexion"):
            _stance_bands(ax, t, motion.stance)
        _markers(ax, motion.plan.markers, labels=ax is axes[0])
    axes[0].legend(loc="upper right", fontsize=7)
    ax = axes[-1]
    ax.plot(t, a[:, J["torso_roll"]], color="tab:green", lw=1.0, label="torso roll")
    ax.plot(t, a[:, J["torso_pitch"]], color="tab:purple", lw=1.0, label="torso pitch (lean)")
    if np.any(motion.pelvis_pitch != 0):
        ax.plot(
            t,
            np.degrees(motion.pelvis_pitch) / 10.0,
            color="k",
            lw=0.8,
            label="pelvis pitch / 10 (somersault; 360 deg = 0)",
        )
    ax.set_ylabel("torso [deg]", fontsize=8)
    ax.legend(loc="upper right", fontsize=7)
    _markers(ax, motion.plan.markers)
    ax.set_xlabel("time [s]")
    fig.suptitle(
        "Kinematic figure: joint angles (B eq. 4.12-4.19 IK; bands: stance left / right)", fontsize=10
    )
    fig.tight_layout()
    return _save(fig, path)


def plot_feet(motion, landmarks: dict, path) -> Path:
    """Heights of the heels and toes above the terrain under them and the pelvis path, over time:
    what B's code does not guarantee (stance feet on the ground, swing feet clear of it)."""
    plt = _pyplot()
    t = motion.times
    terrain = motion.plan.terrain
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    ax = axes[0]
    for sd in ("left", "right"):
        for part, ls in (("heel", "-"), ("toe", ":")):
            p = landmarks[f"{sd}_{part}"]
            ax.plot(
                t,
                (p[:, 2] - terrain.height(p[:, 0])) * 100,
                color=_SIDE_COLOURS[sd],
                ls=ls,
                lw=1.0,
                label=f"{sd} {part}",
            )
    ax.axhline(0, color="k", lw=0.6)
    ax.set_ylabel("height above the\nterrain below [cm]", fontsize=8)
    ax.legend(loc="upper right", fontsize=7, ncol=2)
    _stance_bands(ax, t, motion.stance)
    _markers(ax, motion.plan.markers, labels=True)
    ax = axes[1]
    for sd in ("left", "right"):
        ax.plot(t, landmarks[f"{sd}_heel"][:, 0], color=_SIDE_COLOURS[sd], lw=1.0, label=f"{sd} heel x")
    ax.plot(t, motion.pelvis_pos[:, 0], color="k", lw=1.0, label="pelvis x")
    ax.set_ylabel("forward [m]", fontsize=8)
    ax.legend(loc="upper left", fontsize=7)
    _markers(ax, motion.plan.markers)
    ax = axes[2]
    ax.plot(t, motion.pelvis_pos[:, 2], color="k", lw=1.0, label="pelvis z (eq. 4.22 bob on level ground)")
    ax.set_ylabel("pelvis height [m]", fontsize=8)
    ax.legend(loc="upper left", fontsize=7)
    _markers(ax, motion.plan.markers)
    ax.set_xlabel("time [s]")
    fig.suptitle("Feet against the ground (bands: stance left / right)", fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


def plot_inverse_dynamics(result, markers, path) -> Path:
    """Write :func:`inverse_dynamics_figure` to ``path`` (PNG)."""
    return _save(inverse_dynamics_figure(result, markers), path)


def inverse_dynamics_figure(result, markers):
    """Sagittal and frontal joint torques, vertical and horizontal ground reaction forces (with
    body weight), the friction ratio against W's 0.3 (log scale up to its peak, which is marked),
    and the residual root force in flight."""
    plt = _pyplot()
    t = result.times
    names = list(result.joint_names)
    fig, axes = plt.subplots(5, 1, figsize=(10, 13), sharex=True)
    panels = (
        (axes[0], ("hip_flexion", "knee", "ankle_dorsiflexion"), "sagittal torques"),
        (axes[1], ("hip_abduction", "hip_rotation", "ankle_inversion"), "frontal / axial torques"),
    )
    for ax, joints, title in panels:
        styles = ("-", "--", ":")
        for j, ls in zip(joints, styles, strict=True):
            for sd in ("left", "right"):
                ax.plot(
                    t,
                    result.torques[:, names.index(f"{sd}_{j}")],
                    color=_SIDE_COLOURS[sd],
                    ls=ls,
                    lw=0.9,
                    label=f"{sd} {j}",
                )
        ax.set_ylabel(f"{title}\n[N m]", fontsize=8)
        ax.legend(loc="upper right", fontsize=6, ncol=3)
        _markers(ax, markers, labels=ax is axes[0])
    ax = axes[2]
    mg = result.mass * result.gravity
    for k, sd in enumerate(("left", "right")):
        ax.plot(t, result.grf[:, k, 2], color=_SIDE_COLOURS[sd], lw=1.0, label=f"{sd} vertical")
        ax.plot(t, result.grf[:, k, 0], color=_SIDE_COLOURS[sd], lw=0.8, ls="--", label=f"{sd} forward")
        ax.plot(t, result.grf[:, k, 1], color=_SIDE_COLOURS[sd], lw=0.6, ls=":", label=f"{sd} lateral")
    ax.axhline(mg, color="k", lw=0.6, ls="-.", label="body weight")
    ax.axhline(0, color="k", lw=0.4)
    ax.set_ylabel("ground reaction\nforce [N]", fontsize=8)
    ax.legend(loc="upper right", fontsize=6, ncol=4)
    _markers(ax, markers)
    ax = axes[3]
    fr = result.friction_ratio()
    for k, sd in enumerate(("left", "right")):
        ax.plot(t, fr[:, k], color=_SIDE_COLOURS[sd], lw=0.9, label=sd)
    ax.axhline(0.3, color="k", lw=0.6, ls="-.", label="W's friction 0.3")
    # log scale up to the peak: the summary's peak_friction_ratio (e.g. 15.7) is on the axis
    finite = fr[np.isfinite(fr) & (fr > 0)]
    if finite.size:
        peak = float(finite.max())
        pk, pj = (
            int(i) for i in np.unravel_index(np.nanargmax(np.where(np.isfinite(fr), fr, -np.inf)), fr.shape)
        )
        ax.set_yscale("log")
        ax.set_ylim(max(min(float(np.percentile(finite, 1)), 0.1) / 2, 1e-3), 2.0 * max(peak, 0.3))
        ax.plot([t[pk]], [peak], "v", color="k", ms=5)
        ax.annotate(
            f"peak {peak:.3g} (t = {t[pk]:.2f} s, {('left', 'right')[pj]})",
            (t[pk], peak),
            textcoords="offset points",
            xytext=(4, 2),
            fontsize=7,
        )
    else:
        ax.set_ylim(0, 1.0)
    ax.set_ylabel("|F_t| / F_n\nneeded (log)", fontsize=8)
    ax.legend(loc="upper right", fontsize=7)
    _markers(ax, markers)
    ax = axes[4]
    ax.plot(t, np.linalg.norm(result.residual[:, :3], axis=1), color="k", lw=1.0, label="force [N]")
    ax.plot(
        t, np.linalg.norm(result.residual[:, 3:], axis=1), color="tab:orange", lw=1.0, label="torque [N m]"
    )
    ax.set_ylabel("unsupplied root\nwrench (flight)", fontsize=8)
    ax.legend(loc="upper right", fontsize=7)
    _markers(ax, markers)
    ax.set_xlabel("time [s]")
    fig.suptitle("What the kinematic gait asks of W's biped (MuJoCo mj_inverse, de Leva masses)", fontsize=10)
    fig.tight_layout()
    return fig
