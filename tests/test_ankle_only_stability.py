"""The ankle-only lean release stays a finite simulation: the hold of the hips and knees is stable
by a closed-form bound, and the ideal preset's divergence came from W's min-norm split tipping the
feet onto their heels, which the protocol's QP distribution removes (docs/validate.md, "The
ideal's ankle-only divergence")."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest


def _ankle_scenario(lean_deg: float, **extra):
    from biped.analysis.validate import EXPERIMENTS
    from biped.sim.scenario import Scenario

    exp = EXPERIMENTS["ankle_release"]
    return Scenario(neuromotor="ideal", **{**exp.base, **exp.magnitude(lean_deg), **extra})


def test_ankle_only_hold_is_inside_the_explicit_spring_stability_bound():
    """MuJoCo integrates a joint's spring explicitly (its damping implicitly, with the Euler
    integrator): a spring k on an apparent inertia I with damping b and step h is stable for
    ``k h^2 / I < 4 - 2 b h / I`` (Jury's test on the explicit scheme, b explicit: the stricter
    case). I is each held joint's smallest apparent inertia, ``1 / (M^-1)_jj`` of MuJoCo's
    joint-space mass matrix of the floating biped at the protocol's starting pose (every other
    joint free, no contact): the hold must meet the bound with a margin of 10 at every hip and
    knee hinge, so it cannot be what diverges."""
    from biped.sim.scene import LOCK_DAMPING_N_M_S, LOCK_STIFFNESS_N_M_RAD, build_scene, initial_state

    s = _ankle_scenario(6.0)
    scene = build_scene(s)
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:], _ = initial_state(scene, s)
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    Minv = np.linalg.inv(M)
    h = m.opt.timestep
    held = 0
    for j in range(m.njnt):
        name = m.joint(j).name
        if m.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE or m.jnt_stiffness[j] == 0:
            continue
        assert "ankle" not in name
        held += 1
        k, b = float(m.jnt_stiffness[j]), float(m.dof_damping[m.jnt_dofadr[j]])
        assert (k, b) == (LOCK_STIFFNESS_N_M_RAD, LOCK_DAMPING_N_M_S)
        dof = m.jnt_dofadr[j]
        inertia = 1.0 / Minv[dof, dof]
        assert k * h**2 / inertia < (4.0 - 2.0 * b * h / inertia) / 10.0, (name, inertia)
    assert held == 8  # hip ab-/adduction, flexion, rotation and knee of both legs


def _foot_pitch_deg(r) -> np.ndarray:
    """Each row's largest |pitch| of the two feet (their orientation about the lateral axis) [deg]."""
    w, x, y, z = (r.feet_quat[..., i] for i in range(4))
    return np.degrees(np.abs(np.arcsin(np.clip(2 * (w * y - z * x), -1, 1)))).max(axis=1)


@pytest.mark.slow
def test_ideal_ankle_only_divergence_was_the_feet_tipping_and_the_qp_removes_it():
    """The ideal preset leaned 4.02 deg (ankles only): with W's min-norm split its feet tip onto
    their heels (MuJoCo's recorded foot orientation past 10 deg) before MuJoCo's integration
    diverges; a physics step 5x smaller diverges the same way (so not a step-size instability).
    With the protocol's QP (the centre of pressure held inside each sole) the same lean and a
    larger one that diverged before (6 deg) keep every recorded state finite and the run
    undiverged and standing for the protocol's 4 s; the feet pitch under 5 deg (the heels rise
    2-3.4 deg while the centre of pressure sits at the toes, where the min-norm split tipped them
    past 10 deg the other way, onto the heels)."""
    from biped.sim import simulate
    from biped.sim.scene import build_scene

    for step in (None, 0.0001):
        extra = {"distribution": "statics"} | ({} if step is None else {"physics_timestep_s": step})
        s = _ankle_scenario(4.02, **extra)
        r = simulate(s, scene=build_scene(s))
        assert r.diverged is not None, step
        k = int(np.argmax(~np.isfinite(r.torques).all(axis=1) | (np.abs(r.torques).max(axis=1) > 1e3)))
        assert k > 0 and _foot_pitch_deg(r)[:k].max() > 10.0, step
    for lean in (4.02, 6.0):
        s = _ankle_scenario(lean)
        assert s.distribution == "qp"
        r = simulate(s, scene=build_scene(s))
        assert r.diverged is None and r.controller_error is None, lean
        assert np.isfinite(r.qpos).all() and np.isfinite(r.qvel).all() and np.isfinite(r.torques).all()
        assert not r.fell and math.isclose(r.times[-1], s.duration_s, abs_tol=0.01), lean
        assert _foot_pitch_deg(r).max() < 5.0, (lean, _foot_pitch_deg(r).max())
