"""The compiled push loop (biped.sim.fused) against the Python loop it replaces.

The Python loop of ``run_closed_loop`` (``compiled=False``: the ContactMonitor in Python, the
policy called through its Python wrappers, ``mujoco.mj_step`` from the bindings) is the reference:
the compiled loop must give the same result bit for bit (every record, the events, the fall and
its reason), on W's run, with the sensed feet and torque limits, on a fall, on sweep trials, and
when it hands rows back to Python.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from biped.control import distribution
from biped.control.limits import torque_limits
from biped.control.policy import symmetric_limits
from biped.sim import Scenario, build_scene, contact, fused, mjdata
from biped.sim.push import RecordedTorques, controller_policy, run_closed_loop

ARRAYS = ("times", "qpos", "qvel", "com", "quat", "joint_angles", "torques", "block", "contacts")
ARRAYS += ("feet_pos", "feet_quat", "block_velocity", "block_momentum_after", "loop_measures")
FIELDS = ("events", "block_contact_time_s", "fell", "fall_time_s", "fall_reason", "recovered")
FIELDS += ("controller_error", "diverged", "interrupted", "final_com_error_m")


def both(scenario: Scenario, **policy_kw):
    scene = build_scene(scenario)
    a = run_closed_loop(scenario, scene, controller_policy(scenario, scene, **policy_kw), compiled=True)
    b = run_closed_loop(scenario, scene, controller_policy(scenario, scene, **policy_kw), compiled=False)
    return a, b


def assert_same(a, b):
    for name in ARRAYS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.shape == y.shape and np.array_equal(x, y, equal_nan=name == "loop_measures"), name
    for name in FIELDS:
        assert getattr(a, name) == getattr(b, name), name


def test_the_feet_masks_follow_the_sole_table():
    """The loop's (contact's) per-foot masks against SOLE_GEOMS: bit i is sole part i."""
    for b in range(1 << len(contact.SOLE_GEOMS)):
        on = [foot for i, (foot, _) in enumerate(contact.SOLE_GEOMS) if b >> i & 1]
        feet = ("left" in on, "right" in on)
        assert (bool(b & fused._LEFT_MASK), bool(b & fused._RIGHT_MASK)) == feet
        assert (
            contact._FEET[b]
            == contact.feet_of_bits(b)
            == contact.feet_of_bits(b | contact._BLOCK_BIT)
            == feet
        )


def test_cache_key_covers_the_controller_sources():
    """The loop compiles the controller's kernel in: its cache key names those files too."""
    import biped.control.recursions

    stamp = fused._run_rows._cache._cache_file._source_stamp
    own, extra = stamp
    # recursions, statics, buffers, spatial, distribution, fused_qp, cones, daqp_c, contact, neuromotor,
    # loop_measures, schedule, step_trigger, fused_step, and the plain swing's swing_period,
    # swing_kernel, mj_functions
    import os

    from biped.control import mj_functions, swing_kernel, swing_period

    assert len(extra) == 17
    assert extra[0][1] == os.stat(biped.control.recursions.__file__).st_size
    swing = (swing_period.__file__, swing_kernel.__file__, mj_functions.__file__)
    assert extra[-3:] == tuple((os.stat(f).st_mtime, os.stat(f).st_size) for f in swing)


def test_the_stepping_rows_cache_key_covers_the_masks_and_the_trigger():
    """stepping_row compiles in contact's feet masks, step_trigger's kernel and constants and the
    plain swing's kernels (swing_period, the swing law and its MuJoCo calls): its cache key names
    those files too (a user's NUMBA_CACHE_DIR then never loads it stale)."""
    import os

    from biped.control import step_trigger
    from biped.sim import fused_step

    own, extra = fused_step.stepping_row._cache._cache_file._source_stamp
    from biped.control import mj_functions, swing_kernel, swing_period

    files = (contact.__file__, step_trigger.__file__, swing_period.__file__, swing_kernel.__file__)
    files += (mj_functions.__file__,)
    assert extra == tuple((os.stat(f).st_mtime, os.stat(f).st_size) for f in files)


def test_mjdata_layout_reads_what_the_bindings_read():
    """ncon and the contacts' geom pairs and positions, read through the struct offsets, equal
    MuJoCo's own ``data.ncon`` / ``data.contact.geom`` / ``.pos`` over a run with changing contacts."""
    sc = Scenario(physics="fast", duration_s=0.3)
    scene = build_scene(sc)
    m, d = scene.model, mujoco.MjData(scene.model)
    from biped.sim.scene import initial_state

    d.qpos[:], d.qvel[:] = initial_state(scene, sc)
    mujoco.mj_forward(m, d)
    layout = fused.mjdata_layout(m, d)
    assert layout is not None, mjdata.last_failure
    s32, s64, cptr, c0, geom, pos = layout
    ncon_i = mjdata._OFFSETS[0][0]
    seen = set()
    for _ in range(300):
        mujoco.mj_step(m, d, 2)
        assert s32[ncon_i] == d.ncon
        if d.ncon:
            assert int(s64[cptr]) == c0
            assert np.array_equal(geom[: d.ncon], d.contact.geom)
            assert np.array_equal(pos[: d.ncon], d.contact.pos)
        seen.add(d.ncon)
    assert len(seen) > 2  # the contacts did change


@pytest.mark.parametrize("physics", ["fast", "faithful"])
def test_compiled_loop_is_the_python_loop(physics):
    """W's run through the block hit (0.082 s) and the heel lifting: identical results."""
    a, b = both(Scenario(physics=physics, duration_s=0.4))
    assert a.block_contact_time_s is not None and len(a.events) > 2
    assert_same(a, b)


def test_sensed_feet_and_torque_limits():
    sc = Scenario(physics="fast", duration_s=0.4, support="sensed", block_velocity_m_s=(-6.0, 0.0, 0.1))
    a, b = both(sc, torque_limits=symmetric_limits(40.0))
    assert np.any(np.abs(a.torques) == 40.0) and np.all(np.abs(a.torques) <= 40.0)  # clipped
    assert_same(a, b)


@pytest.mark.parametrize("gain_scale", [1.0, 0.3])
def test_joint_pd(gain_scale):
    """The joint-PD baseline (its gains scaled as a sweep does), through the block hit."""
    sc = Scenario(physics="fast", duration_s=0.4, controller="joint-pd")
    a, b = both(sc, gain_scale=gain_scale)
    assert fused.fused_controller(controller_policy(sc, build_scene(sc))) is not None
    assert a.block_contact_time_s is not None and np.abs(a.torques).max() > 1.0
    assert_same(a, b)


def test_a_fall_and_a_divergence():
    """A fall (a set point 10 cm lower takes the COM under a raised fall height mid-run) and a
    divergence (a 20 kg block at 6 m/s): the run stops at the same row with the same reason."""
    sc = Scenario(physics="fast", duration_s=0.5, target_com_m=(-0.01, 0.0, 1.0), fall_height_m=1.02)
    a, b = both(sc)
    assert a.fell and "below" in a.fall_reason and 0.01 < a.fall_time_s < 0.5
    assert_same(a, b)
    sc = Scenario(physics="fast", duration_s=0.5, block_mass_kg=20.0, block_velocity_m_s=(-6.0, 0.0, 0.0))
    a, b = both(sc)
    assert a.diverged and len(a.times) < 250
    assert_same(a, b)


def test_rows_handed_back_to_python(monkeypatch):
    """A contact buffer that seems to have moved sends every row with contacts to the Python
    loop (and the rows without to the compiled one): still the same result."""
    real = fused.mjdata_layout

    def moved(model, data):
        s32, s64, cptr, c0, geom, pos = real(model, data)
        return s32, s64, cptr, c0 + 8, geom, pos

    monkeypatch.setattr(fused, "mjdata_layout", moved)
    a, b = both(Scenario(physics="fast", duration_s=0.2))
    # the response's records of a row whose contacts moved during its step are redone by a
    # forward pass (loop_measures.fill_rows): the same to the constraint solver's tolerance
    ra, rb = a.loop_measures, b.loop_measures
    np.testing.assert_allclose(ra, rb, rtol=0, atol=1e-3)
    assert np.array_equal(ra[:, :6], rb[:, :6]) and np.array_equal(ra[:, 16:], rb[:, 16:])
    a.loop_measures[:] = b.loop_measures
    assert_same(a, b)


def test_other_policies_keep_the_python_loop():
    sc = Scenario(physics="fast", duration_s=0.02)
    scene = build_scene(sc)
    from biped.errors import ScenarioError

    with pytest.raises(ScenarioError, match="compiled loop"):
        run_closed_loop(sc, scene, RecordedTorques(np.zeros((11, 12)), 500.0), compiled=True)
    stepping = sc.with_overrides(stepping=True)  # (stepping runs compiled: tests/test_sim_fused_step.py)
    assert fused.fused_controller(controller_policy(stepping, build_scene(stepping))) is not None


def both_qp(scenario: Scenario, **policy_kw):
    """``both`` for the QP distribution, also returning the two runs' ContactQP objects (the
    solve runs in Python in both loops: its fallbacks counted on the controller's own QP)."""
    scene = build_scene(scenario)
    pa = controller_policy(scenario, scene, **policy_kw)
    pb = controller_policy(scenario, scene, **policy_kw)
    assert fused.fused_controller(pa) is not None  # the QP runs in the compiled loop
    a = run_closed_loop(scenario, scene, pa, compiled=True)
    b = run_closed_loop(scenario, scene, pb, compiled=False)
    qa, qb = pa.policy.controller.qp, pb.policy.controller.qp
    assert qa.status == qb.status and qa.fallbacks == qb.fallbacks
    assert np.array_equal(qa.x, qb.x) and np.array_equal(qa.Gq, qb.Gq) and np.array_equal(qa.b, qb.b)
    return a, b, qa


@pytest.mark.parametrize("physics", ["fast", "faithful"])
def test_qp_distribution(physics):
    """W's push with distribution "qp" (always the sensed feet) through the block hit and the
    heel contacts' flicker: identical results, solver status and fallback counts."""
    a, b, _ = both_qp(Scenario(physics=physics, duration_s=0.4, distribution="qp"))
    assert a.block_contact_time_s is not None and len(a.events) > 2
    assert_same(a, b)


def test_qp_torque_limits_and_fallbacks():
    """Human torque limits (rows of the QP), and limits so low (0.5 N m) that the minimum normal
    force cannot be met: the RELAXED retry happens at the same periods, the counters agree (and
    the biped falls at the same row)."""
    sc = Scenario(physics="fast", duration_s=0.4, distribution="qp")
    a, b, qp = both_qp(sc, torque_limits=torque_limits("human", body_mass_kg=73.0))
    assert qp.limited
    assert_same(a, b)
    sc = Scenario(physics="fast", duration_s=0.3, distribution="qp", block_velocity_m_s=(-6.0, 0.0, 0.1))
    a, b, qp = both_qp(sc, torque_limits=symmetric_limits(0.5))
    assert qp.fallbacks[distribution.RELAXED] > 0  # (ZEROED: counted alike, not reached here)
    assert a.fell and np.all(np.abs(a.torques) <= 0.5)
    assert_same(a, b)


def test_qp_solves_in_c_and_the_objmode_path_still_agrees(monkeypatch):
    """With the installed daqp (a checked version) the loop solves the QP with daqp's C function,
    bit for bit the Python path's daqp.solve (the tests above); with the C path refused (as for
    another daqp version) it goes through objmode, with the same results."""
    import importlib.metadata

    from biped.control import daqp_c

    solves = []
    real = daqp_c.sync_status

    def counting(qp, qstat):
        solves.append(int(qstat[daqp_c.S_SOLVES]))
        real(qp, qstat)

    monkeypatch.setattr(fused, "sync_status", counting)
    sc = Scenario(physics="fast", duration_s=0.3, distribution="qp")
    a, b, _ = both_qp(sc)
    assert_same(a, b)
    if importlib.metadata.version("daqp") in daqp_c.CHECKED_VERSIONS:
        assert daqp_c.daqp_c() is not None  # the structs passed the check against daqp.solve
        assert sum(solves) > 100  # every period with a foot down was solved in C
    solves.clear()
    monkeypatch.setattr(daqp_c, "_C", [None])  # as if the installed daqp had another layout
    a2, b2, _ = both_qp(sc)
    assert solves == []  # no C solve: objmode
    assert_same(a2, b2)
    assert_same(a, a2)


def test_qp_fall_and_a_foot_in_the_air():
    """A fall (the COM set point 10 cm lower under a raised fall height) and a 4 kg block that
    lifts a foot (its wrench an equality row, zero): the same rows, events and fall."""
    sc = Scenario(
        physics="fast", duration_s=0.5, distribution="qp", target_com_m=(-0.01, 0.0, 1.0), fall_height_m=1.02
    )
    a, b, _ = both_qp(sc)
    assert a.fell and "below" in a.fall_reason
    assert_same(a, b)
    sc = Scenario(
        physics="fast",
        duration_s=0.6,
        distribution="qp",
        block_velocity_m_s=(-6.0, 0.0, 0.1),
        block_mass_kg=4.0,
    )
    a, b, _ = both_qp(sc)
    assert (a.left_contact != a.right_contact).any()  # a foot in the air while the other stood
    assert (~a.left_contact & ~a.right_contact).any()  # and no foot down (the first rows): no solve
    assert_same(a, b)


def test_sweep_rows_unchanged(monkeypatch):
    """Sweep trials (``run_trial``: the sweep's scene cache, its policy, its measurements) give
    the same rows with the compiled loop as with the Python loop."""
    from biped.sim.sweep import SweepSpec, hold_scenario
    from biped.sim.sweep.trial import run_trial

    base = hold_scenario(Scenario(physics="fast")).with_overrides(duration_s=0.4)
    spec = SweepSpec(axes={"speed_m_s": (3.0, 6.0), "direction_deg": (0.0, 90.0, 180.0)}, base=base)
    pd = SweepSpec(
        axes={"speed_m_s": 5.0, "direction_deg": (0.0, 90.0)}, base=base.with_overrides(controller="joint-pd")
    )
    setups = [spec.setup(t) for t in spec.trials()] + [pd.setup(t) for t in pd.trials()]
    made = []
    real = fused.fused_rows
    monkeypatch.setattr(fused, "fused_rows", lambda *a, **k: made.append(real(*a, **k)) or made[-1])
    compiled = [run_trial(s) for s in setups]
    assert len(made) == 8 and all(f is not None for f in made)  # the trials ran compiled
    monkeypatch.setattr(fused, "fused_rows", lambda *a, **k: None)
    python = [run_trial(s) for s in setups]
    assert len(compiled) == 8
    for a, b in zip(compiled, python, strict=True):
        assert a.keys() == b.keys()
        for key in a:
            same = a[key] == b[key] or (a[key] != a[key] and b[key] != b[key])  # NaN == NaN
            assert same, (key, a[key], b[key])


@pytest.mark.slow
def test_w_full_run_and_a_sweep_are_unchanged():
    """W's 3 s run (faithful; min-norm and qp) and a few sweep trials (fast): the compiled loop's results and
    events are those of the Python loop."""
    a, b = both(Scenario())
    assert_same(a, b)
    a, b, _ = both_qp(Scenario(distribution="qp"))  # W's push with the QP, 3 s
    assert a.recovered
    assert_same(a, b)
    for velocity in ((-3.0, 1.0, 0.3), (-5.0, -2.0, 0.2), (2.0, 0.5, 0.4)):
        a, b = both(Scenario(physics="fast", block_velocity_m_s=velocity))
        assert_same(a, b)
