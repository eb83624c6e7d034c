"""Shared fixtures: the shipped biped model, loaded once per session.

Kept generic on purpose (other test modules may use them); oracles specific to one subject live
in that subject's test module.
"""

from __future__ import annotations

import mujoco
import pytest

from biped import models
from biped.sim import mjlog

# MuJoCo's warnings of the test session (and of the processes it starts) go to no file: never
# MUJOCO_LOG.TXT in the directory pytest runs from.
mjlog.route_to(None)


@pytest.fixture(scope="session")
def gl():
    """The offscreen OpenGL backend MuJoCo renders with here (``"egl"``, ...); skips the test where
    none works (:func:`biped.viz.video.gl_available` says why)."""
    from biped.viz.video import gl_available

    ok, why = gl_available()
    if not ok:
        pytest.skip(why)
    return why


@pytest.fixture(scope="session")
def wendlandt_path():
    """Path of the shipped MJCF of W's biped."""
    return models.path("wendlandt")


@pytest.fixture(scope="session")
def wendlandt_mj(wendlandt_path):
    """``mujoco.MjModel`` of W's biped (do not mutate: shared by the session)."""
    return mujoco.MjModel.from_xml_path(str(wendlandt_path))


# A small asymmetric two-legged tree that exercises what W's symmetric biped does not: rotated
# inertial frames (iquat), body quaternions, joint positions off the body origin, skew hinge axes,
# two different six-hinge legs bent at qpos0, and a tilted gravity. Feet: "lfoot", "rfoot".
ASYM_XML = """<mujoco model="asym"><option gravity="0.3 -0.2 -9.81"/><worldbody>
<body name="torso" pos="0.1 0.2 1" quat="0.96 0.1 -0.2 0.15"><freejoint name="root"/>
 <inertial pos="0.02 -0.01 0.05" quat="0.9 0.1 0.3 0.2" mass="20" diaginertia="1.1 0.8 0.5"/>
 <body name="l1" pos="0.05 -0.1 -0.2" quat="0.98 0.0 0.1 0.05">
  <joint name="lj1" axis="1 0.2 0" pos="0 0.01 0.03"/>
  <inertial pos="0 0.01 -0.02" mass="0.2" diaginertia="0.002 0.002 0.001"/>
  <body name="l2" pos="0 0 -0.05"><joint name="lj2" axis="0 1 0.1"/>
   <inertial pos="0 0.01 -0.1" quat="0.7 0.7 0.1 0" mass="3" diaginertia="0.1 0.08 0.02"/>
   <body name="l3" pos="0 0 -0.1"><joint name="lj3" axis="0.1 0 1" pos="0.01 0 0"/>
    <inertial pos="0.01 0 -0.15" mass="2" diaginertia="0.05 0.04 0.01"/>
    <body name="l4" pos="0 0 -0.3" quat="0.87 0 -0.5 0"><joint name="lj4" axis="0 1 0"/>
     <inertial pos="0 0 -0.2" quat="0.99 0.1 0 0" mass="2.2" diaginertia="0.04 0.035 0.008"/>
     <body name="l5" pos="0 0 -0.4" quat="0.9 0 0.43 0"><joint name="lj5" axis="1 0 0.2"/>
      <inertial pos="0 0 0" mass="0.1" diaginertia="0.001 0.001 0.001"/>
      <body name="lfoot" pos="0 0 -0.03" quat="0.99 0 0 0.1"><joint name="lj6" axis="0.3 1 0"/>
       <inertial pos="0.05 0 -0.03" quat="0.9 0 0.4 0" mass="1" diaginertia="0.005 0.004 0.002"/>
 </body></body></body></body></body></body>
 <body name="r1" pos="0.0 0.12 -0.18"><joint name="rj1" axis="1 0 0.3"/>
  <inertial pos="0 0 -0.12" mass="2.5" diaginertia="0.09 0.07 0.02"/>
  <body name="r2" pos="0.02 0 -0.1" quat="0.95 0.3 0 0"><joint name="rj2" axis="0 1 0"/>
   <inertial pos="0 0 0" mass="0.3" diaginertia="0.002 0.003 0.002"/>
   <body name="r3" pos="0 0 -0.05"><joint name="rj3" axis="0 0 1"/>
    <inertial pos="0 0 -0.18" mass="1.8" diaginertia="0.05 0.045 0.01"/>
    <body name="r4" pos="0 0.02 -0.36" quat="0.8 0 -0.6 0"><joint name="rj4" axis="0 1 0.05"/>
     <inertial pos="0 0 -0.17" mass="2" diaginertia="0.03 0.03 0.006"/>
     <body name="r5" pos="0 0 -0.38" quat="0.85 0 0.53 0"><joint name="rj5" axis="1 1 0"/>
      <inertial pos="0 0 0" mass="0.4" diaginertia="0.001 0.001 0.001"/>
      <body name="rfoot"><joint name="rj6" axis="0 1 -0.2" pos="0 0 0.02"/>
       <inertial pos="0.06 0.01 -0.04" quat="0.8 0.2 0.5 0.1" mass="1.1" diaginertia="0.006 0.005 0.002"/>
 </body></body></body></body></body></body>
</body></worldbody></mujoco>"""


@pytest.fixture(scope="session")
def asym_xml_path(tmp_path_factory):
    """Path of :data:`ASYM_XML` written to a temporary file (feet "lfoot", "rfoot")."""
    path = tmp_path_factory.mktemp("models") / "asym.xml"
    path.write_text(ASYM_XML)
    return path


@pytest.fixture(scope="session", params=["wendlandt", "asym"])
def tree_case(request, wendlandt_path, asym_xml_path):
    """(MJCF path, feet) of W's biped and of the asymmetric tree, for oracle tests over both."""
    if request.param == "wendlandt":
        return wendlandt_path, ("left_foot", "right_foot")
    return asym_xml_path, ("lfoot", "rfoot")
