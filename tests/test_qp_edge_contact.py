"""A foot pitched onto one end's edge (on its toe, heel up, or on its heel) is a line contact in
the QP (:func:`biped.control.cones.edge_contact`, ``QPWeights.edge_contact``; docs/controller.md,
"A foot on its toe: the edge contact"), checked against MuJoCo's own contacts: on W's model with a
floor, the pitched foot's contact points lie on the QP's strip along the lower edge, MuJoCo's
contact wrench meets the strip's rows, the QP's centre of pressure is on that edge, and the flat
sole's solution puts it where MuJoCo has no contact (it would need a heel force)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from biped.control import WorkspaceController
from biped.control.cones import EDGE_HALF_LINE, contact_rows, edge_contact, floor_friction_rows
from biped.control.distribution import QPWeights
from biped.errors import ScenarioError
from biped.model import sole_rectangles
from biped.spatial import adjoint, transform

FLOOR = '<geom name="floor" type="plane" size="5 5 0.1" contype="1" conaffinity="2"/>'


@pytest.fixture(scope="module")
def floor_model(wendlandt_path):
    """W's model with a floor; the left foot does not collide (single support on the right)."""
    xml = open(wendlandt_path).read().replace("<worldbody>", "<worldbody>\n" + FLOOR, 1)
    m = mujoco.MjModel.from_xml_string(xml)
    for g in range(m.ngeom):
        if m.geom_bodyid[g] == m.body("left_foot").id:
            m.geom_contype[g] = m.geom_conaffinity[g] = 0
    return m


def _sole_pose(m, d, sole):
    b = m.body("right_foot").id
    return transform(d.ximat[b].reshape(3, 3), d.xipos[b]) @ sole.g_foot_sole


def _pitched(m, sole, dq, pen=0.001):
    """W's keyframe with the right ankle's dorsiflexion moved by dq [rad], the body lowered or
    raised so that the right sole's lowest corner is ``pen`` into the floor; after mj_forward."""
    d = mujoco.MjData(m)
    d.qpos[:] = m.key_qpos[m.key("wendlandt_initial").id]
    d.qpos[m.jnt_qposadr[m.joint("right_ankle_dorsiflexion").id]] += dq
    mujoco.mj_kinematics(m, d)
    g = _sole_pose(m, d, sole)
    X, Y = sole.half_length, sole.half_width
    z = min((g @ [sx * X, sy * Y, 0.0, 1.0])[2] for sx in (-1, 1) for sy in (-1, 1))
    d.qpos[2] -= z + pen
    mujoco.mj_forward(m, d)
    return d


def _mujoco_contacts(m, d, g0s):
    """MuJoCo's contact points on the right foot in its sole frame (n, 3) and their summed
    wrench on the foot in the sole frame at the sole centre."""
    fb = m.body("right_foot").id
    R, p = g0s[:3, :3], g0s[:3, 3]
    pts, w = [], np.zeros(6)
    for i in range(d.ncon):
        c = d.contact[i]
        b1, b2 = m.geom_bodyid[c.geom1], m.geom_bodyid[c.geom2]
        if fb not in (b1, b2):
            continue
        f6 = np.zeros(6)
        mujoco.mj_contactForce(m, d, i, f6)
        fw = c.frame.reshape(3, 3).T @ f6[:3]  # on geom2, in the world
        if b2 != fb:
            fw = -fw
        ps, fs = R.T @ (c.pos - p), R.T @ fw
        pts.append(ps)
        w += np.concatenate([fs, np.cross(ps, fs)])
    return np.array(pts), w


@pytest.mark.parametrize("dq, end", [(-0.17, -1.0), (0.17, 1.0)], ids=["toe", "heel"])
def test_the_pitched_foot_is_the_line_mujoco_touches(wendlandt_path, floor_model, dq, end):
    """The right foot pitched 9.7 deg (toe: heel up; heel: toe up), its lower edge 1 mm into the
    floor: MuJoCo's contacts are on that edge only, inside the QP's strip; MuJoCo's contact
    wrench meets the strip's rows; the QP's CoP is on the edge; the flat sole's CoP is not."""
    m = floor_model
    sole = sole_rectangles(m)[1]
    X, Y = sole.half_length, sole.half_width
    d = _pitched(m, sole, dq)
    g0s = _sole_pose(m, d, sole)
    pts, w_mj = _mujoco_contacts(m, d, g0s)
    assert len(pts) >= 2 and w_mj[2] > 0.5  # MuJoCo pushes on the foot
    np.testing.assert_allclose(pts[:, 0], end * X, atol=2e-4)  # the lower end's edge, nothing else
    assert np.ptp(pts[:, 1]) > 1.9 * Y  # both corners: a line, not a point
    rise = 2 * X * abs(g0s[2, 0])  # the raised end's height above the lower one
    assert rise > QPWeights().edge_lift_m[1]
    cop = {}
    for edge in (True, False):
        wts = QPWeights(leg_weight=0.0, floor_friction=True, edge_contact=edge)
        ctrl = WorkspaceController.from_mjcf(wendlandt_path, distribution="qp", qp_weights=wts)
        out = ctrl.compute(d.qpos, d.qvel, feet_in_contact=(False, True))
        assert ctrl.qp.status == 0
        gfs = sole.g_foot_sole
        w = adjoint(gfs[:3, :3], gfs[:3, 3]).T @ out.foot_wrench_right  # the QP's, sole frame
        cop[edge] = -w[4] / w[2]
        xn, cx = ctrl.qp._dims[1, 2:4]
        if edge:  # the strip: 2 EDGE_HALF_LINE wide, its outer side the lower end's edge
            assert xn == pytest.approx(EDGE_HALF_LINE) and cx + end * xn == pytest.approx(end * X)
            assert np.all(np.abs(pts[:, 0] - cx) <= xn + 2e-4)  # MuJoCo's contacts inside it
            # MuJoCo's wrench (its elliptic cone of friction 0.3 about the floor's normal inside
            # the pyramid of 0.3 on the floor's axes) meets the strip's normal-force, friction and
            # CoP rows (0-9; the CoP within 0.2 mm: MuJoCo's contact point is the middle of the
            # 1 mm penetration, not the sole's plane). Not the yaw rows: they are derived for the
            # pyramid on the sole's axes, which a pitched sole's floor friction leaves
            Ct, b = np.zeros((18, 6)), np.zeros(18)
            contact_rows(xn, Y, cx, 0.3, 0.0, 1e9, 0, Ct, b, 0)
            floor_friction_rows(g0s, np.eye(4), 0.3, 0, Ct, 0)
            assert np.all((Ct @ w_mj - b)[:10] >= -2e-4 * w_mj[2])
            assert abs(cop[edge] - end * X) <= 2 * EDGE_HALF_LINE + 1e-9
            assert np.all(Ct @ w - b >= -1e-6 * np.linalg.norm(w))
        else:
            assert (xn, cx) == (X, 0.0)
    # the flat sole's solution puts the CoP 5 cm or more inside, where MuJoCo has no contact
    assert abs(cop[False] - end * X) > 0.05


def test_a_flat_foot_keeps_the_whole_sole(wendlandt_path, wendlandt_mj):
    """W's keyframe (soles flat): the same solution to the bit with the edge contact or without."""
    m = wendlandt_mj
    d = mujoco.MjData(m)
    d.qpos[:] = m.key_qpos[m.key("wendlandt_initial").id]
    mujoco.mj_forward(m, d)
    outs = []
    for edge in (True, False):
        ctrl = WorkspaceController.from_mjcf(
            wendlandt_path, distribution="qp", qp_weights=QPWeights(edge_contact=edge)
        )
        outs.append(ctrl.compute(d.qpos, d.qvel).torques.copy())
        np.testing.assert_array_equal(ctrl.qp._dims[:, 2], ctrl.qp._dims[:, 0])
        np.testing.assert_array_equal(ctrl.qp._dims[:, 3], 0.0)
    np.testing.assert_array_equal(outs[0], outs[1])


@pytest.mark.parametrize("theta_deg", [0.5, 1.0, 2.0, 3.0, 3.4, 4.0, 10.0, -2.0, -10.0])
def test_the_far_edge_moves_with_the_raised_end(theta_deg):
    """edge_contact against the closed form: a sole of half length X pitched by theta about its
    y axis raises one end 2 X sin(theta) above the other; up to the start height the whole sole,
    from the full height the strip at the lower end, the far edge linear in the height between."""
    X, lift0, lift1 = 0.12, 0.005, 0.015
    t = math.radians(theta_deg)
    R = np.array([[math.cos(t), 0, math.sin(t)], [0, 1, 0], [-math.sin(t), 0, math.cos(t)]])
    gf = transform(R, np.zeros(3))
    xn, cx = edge_contact(gf, np.eye(4), X, lift0, lift1, EDGE_HALF_LINE)
    rise = 2 * X * abs(math.sin(t))
    lower = X if R[2, 0] < 0 else -X  # the end whose world z is lower
    if rise <= lift0:
        assert (xn, cx) == (X, 0.0)
        return
    far = -lower * (1 - 2 * min(1.0, (rise - lift0) / (lift1 - lift0)))  # the far edge, closed form
    if abs(far - lower) < 2 * EDGE_HALF_LINE:
        far = lower - math.copysign(2 * EDGE_HALF_LINE, lower)
    assert cx + math.copysign(xn, lower) == pytest.approx(lower, abs=1e-12)  # the lower edge kept
    assert cx - math.copysign(xn, lower) == pytest.approx(far, abs=1e-12)


def test_edge_contact_off_and_bad_heights():
    assert not QPWeights().edge_contact  # opt-in (docs/controller.md, "A foot on an edge")
    assert QPWeights(edge_contact=False).array[10] == -1.0
    for bad in ((0.01, 0.005), (-0.001, 0.01), (0.0, float("nan"))):
        with pytest.raises(ScenarioError, match="edge_lift_m must be"):
            QPWeights(edge_lift_m=bad)
