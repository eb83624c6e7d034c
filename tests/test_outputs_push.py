"""What a push run writes, checked against MuJoCo and closed forms: the ground reaction forces
and centres of pressure of trajectory.csv (weight at rest, CoP on the sole), the whole-body COM
and the body's velocities (MuJoCo's masses, finite differences), the block's momentum when it
leaves the body (ballistic flight afterwards), the column dictionary, strict JSON."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from _helpers import read_csv, strict_json

import biped.models
from biped.outputs.push import column_dictionary, summary_dict, write_outputs, write_summary
from biped.sim import Scenario, build_scene, simulate
from biped.sim.measure import block_separation, foot_drift, measure_rows
from biped.sim.sweep import ballistic_impulse


@pytest.fixture(scope="module")
def w_run(tmp_path_factory):
    """W's default scenario, the full 3 s, with its files (no video/replay/figures)."""
    scenario = Scenario()
    scene = build_scene(scenario)
    result = simulate(scenario, scene=scene)
    out = tmp_path_factory.mktemp("w_run")
    write_outputs(result, out, figures=False, video=False, replay=False, scene=scene, log=lambda m: None)
    head, data = read_csv(out / "trajectory.csv")
    return {
        "scenario": scenario,
        "scene": scene,
        "result": result,
        "out": out,
        "head": head,
        "data": data,
        "col": lambda n: data[:, head.index(n)],
    }


def _biped_weight() -> float:
    """The shipped biped's weight [N] from its MJCF, loaded on its own (block and floor absent)."""
    m = mujoco.MjModel.from_xml_path(str(biped.models.path("wendlandt")))
    return float(m.body_mass.sum()) * float(np.linalg.norm(m.opt.gravity))


@pytest.mark.slow
def test_summed_vertical_grf_at_rest_equals_the_weight(w_run):
    """After recovering (last 0.5 s of W's run) the floor carries the whole biped: the vertical
    forces of both feet (MuJoCo's contact forces) sum to its weight (MJCF masses x g), and the
    horizontal ones cancel."""
    c = w_run["col"]
    t = c("time")
    rest = t > 2.5
    weight = _biped_weight()
    fz = c("left_grf_z") + c("right_grf_z")
    assert np.abs(fz[rest] / weight - 1.0).max() < 1e-3
    for a in "xy":
        assert np.abs(c(f"left_grf_{a}")[rest] + c(f"right_grf_{a}")[rest]).max() < 1e-3 * weight
    # both feet share the load (W's symmetric stance): each carries 35-65 %
    share = c("left_grf_z")[rest] / fz[rest]
    assert 0.35 < share.min() and share.max() < 0.65


@pytest.mark.slow
def test_cop_inside_the_sole_while_the_foot_is_flat(w_run):
    """Whenever a foot's heel and toe boxes both touch the floor and it carries load, its CoP
    lies on the sole: inside the rectangle the two boxes' bottom faces cover, taken from MuJoCo's
    geoms (sizes and poses at that row), to 1 mm. And the CoP column is empty when the foot
    carries no load."""
    scene, result = w_run["scene"], w_run["result"]
    c = w_run["col"]
    m = scene.model
    d = mujoco.MjData(m)
    checked = 0
    for i, foot in enumerate(("left", "right")):
        geoms = [m.geom(f"{foot}_heel").id, m.geom(f"{foot}_toe").id]
        flat = result.contacts[:, 2 * i] & result.contacts[:, 2 * i + 1]
        loaded = c(f"{foot}_grf_z") > 5.0
        assert np.isnan(c(f"{foot}_cop_x")[c(f"{foot}_grf_z") <= 0.0]).all()
        body = m.geom_bodyid[geoms[0]]
        for k in np.flatnonzero(flat & loaded)[::5]:
            d.qpos[:] = result.qpos[k]
            mujoco.mj_kinematics(m, d)
            R = d.xmat[body].reshape(3, 3)
            lo, hi = np.full(2, np.inf), np.full(2, -np.inf)
            for g in geoms:  # the box's extent in the foot frame
                centre = R.T @ (d.geom_xpos[g] - d.xpos[body])
                gR = R.T @ d.geom_xmat[g].reshape(3, 3)
                ext = np.abs(gR[:2, :2]) @ m.geom_size[g][:2]
                lo = np.minimum(lo, centre[:2] - ext)
                hi = np.maximum(hi, centre[:2] + ext)
            cop = np.array([c(f"{foot}_cop_x")[k], c(f"{foot}_cop_y")[k], 0.0])
            local = (R.T @ (cop - d.xpos[body]))[:2]
            assert np.all(local > lo - 1e-3) and np.all(local < hi + 1e-3), (foot, k, local, lo, hi)
            checked += 1
    assert checked > 200


@pytest.mark.slow
def test_whole_body_com_and_velocities_against_mujoco(w_run):
    """whole_body_com = sum m_i x_i / sum m_i over the biped's bodies (MJCF masses, positions
    from mj_kinematics); its velocity and the central body's linear and angular velocities
    match central differences of the recorded positions and orientations."""
    scene, result = w_run["scene"], w_run["result"]
    c = w_run["col"]
    m = scene.model
    d = mujoco.MjData(m)
    biped = [b for b in range(1, m.nbody) if b != scene.block_body]
    mass = m.body_mass[biped]
    com = np.zeros((len(result.times), 3))
    for k in range(len(result.times)):
        d.qpos[:] = result.qpos[k]
        mujoco.mj_kinematics(m, d)
        com[k] = mass @ d.xipos[biped] / mass.sum()
    wcom = np.stack([c(f"whole_body_com_{a}") for a in "xyz"], axis=1)
    assert np.abs(wcom - com).max() < 1e-12
    dt = result.times[1] - result.times[0]
    smooth = result.times > 1.0  # after the hit and the landing
    fd = (com[2:] - com[:-2]) / (2 * dt)
    vel = np.stack([c(f"whole_body_com_vel_{a}") for a in "xyz"], axis=1)[1:-1]
    assert np.abs(fd - vel)[smooth[1:-1]].max() < 1e-4
    # during the hit the velocities are large: compare there too, relative to their size, on rows
    # whose neighbours see the same contacts (a central difference across an impact is not a
    # derivative)
    flags = np.column_stack([result.contacts, c("block_contact")]).astype(bool)
    same = (flags[:-2] == flags[1:-1]).all(axis=1) & (flags[2:] == flags[1:-1]).all(axis=1)
    hit = (result.times[1:-1] > 0.07) & (result.times[1:-1] < 0.4) & same
    scale = np.abs(vel[hit]).max()
    assert scale > 0.05 and np.abs(fd - vel)[hit].max() < 0.02 * scale
    cb = np.stack([c(f"central_body_com_{a}") for a in "xyz"], axis=1)
    cbv = np.stack([c(f"central_body_vel_{a}") for a in "xyz"], axis=1)[1:-1]
    fd_cb = (cb[2:] - cb[:-2]) / (2 * dt)
    assert np.abs(fd_cb - cbv)[hit].max() < 0.02 * np.abs(cbv[hit]).max()
    quat = np.stack([c(f"quat_{a}") for a in "wxyz"], axis=1)
    w = np.stack([c(f"central_body_angvel_{a}") for a in "xyz"], axis=1)[1:-1]
    fd_w = np.zeros_like(w)
    conj = np.zeros(4)
    rel = np.zeros(4)
    for k in range(1, len(quat) - 1):  # world-frame rotation from row k-1 to k+1
        mujoco.mju_negQuat(conj, quat[k - 1])
        mujoco.mju_mulQuat(rel, quat[k + 1], conj)
        mujoco.mju_quat2Vel(fd_w[k - 1], rel, 2 * dt)
    assert np.abs(w[hit]).max() > 0.1  # the hit turns the body
    assert np.abs(fd_w - w)[hit].max() < 0.02 * np.abs(w[hit]).max()


@pytest.mark.slow
def test_block_momentum_after_is_taken_when_the_block_leaves_the_body(w_run):
    """block_momentum_after is the block's momentum at the first row without a block-biped
    contact after the hit: from there the block flies free (its momentum changes by m g t only,
    a closed form) until it lands, while the row before it was still being pushed. It equals
    the sweep's independent ballistic estimate of the impulse, and differs from the momentum at
    the end of the run (the block lies on the floor)."""
    result = w_run["result"]
    summary = strict_json((w_run["out"] / "summary.json").read_text())
    mass = result.scenario.block_mass_kg
    g = np.array([0.0, 0.0, -9.81])
    t_sep = summary["block_leaves_body_time_s"]
    p_after = np.array(summary["block_momentum_after_kg_m_s"])
    p_before = np.array(summary["block_momentum_before_kg_m_s"])
    assert summary["block_contact_time_s"] < t_sep < summary["block_contact_time_s"] + 0.05
    k = int(np.argmin(np.abs(result.times - t_sep)))
    v = result.block_velocity
    assert mass * v[k] == pytest.approx(p_after, abs=1e-12)
    flight = []
    for j in range(k, len(result.times)):
        if result.block[j, 2] < 0.1:  # near the floor: the free flight is over
            break
        flight.append(j)
    assert len(flight) > 10
    for j in flight:
        expect = p_after + mass * g * (result.times[j] - t_sep)
        assert mass * v[j] == pytest.approx(expect, abs=1e-9)
    k_hit = int(np.argmin(np.abs(result.times - summary["block_contact_time_s"])))
    during = p_after + mass * g * (result.times[k_hit] - t_sep)
    assert np.linalg.norm(mass * v[k_hit] - during) > 1.0  # the hit changed it: not ballistic
    J, _ = ballistic_impulse(result.times, v, mass)
    # the impulse the block delivered is its momentum change, gravity taken out
    assert -J == pytest.approx(p_after - p_before - mass * g * t_sep, abs=1e-9)
    p_end = np.array(summary["block_momentum_end_kg_m_s"])
    assert np.linalg.norm(p_end) < 1e-3 and np.linalg.norm(p_after) > 0.5


@pytest.mark.slow
def test_feet_drift_is_checkable_from_the_csv(w_run):
    """The README's "feet drift ~5 mm in +y, ~1 mm in -x": the summary's feet_drift_m is the feet
    frames' displacement from the hit to the end, and the CSV's foot columns give the same."""
    summary = strict_json((w_run["out"] / "summary.json").read_text())
    drift = summary["feet_drift_m"]
    c = w_run["col"]
    t = c("time")
    k0 = int(np.argmin(np.abs(t - drift["from_s"])))
    for foot in ("left", "right"):
        p = np.stack([c(f"{foot}_foot_{a}") for a in "xyz"], axis=1)
        assert p[-1] - p[k0] == pytest.approx(drift[foot], abs=1e-12)
        dx, dy, _ = drift[foot]
        assert 0.003 < dy < 0.008 and -0.002 < dx < 0.0  # what the README states


def test_column_dictionary_names_every_column_with_a_unit(tmp_path):
    r = simulate(Scenario(duration_s=0.05))
    paths = write_outputs(r, tmp_path, figures=False, video=False, replay=False, log=lambda m: None)
    head, data = read_csv(paths["trajectory"])
    cols = strict_json((tmp_path / "columns.json").read_text())
    assert list(cols) == head == list(column_dictionary(r.joint_names))
    assert all(set(v) == {"unit", "meaning"} and v["unit"] for v in cols.values())
    assert cols["left_grf_z"]["unit"] == "N" and cols["right_cop_x"]["unit"] == "m"
    assert cols["central_body_angvel_z"]["unit"] == "rad/s"
    assert data.shape == (len(r.times), len(head))
    # the central-body COM at t = 0 is the scenario's initial COM (W: 1.035 m)
    assert data[0, head.index("central_body_com_z")] == pytest.approx(1.035)


def test_summary_is_strict_json_when_values_do_not_exist(tmp_path):
    """A run that stops before its first row has NaN errors and an infinite real-time factor;
    summary.json holds null there, never NaN / Infinity (not JSON)."""
    r = simulate(Scenario(duration_s=0.05))
    bad = dataclasses.replace(
        r,
        final_com_error_m=float("nan"),
        realtime_factor=float("inf"),
        final_orientation_error_deg=float("nan"),
        wall_time_s=float("nan"),
        block_momentum_before=np.array([np.nan, np.inf, -np.inf]),
    )
    path = write_summary(bad, tmp_path / "summary.json", rows=measure_rows(build_scene(r.scenario), r))
    data = strict_json(path.read_text())
    assert data["final_com_error_m"] is None and data["realtime_factor"] is None
    assert data["block_momentum_before_kg_m_s"] == [None, None, None]
    assert data["judged_against"]["final_com_error_m"] is None
    assert summary_dict(r)["block_momentum_after_kg_m_s"] is None  # no rows given: unknown


def test_joint_pd_is_judged_against_its_own_set_point():
    """The joint-PD baseline holds its initial posture: its verdict uses the initial state as set
    point; W's controller keeps the scenario's."""
    pd_run = simulate(Scenario(duration_s=0.05, controller="joint-pd"))
    s = summary_dict(pd_run)
    assert s["judged_against"]["com_m"] == list(pd_run.scenario.initial_com_m)
    assert "own" in s["judged_against"]["set_point"]
    ws = summary_dict(simulate(Scenario(duration_s=0.05)))
    assert ws["judged_against"]["com_m"] == pytest.approx(list(Scenario().target_com_m))


def test_block_separation_without_a_hit():
    r = simulate(
        Scenario(duration_s=0.05, block_position_m=(3.0, 3.0, 0.06), block_velocity_m_s=(0.0, 0.0, 0.0))
    )
    sep = block_separation(r, measure_rows(build_scene(r.scenario), r))
    assert sep.contact_time_s is None and sep.time_s is None and np.isnan(sep.momentum).all()
    assert foot_drift(r) is None or set(foot_drift(r)) == {"from_s", "to_s", "left", "right"}
