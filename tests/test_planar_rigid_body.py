"""McGhee's 6-DOF rigid body (B Appendix A, eq. 4.24, 4.25) against MuJoCo and conservation laws."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from biped.errors import SingularityError, StateError
from biped.planar import rigid_body as rb
from biped.planar import symbolic
from biped.spatial import quat_to_rot, rot_to_quat

MASS, INERTIA, G = 10.0, (2.0, 3.0, 4.0), 32.2185

# B's earth frame has z down: a MuJoCo world whose gravity points along +z is the same frame.
MJCF = f"""
<mujoco>
  <option gravity="0 0 {G}" timestep="0.001" integrator="RK4"/>
  <worldbody>
    <body name="body">
      <freejoint/>
      <inertial pos="0 0 0" mass="{MASS}" diaginertia="{INERTIA[0]} {INERTIA[1]} {INERTIA[2]}"/>
    </body>
  </worldbody>
</mujoco>
"""


def _integrate(p, x0, t_end, wrench_world=None):
    def f(t, x):
        R = rb.rotation_matrix(*x[3:6])
        w = (
            np.zeros(6)
            if wrench_world is None
            else np.concatenate([R.T @ wrench_world[:3], R.T @ wrench_world[3:]])
        )
        return rb.state_derivative(p, x, w)

    sol = solve_ivp(f, (0, t_end), x0, rtol=1e-11, atol=1e-12, method="DOP853")
    return sol.y[:, -1]


def test_follows_mujoco_free_body_under_same_force_and_torque():
    p = rb.RigidBodyParams(MASS, INERTIA, G)
    x0 = np.array([0.1, -0.2, 0.3, 0.2, 0.3, -0.4, 1.0, -0.5, 0.3, 0.7, -0.4, 1.1])
    wrench_world = np.array([15.0, -40.0, -200.0, 3.0, -2.0, 1.5])  # constant in the earth frame
    t_end = 1.0

    model = mujoco.MjModel.from_xml_string(MJCF)
    data = mujoco.MjData(model)
    R0 = rb.rotation_matrix(*x0[3:6])
    data.qpos[:3] = x0[:3]
    data.qpos[3:7] = rot_to_quat(R0)
    data.qvel[:3] = R0 @ x0[6:9]  # free joint: linear velocity in the world frame
    data.qvel[3:6] = x0[9:12]  # angular velocity in the body frame
    data.xfrc_applied[1] = wrench_world
    for _ in range(round(t_end / model.opt.timestep)):
        mujoco.mj_step(model, data)

    x = _integrate(p, x0, t_end, wrench_world)
    np.testing.assert_allclose(x[:3], data.qpos[:3], atol=1e-8)
    np.testing.assert_allclose(rb.rotation_matrix(*x[3:6]), quat_to_rot(data.qpos[3:7]), atol=1e-8)
    np.testing.assert_allclose(x[9:12], data.qvel[3:6], atol=1e-8)
    R = rb.rotation_matrix(*x[3:6])
    np.testing.assert_allclose(R @ x[6:9], data.qvel[:3], atol=1e-8)


def test_growth_rates_and_euler_rates_match_kanes_method():
    """Eq. 4.24, 4.25 and the Euler-rate matrix against a sympy KanesMethod derivation."""
    f = symbolic.rigid_body().numeric()
    rng = np.random.default_rng(7)
    for _ in range(10):
        p = rb.RigidBodyParams(rng.uniform(1, 100), tuple(rng.uniform(1, 10, 3)), rng.uniform(0, 40))
        s = rng.uniform(-2, 2, 12)
        s[4] = rng.uniform(-1.4, 1.4)
        wrench = rng.uniform(-50, 50, 6)
        expected = f((p.mass, *p.inertia, p.g), s, wrench)
        np.testing.assert_allclose(rb.state_derivative(p, s, wrench), expected, rtol=1e-12, atol=1e-12)


def test_torque_free_keeps_energy_and_angular_momentum():
    p = rb.RigidBodyParams(MASS, INERTIA, g=0.0)
    x0 = np.array([0, 0, 0, 0.1, -0.2, 0.3, 1.0, 2.0, -0.5, 0.3, 0.2, 2.0])
    e0, h0 = rb.kinetic_energy(p, x0), rb.angular_momentum_earth(p, x0)
    x = _integrate(p, x0, 5.0)
    assert rb.kinetic_energy(p, x) == pytest.approx(e0, rel=1e-9)
    np.testing.assert_allclose(rb.angular_momentum_earth(p, x), h0, rtol=1e-8, atol=1e-9)
    assert not np.allclose(x[9:12], x0[9:12])  # the body rate did change (asymmetric top)


def test_gravity_in_every_row_of_eq_4_24():
    """At rest, the growth rate is earth gravity (0, 0, g) seen in body axes, for any attitude
    (B's print drops g from the second row)."""
    p = rb.RigidBodyParams(MASS, INERTIA, G)
    for phi, theta, psi in [(0.5, 0.3, -1.0), (-1.2, 0.7, 2.0)]:
        x = np.array([0, 0, 0, phi, theta, psi, *np.zeros(6)])
        d = rb.state_derivative(p, x, np.zeros(6))
        R = rb.rotation_matrix(phi, theta, psi)
        np.testing.assert_allclose(R @ d[6:9], [0, 0, G], atol=1e-12)
        np.testing.assert_allclose(d[9:12], 0.0)


def test_euler_angles_round_trip():
    for ang in [(0.3, -0.2, 2.5), (-2.0, 1.2, -0.3)]:
        np.testing.assert_allclose(rb.euler_angles(rb.rotation_matrix(*ang)), ang, atol=1e-12)


def test_gimbal_lock_raises():
    p = rb.RigidBodyParams()
    x = np.array([0, 0, 0, 0.1, math.pi / 2 - 1e-4, 0, 0, 0, 0, 0, 0.1, 0])
    with pytest.raises(SingularityError, match="gimbal lock"):
        rb.state_derivative(p, x, np.zeros(6))
    x[4] = -math.pi / 2
    with pytest.raises(SingularityError, match="-?90"):
        rb.state_derivative(p, x, np.zeros(6))
    x[4] = 1.5  # 4 deg away is fine
    assert np.all(np.isfinite(rb.state_derivative(p, x, np.zeros(6))))


def test_bad_state():
    p = rb.RigidBodyParams()
    with pytest.raises(StateError, match="must be finite"):
        rb.state_derivative(p, [np.nan] + [0.0] * 11, np.zeros(6))
