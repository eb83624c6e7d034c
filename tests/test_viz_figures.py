"""What the figures show, read back from the matplotlib axes and the rendered pixels.

Oracles: orientations composed with MuJoCo's own quaternion functions (``mju_axisAngle2Quat``,
``mju_mulQuat``) from known roll, pitch and yaw angles, and scipy's Euler decomposition; the
event times of the run; the body-leg model's characteristic polynomial roots (``numpy.roots``,
not the eigenvalues the map is made of); the friction ratio recomputed from the ground forces;
the colours of each curve found in the rendered image.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import matplotlib
import mujoco
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from biped.models import JOINT_NAMES
from biped.viz.push_figures import (
    ZOOM_S,
    fig3_joint_angles,
    fig5_body_position,
    fig6_orientation,
    orientation_error_rpy_deg,
)


def _axis_angle(axis, deg):
    q = np.empty(4)
    mujoco.mju_axisAngle2Quat(q, np.asarray(axis, dtype=float), math.radians(deg))
    return q


def _mul(a, b):
    q = np.empty(4)
    mujoco.mju_mulQuat(q, a, b)
    return q


def _target():
    return _axis_angle([0, -1, 0], 7.5)  # W's set point leans about -y


def _compose(target, roll, pitch, yaw):
    """target * Rz(yaw) * Ry(pitch) * Rx(roll), with MuJoCo's quaternion product."""
    q = _mul(target, _axis_angle([0, 0, 1], yaw))
    q = _mul(q, _axis_angle([0, 1, 0], pitch))
    return _mul(q, _axis_angle([1, 0, 0], roll))


def _fake_run(T=301, dt=0.01):
    """A push-run-shaped record whose body turns by known roll, pitch and yaw about the set point."""
    t = np.arange(T) * dt
    roll = 3.0 * np.sin(2 * t)
    pitch = 10.0 * np.exp(-2 * t)
    yaw = -5.0 * t * np.exp(-t)
    target = _target()
    quat = np.array([_compose(target, r, p, y) for r, p, y in zip(roll, pitch, yaw, strict=False)])
    quat[::7] *= -1  # the sign of a quaternion is free
    ev = SimpleNamespace
    events = (
        ev(time_s=0.086, foot="left", part="heel", kind="lift_off"),
        ev(time_s=0.274, foot="left", part="heel", kind="touch_down"),
        ev(time_s=1.2, foot="right", part="toe", kind="lift_off"),
    )
    rng = np.random.default_rng(0)
    return SimpleNamespace(
        times=t,
        quat=quat,
        target_quat=target,
        joint_names=JOINT_NAMES,  # W's biped's 12 leg joints
        joint_angles=rng.normal(size=(T, 12)).cumsum(0) * 0.01,
        torques=rng.normal(size=(T, 12)),
        com=np.column_stack([0.01 * np.sin(t), 0 * t, 1.1 + 0 * t]),
        target_com=np.array([0.0, 0.0, 1.1]),
        events=events,
        block_contact_time_s=0.082,
        fall_time_s=None,
    ), np.column_stack([roll, pitch, yaw])


def test_orientation_error_is_roll_pitch_yaw_about_the_set_point():
    from scipy.spatial.transform import Rotation

    run, rpy = _fake_run()
    got = orientation_error_rpy_deg(run.quat, run.target_quat)
    np.testing.assert_allclose(got, rpy, atol=1e-9)
    # scipy's intrinsic z-y-x angles of R_target^T R agree (scipy takes (x, y, z, w))
    rel = Rotation.from_quat(run.target_quat[[1, 2, 3, 0]]).inv() * Rotation.from_quat(
        run.quat[:, [1, 2, 3, 0]]
    )
    np.testing.assert_allclose(got[:, ::-1], rel.as_euler("ZYX", degrees=True), atol=1e-9)
    # a pure lean about the set point's y axis is all pitch
    q = _mul(run.target_quat, _axis_angle([0, 1, 0], 4.0))
    np.testing.assert_allclose(orientation_error_rpy_deg(q[None], run.target_quat), [[0, 4, 0]], atol=1e-12)


def _vertical_lines(ax):
    return sorted(
        {
            float(ln.get_xdata()[0])
            for ln in ax.get_lines()
            if len(ln.get_xdata()) == 2 and ln.get_xdata()[0] == ln.get_xdata()[1]
        }
    )


def test_fig6_plots_the_error_in_degrees_beside_the_quaternion_and_zooms_on_the_hit():
    run, rpy = _fake_run()
    fig = fig6_orientation(run)
    try:
        by_title = {ax.get_title(): ax for ax in fig.axes}
        full = by_title["orientation error, z-y-x angles"]
        zoom = by_title[f"the same, first {ZOOM_S:g} s"]
        for ax in (full, zoom):
            curves = {ln.get_label(): ln for ln in ax.get_lines() if len(ln.get_xdata()) > 2}
            for k, name in enumerate(("roll (x)", "pitch (y)", "yaw (z)")):
                np.testing.assert_allclose(curves[name].get_ydata(), rpy[:, k], atol=1e-9)
            assert "deg" in ax.get_ylabel()
        assert zoom.get_xlim() == pytest.approx((0.0, ZOOM_S))
        want = sorted([run.block_contact_time_s] + [e.time_s for e in run.events])
        assert _vertical_lines(full) == pytest.approx(want)
        # the zoom panel names the events inside it: the hit and the heel's lift-off share a
        # label (4 ms apart), the touch-down has its own; the event at 1.2 s is not named
        texts = [t.get_text() for t in zoom.texts]
        assert texts == ["0.082 block\n0.086 L heel up", "0.274 L heel down"], texts
        # the quaternion panels are still there, one per component
        assert sum(ax.get_ylabel() in ("q_w", "q_x", "q_y", "q_z") for ax in fig.axes) == 4
    finally:
        plt.close(fig)


@pytest.mark.parametrize("make", [fig3_joint_angles, fig5_body_position])
def test_each_panel_has_a_zoom_of_the_first_half_second_with_the_same_data(make):
    run, _ = _fake_run()
    fig = make(run)
    try:
        axes = [ax for ax in fig.axes if ax.get_lines()]
        zooms = [ax for ax in axes if ax.get_xlim() == pytest.approx((0.0, ZOOM_S))]
        fulls = [ax for ax in axes if ax not in zooms]
        assert len(zooms) == len(fulls) >= 2
        for f, z in zip(fulls, zooms, strict=False):
            fc = [ln.get_ydata() for ln in f.get_lines() if len(ln.get_xdata()) == run.times.size]
            zc = [ln.get_ydata() for ln in z.get_lines() if len(ln.get_xdata()) == run.times.size]
            assert len(fc) == len(zc) >= 1
            for a, b in zip(fc, zc, strict=False):
                np.testing.assert_array_equal(a, b)
            assert z.get_ylim() == f.get_ylim()
            evs = [t for t in _vertical_lines(z) if t <= ZOOM_S]
            assert evs == pytest.approx([0.082, 0.086, 0.274])
        if make is fig3_joint_angles:
            col = list(run.joint_names).index("left_knee")
            knee = next(ln for ln in fulls[0].get_lines() if ln.get_label() == "knee")
            np.testing.assert_allclose(knee.get_ydata(), np.degrees(run.joint_angles[:, col]))
    finally:
        plt.close(fig)


def _pixels_of(fig, colour, tol=40):
    """How many pixels of the drawn figure are within ``tol`` of ``colour`` (RGB 0..255)."""
    fig.canvas.draw()
    img = np.asarray(fig.canvas.buffer_rgba())[..., :3].astype(int)
    return int((np.abs(img - np.asarray(colour)).max(axis=-1) < tol).sum())


def test_comparison_shows_every_run_in_the_legend_even_when_two_coincide():
    from matplotlib.colors import to_rgb

    from biped.planar import runs
    from biped.viz.posture import comparison_figure

    trajs = {
        m: runs.simulate_body_leg(method=m, gains=runs.BODY_LEG_GAINS, duration=2.0)
        for m in ("lagrange-linear", "lagrange", "newton-euler")
    }
    # the case of the issue: two forms give the same curve to rounding
    assert np.abs(trajs["lagrange"].states - trajs["newton-euler"].states).max() < 1e-9
    fig = comparison_figure(trajs)
    try:
        assert fig._suptitle is not None and fig._suptitle.get_text()
        ax = fig.axes[0]
        entries = [t.get_text() for t in ax.get_legend().get_texts()]
        assert len(entries) == 3 and [e.split()[0] for e in entries] == list(trajs)
        diff = float(entries[2].split("from lagrange: ")[1].split()[0])  # says it coincides
        assert diff < 1e-9
        # every legend entry's colour is seen in the drawn figure, outside the legend too
        ax.get_legend().set_visible(False)
        for line in ax.get_lines():
            rgb = 255 * np.array(to_rgb(line.get_color()))
            if line.get_alpha() is not None:  # a pale line on white
                rgb = 255 - line.get_alpha() * (255 - rgb)
            assert _pixels_of(fig, rgb) > 200, line.get_label()
    finally:
        plt.close(fig)


def test_stability_map_marks_the_best_gains_on_it_and_found():
    from biped.planar import analysis
    from biped.planar.body_leg import BodyLegParams
    from biped.viz.posture import stability_map_figure

    p = BodyLegParams()
    k1, k2 = np.linspace(0, 50000, 21), np.linspace(0, 50000, 17)
    smap = analysis.stability_map(p, k1, k2, 2500.0, 400.0)
    # oracle: roots of the characteristic polynomial (eq. 3.80), not the map's eigenvalues
    margin = np.array(
        [
            [-np.roots(analysis.characteristic_polynomial(p, (a, 2500.0, b, 400.0))).real.max() for a in k1]
            for b in k2
        ]
    )
    i, j = np.unravel_index(np.argmax(margin), margin.shape)
    best = SimpleNamespace(gains=np.array([15776.0, 4999.9, 4776.0, 717.5]), margin=3.83)
    fig = stability_map_figure(smap, {"B": (25000.0, 40000.0)}, best=best)
    try:
        ax = fig.axes[0]
        star = next(ln for ln in ax.get_lines() if ln.get_marker() == "*")
        assert (star.get_xdata()[0], star.get_ydata()[0]) == (k1[j], k2[i])
        assert f"{margin[i, j]:.3g}" in star.get_label()
        diamond = next(ln for ln in ax.get_lines() if ln.get_marker() == "D")
        assert (diamond.get_xdata()[0], diamond.get_ydata()[0]) == (15776.0, 4776.0)
        legend = [t.get_text() for t in ax.get_legend().get_texts()]
        assert any("best on this map" in t for t in legend)
        assert any("best found" in t and "K_theta1dot = 5000" in t for t in legend), legend
    finally:
        plt.close(fig)


def test_walk_friction_panel_reaches_the_peak_the_summary_reports():
    from biped.kinematic.dynamics import InverseDynamics
    from biped.viz.walk_figures import inverse_dynamics_figure

    T = 400
    t = np.arange(T) / 100.0
    grf = np.zeros((T, 2, 3))
    grf[:, :, 2] = 350.0 + 50 * np.sin(t)[:, None]
    grf[:, :, 0] = 40.0 * np.cos(3 * t)[:, None]
    grf[123, 0] = [31.4, 0.0, 2.0]  # a foot nearly unloaded: 15.7 needed
    stance = np.ones((T, 2), bool)
    stance[200:220, 1] = False
    idyn = SimpleNamespace(
        times=t,
        joint_names=tuple(
            f"{side}_{j}"
            for side in ("left", "right")
            for j in (
                "hip_flexion",
                "knee",
                "ankle_dorsiflexion",
                "hip_abduction",
                "hip_rotation",
                "ankle_inversion",
            )
        ),
        torques=np.zeros((T, 12)),
        grf=grf,
        stance=stance,
        mass=75.0,
        gravity=9.81,
        residual=np.zeros((T, 6)),
    )
    idyn.friction_ratio = lambda: InverseDynamics.friction_ratio(idyn)
    # the peak recomputed here from the forces, row by row
    peak = max(
        math.hypot(*grf[k, j, :2]) / grf[k, j, 2]
        for k in range(T)
        for j in range(2)
        if stance[k, j] and grf[k, j, 2] > 0
    )
    assert peak == pytest.approx(15.7)
    fig = inverse_dynamics_figure(idyn, [{"time_s": 1.0, "label": "step"}])
    try:
        ax = next(a for a in fig.axes if "needed" in a.get_ylabel())
        lo, hi = ax.get_ylim()
        assert hi > peak and lo > 0 and ax.get_yscale() == "log"
        left = next(ln for ln in ax.get_lines() if ln.get_label() == "left")
        assert np.nanmax(left.get_ydata()) == pytest.approx(peak)
        assert any("peak 15.7" in tx.get_text() and "t = 1.23 s" in tx.get_text() for tx in ax.texts)
        # W's friction 0.3 is still drawn inside the axis
        assert lo < 0.3 < hi
    finally:
        plt.close(fig)
