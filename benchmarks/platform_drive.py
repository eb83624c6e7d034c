"""How to drive the moving floor of ``perturbation = "platform"``: the servo-driven slide joint it
uses against a mocap body teleported along the same path each control period (docs/perturbations.md,
"platform"). Both carry W's biped (W's controller, QP distribution) through the same ramp-and-hold
move; printed: each foot's displacement against the platform's, and the peak foot slip speed
relative to the floor under it.

    python benchmarks/platform_drive.py [--move 0.1] [--friction 1.0]
"""

from __future__ import annotations

import argparse

import numpy as np

from biped.sim import Scenario, build_scene
from biped.sim.perturbations.base import hold_here, workspace_controller
from biped.sim.perturbations.platform import PLATFORM, PLATFORM_JOINT, Platform, PlatformDriver, profile
from biped.sim.push import controller_policy, run_closed_loop
from biped.sim.scene import scene_spec


def servo(sc):
    scene = build_scene(sc)
    r = run_closed_loop(sc, scene, controller_policy(sc, scene))
    m = scene.model
    x = r.qpos[:, m.jnt_qposadr[m.joint(PLATFORM_JOINT).id]]
    return r, x


class MocapDriver(PlatformDriver):
    """PlatformDriver's quiet stance and set point riding with the feet, but the platform a mocap
    body put at the path's position each control period of the ramp (no joint, no velocity)."""

    def __init__(self, scenario, model, controller, central):
        s = scenario
        self.period = 1.0 / s.control_rate_hz
        self.k0 = round(s.platform_start_s * s.control_rate_hz)
        self.k1 = self.k0 + max(1, round(s.platform_duration_s * s.control_rate_hz))
        self.rows = np.unique(np.r_[0, np.arange(self.k0, self.k1 + 1)]).astype(np.int64)
        self.distance = float(np.hypot(*s.platform_displacement_m))
        self.duration = (self.k1 - self.k0) * self.period
        self.axis = np.array([*s.platform_displacement_m, 0.0]) / self.distance
        self.mid = int(model.body_mocapid[model.body(PLATFORM).id])
        self.controller, self.central, self.target0 = controller, central, np.zeros(3)
        self.xs: list = []

    def apply(self, k, t, data):
        if k == 0 and self.controller is not None:
            self.target0, quat = hold_here(self.controller, data, self.central)
            self.final_target = (self.target0 + self.distance * self.axis, quat)
        if not self.k0 <= k <= self.k1:
            return
        tm = (
            (k - self.k0 + 1) * self.period if k < self.k1 else self.duration
        )  # where it is at the period's end
        x = float(profile(tm, self.distance, self.duration)[0])
        data.mocap_pos[self.mid] = x * self.axis
        if self.controller is not None:
            self.controller.target.array[:2] = self.target0[:2] + x * self.axis[:2]


def mocap(sc):
    """The same scene with the platform a mocap body (no joint, no actuators)."""
    import biped.sim.scene as scene_mod

    spec = scene_spec(sc)
    spec.delete(spec.joint(PLATFORM_JOINT))
    for a in list(spec.actuators):
        if a.name.startswith(PLATFORM):
            spec.delete(a)
    spec.body(PLATFORM).mocap = True
    orig_spec, orig_driver = scene_mod.scene_spec, Platform.driver
    scene_mod.scene_spec = lambda s: spec  # build_scene compiles this spec
    Platform.driver = lambda self, scene, model, data, policy: MocapDriver(  # type: ignore[method-assign]
        self.scenario, model, workspace_controller(policy), scene.central_body
    )
    try:
        scene = build_scene(sc)
        r = run_closed_loop(sc, scene, controller_policy(sc, scene))
    finally:
        scene_mod.scene_spec, Platform.driver = orig_spec, orig_driver
    t = r.times - sc.platform_start_s
    x = profile(t, float(np.hypot(*sc.platform_displacement_m)), sc.platform_duration_s)[0]
    return r, x


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--move", type=float, default=0.1)
    ap.add_argument("--friction", type=float, default=1.0)
    args = ap.parse_args()
    sc = Scenario(
        physics="fast", distribution="qp", perturbation="platform", duration_s=1.0,
        platform_displacement_m=(args.move, 0.0), friction=args.friction,
    )  # fmt: skip
    for name, fn in (("servo-driven slide (used)", servo), ("mocap, teleported", mocap)):
        r, x = fn(sc)
        feet = r.feet_pos[-1, :, 0] - r.feet_pos[0, :, 0]
        vf = np.diff(r.feet_pos[:, :, 0], axis=0) * sc.control_rate_hz
        vp = np.diff(x)[:, None] * sc.control_rate_hz
        slip = np.abs(vf - vp).max()
        print(
            f"{name:28s} platform {x[-1] * 100:6.2f} cm, feet {feet[0] * 100:6.2f} / {feet[1] * 100:6.2f} cm, "
            f"peak foot slip speed {slip:.3f} m/s, fell {r.fell}"
        )


if __name__ == "__main__":
    main()
