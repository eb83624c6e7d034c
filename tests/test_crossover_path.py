"""The crossover's swing path timed from the step's geometry (issue #23, stance slip <= 2 cm;
``SteppingConfig.crossover_path``, :mod:`biped.control.crossover_path`): the windows against the
minimum-jerk polynomial's roots (numpy) and a brute-force check that the soles clear, and the
sideways crossover of the sweep grid (90 deg 18 m/s, fast physics) measured in MuJoCo: its stance
sole's slide and its contact forces, with the legs' contacts with each other switched on."""

from __future__ import annotations

import numpy as np
import pytest
from _helpers import leg_geoms
from test_swing_drop import SET_B, _sole_forces

from biped.control import crossover_path as cpath


def test_min_jerk_inverse_is_the_polynomials_root():
    """For f in (0, 1) the inverse is the real root in [0, 1] of ``6 u^5 - 15 u^4 + 10 u^3 - f``
    (numpy's polynomial roots); outside [0, 1] it clamps."""
    for f in (0.01, 0.2, 0.5, 0.77, 0.99):
        roots = np.roots([6, -15, 10, 0, 0, -f])
        real = [r.real for r in roots if abs(r.imag) < 1e-9 and -1e-9 <= r.real <= 1 + 1e-9]
        assert len(real) == 1
        assert cpath.min_jerk_inverse(f) == pytest.approx(real[0], abs=1e-9)
    assert cpath.min_jerk_inverse(-0.3) == pytest.approx(0.0, abs=1e-9)
    assert cpath.min_jerk_inverse(1.7) == pytest.approx(1.0, abs=1e-9)


def _path(dx, dy, wins, u):
    def mj(s):
        s = np.clip(s, 0.0, 1.0)
        return s**3 * (10 - 15 * s + 6 * s * s)

    (a0, a1), (b0, b1) = wins
    return dx * mj((u - a0) / (a1 - a0)), dy * mj((u - b0) / (b1 - b0))


@pytest.mark.parametrize(
    "dx, dy, gap", [(0.2, 0.72, -0.48), (-0.3, -0.45, 0.2), (0.05, 0.6, -0.3), (0.45, 0.5, -0.16)]
)
def test_the_timed_windows_clear_the_soles_and_accelerate_less(dx, dy, gap):
    """Sampled finely over the swing: whenever the swing sole is within the band across from the
    stance sole's centre (``|gap + y| < band``), the along-x move is done (the soles clear by the
    landing point's clearance). Where the fixed windows (x in the first 60 %, y in the last 60 %)
    clear too, the timed path's larger peak acceleration (finite differences of the sampled path)
    is no larger than theirs; from a narrow start (16 cm across) they do not clear."""
    band = 0.1
    wins = cpath.windows(dx, dy, gap, band)
    u = np.linspace(0.0, 1.0, 20001)
    x, y = _path(dx, dy, wins, u)
    inside = np.abs(gap + y) < band
    assert np.all(np.abs(x[inside] - dx) <= 1e-6 * max(abs(dx), 1.0)), (wins, x[inside].min())

    def peak(xs):
        h = u[1] - u[0]
        return np.abs(np.diff(xs, 2)).max() / h**2

    xf, yf = _path(dx, dy, cpath.FIXED, u)
    fixed_clears = bool(np.all(np.abs(xf[np.abs(gap + yf) < band] - dx) <= 1e-6 * max(abs(dx), 1.0)))
    timed, fixed = max(peak(x), peak(y)), max(peak(xf), peak(yf))
    assert timed <= fixed * (1 + 1e-3) or not fixed_clears, (wins, timed, fixed)
    assert fixed_clears == (gap != -0.16), (wins, fixed_clears)  # a narrow start: the fixed windows do not


#: Candidate C' of docs/sweep.md: set B (the stance model and the swing reaction on forward and
#: backward steps, friction 0.35 / 0.55), the ramped drop on them, the hip rotations' damping
#: compensated at rest.
C_PRIME = {
    **SET_B,
    "swing_drop_ramp": True,
    "lateral_swing_drop_ramp": False,
    "rest_damping_compensation": True,
    "rest_damping_joints": ("hip_rotation",),
}


def _run_with_leg_contacts(sc, **params):
    """The run of ``sc`` with the stepping set ``params`` on the ``"qp"`` set, MuJoCo's contacts
    between the two legs switched on: (result, MuJoCo's floor force on each sole after every
    physics step (normal, tangential) [N] (n, 2, 2), their times [s], the count of leg-leg
    contacts seen)."""

    from biped.control.stepping import SteppingController
    from biped.control.stepping_config import SteppingConfig
    from biped.sim.policies import policy_config
    from biped.sim.push import run_closed_loop
    from biped.sim.scene import build_scene

    scene = build_scene(sc)
    m = scene.model
    left, right = set(leg_geoms(m, "left")), set(leg_geoms(m, "right"))
    for gs, own, other in ((left, 4, 8), (right, 8, 4)):
        m.geom_contype[list(gs)] = own
        m.geom_conaffinity[list(gs)] = 1 | other
    soles = {m.geom(f"{s}_{p}").id: k for k, s in enumerate(("left", "right")) for p in ("heel", "toe")}
    forces, times, legs = [], [], [0]
    c6 = np.zeros(6)

    def on_step(m, d):
        fn, ft = _sole_forces(m, d, soles, c6)
        forces.append(np.stack([fn, ft], axis=1))
        times.append(d.time)
        for c in d.contact[: d.ncon]:
            a, b = int(c.geom1), int(c.geom2)
            legs[0] += (a in left and b in right) or (a in right and b in left)

    cfg = SteppingConfig.for_trigger("qp", **params)
    r = run_closed_loop(
        sc, scene, SteppingController(policy_config(sc), cfg, scene.joint_names), on_step=on_step
    )
    return r, np.array(forces), np.array(times), legs[0]


@pytest.mark.slow
def test_the_timed_crossover_keeps_the_stance_foot_within_2_cm():
    """90 deg 18 m/s, fast physics, set C' (docs/sweep.md): a sideways first step, then a
    crossover. With the fixed windows the foot is moved 0.7 m across in 0.12 s: MuJoCo's normal
    force on the stance sole exceeds 3 body weights with the tangential force at mu times it, and
    the sole slides over 4 cm (measured 5.0). Timed from the geometry the stance sole slides <= 2
    cm (measured 1.1), its normal force stays under 2.5 weights, and the run ends at rest. The
    legs' contacts with each other are on in both runs: none occurs."""
    from test_stance_slip import _stance_slips
    from test_stepping_trigger import _sweep_scenario

    from biped.sim.scene import build_scene

    sc = _sweep_scenario(18, 90, "--stepping")
    weight = float(np.sum(build_scene(sc).model.body_mass[1:])) * 9.81
    out = {}
    for path in ("fixed", "timed"):
        r, f, t, legs = _run_with_leg_contacts(sc, **C_PRIME, crossover_path=path)
        steps = r.extra["steps"]
        assert len(steps) == 2 and steps[1]["crossover"] and not steps[0]["crossover"], steps
        assert legs == 0, (path, legs)
        st = steps[1]
        k = 1 - ("left", "right").index(st["foot"])
        sel = (t >= st["lift_off_s"]) & (t <= st["touch_down_s"])
        out[path] = (max(_stance_slips(sc, r)), f[sel, k, 0].max() / weight, r)
    assert out["fixed"][0] > 0.04 and out["fixed"][1] > 3.0, out["fixed"][:2]
    assert out["timed"][0] <= 0.02 and out["timed"][1] < 2.5, out["timed"][:2]
    assert out["timed"][2].recovered


def test_crossover_path_takes_only_its_two_rules():
    """``crossover_path``: a one-line error names the two valid rules; "fixed" is the default."""
    from biped.control.stepping_config import SteppingConfig
    from biped.errors import ScenarioError

    assert SteppingConfig().crossover_path == "fixed"
    assert SteppingConfig(crossover_path="timed").crossover_path == "timed"
    with pytest.raises(ScenarioError, match="crossover_path must be 'fixed' or 'timed'; got 'arc'"):
        SteppingConfig(crossover_path="arc")


@pytest.mark.parametrize("dx, dy, gap", [(-0.57, -0.19, 0.2), (0.2, 0.72, -0.48), (0.05, 0.1, -0.3)])
def test_swing_time_bounds_the_sampled_paths_peak_acceleration(dx, dy, gap):
    """``crossover_max_acc_m_s2``: the swing time :func:`swing_time` returns makes the sampled
    path's peak acceleration (finite differences in seconds, both moves) at most the bound, equal
    to it (0.1 %) where it lengthens the swing, and keeps the set time where that is below it
    already; the constant is 10 / sqrt(3) (the minimum-jerk profile's peak, sampled)."""
    s = np.linspace(0.0, 1.0, 200001)
    prof = s**3 * (10 - 15 * s + 6 * s * s)
    assert np.abs(np.diff(prof, 2)).max() / (s[1] - s[0]) ** 2 == pytest.approx(cpath.MIN_JERK_PEAK, rel=1e-4)
    wins = cpath.windows(dx, dy, gap, 0.1)
    a_max, t0 = 120.0, 0.2
    T = cpath.swing_time(dx, dy, wins, t0, a_max)
    u = np.linspace(0.0, 1.0, 40001)
    x, y = _path(dx, dy, wins, u)
    h = (u[1] - u[0]) * T
    peak = max(np.abs(np.diff(x, 2)).max(), np.abs(np.diff(y, 2)).max()) / h**2
    assert peak <= a_max * (1 + 1e-3)
    if T > t0:
        assert peak == pytest.approx(a_max, rel=1e-3)
    else:  # already within the bound at the set time
        assert T == t0


def test_crossover_max_acc_needs_the_timed_path():
    """A bound without the timed path, or not positive, is a one-line error naming both."""
    from biped.control.stepping_config import SteppingConfig
    from biped.errors import ScenarioError

    with pytest.raises(ScenarioError, match="crossover_max_acc_m_s2 must be a positive"):
        SteppingConfig(crossover_max_acc_m_s2=120.0)
    with pytest.raises(ScenarioError, match="crossover_max_acc_m_s2 must be a positive"):
        SteppingConfig(crossover_path="timed", crossover_max_acc_m_s2=0.0)
    assert (
        SteppingConfig(crossover_path="timed", crossover_max_acc_m_s2=120.0).crossover_max_acc_m_s2 == 120.0
    )
