"""Time to draw one 1280 x 720 frame of the push video with MuJoCo's offscreen renderer.

    MUJOCO_GL=egl python benchmarks/video.py [--frames 10] [--rounds 3]

Draws frames of W's push scene (the initial posture, the block in flight) with the push video's
camera, with the shadow map at MuJoCo's default 4096 texels (the reference) and at the 2048 the
video uses (``shadows="follow"``), and without anti-aliasing for comparison; the settings are
interleaved in rounds so that a change in machine load affects all alike. Prints the median per
frame [s] and the ratio to the reference. Rendering only: no caption, no H.264 encoding.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", os.environ["MUJOCO_GL"])

import mujoco
import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()

    from biped.sim import Scenario
    from biped.sim.scene import build_scene, initial_state

    scene = build_scene(Scenario())
    m = scene.model
    m.vis.global_.offwidth, m.vis.global_.offheight = 1280, 720
    q0, _ = initial_state(scene, Scenario())
    d = mujoco.MjData(m)
    d.qpos[:] = q0
    mujoco.mj_forward(m, d)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = d.subtree_com[1]
    cam.distance, cam.azimuth, cam.elevation = 3.5, -110.0, -10.0
    settings = {
        "shadow 4096, 4x MSAA (MuJoCo's default)": (4096, 4),
        "shadow 2048, 4x MSAA (the push video)": (2048, 4),
        "shadow 2048, no MSAA": (2048, 0),
    }
    times: dict[str, list[float]] = {k: [] for k in settings}
    for _ in range(args.rounds):
        for name, (texels, samples) in settings.items():
            m.vis.quality.shadowsize, m.vis.quality.offsamples = texels, samples
            ren = mujoco.Renderer(m, 720, 1280)
            ren.update_scene(d, camera=cam)
            ren.render()  # first frame: context set-up
            for _ in range(args.frames):
                t = time.perf_counter()
                ren.update_scene(d, camera=cam)
                ren.render()
                times[name].append(time.perf_counter() - t)
            ren.close()
    ref = float(np.median(times[next(iter(settings))]))
    print(
        f"{platform.machine()}, {os.cpu_count()} cores, MUJOCO_GL={os.environ['MUJOCO_GL']}, "
        f"{args.rounds} rounds x {args.frames} frames"
    )
    for name, ts in times.items():
        med = float(np.median(ts))
        print(f"  {name:<40} median {med:.3f} s/frame   ratio {med / ref:.2f}")


if __name__ == "__main__":
    main()
