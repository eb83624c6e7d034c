"""The child-process side of :func:`biped.viz.video.render_video`: one MuJoCo offscreen renderer
that draws every frame of a job folder (model ``model.mjb``, ``qpos.npy``, ``job.json``) into an
H.264 MP4 file, with the caption, a floor grid for a model without one and shadows that follow the
camera.

It runs in a fresh ``python`` started by :func:`biped.viz.video.render_video` with ``MUJOCO_GL``
already set (see that module's docstring), so it may import ``mujoco`` and open a GL context.
"""

from __future__ import annotations

import json
import pathlib
from typing import Any

import numpy as np

#: Shadow-map size [texels] in ``shadows="follow"`` mode (MuJoCo's default is 4096).
_SHADOW_TEXELS = 2048

_EYE = np.eye(3).ravel()


_ARROW_RGBA = np.array([0.85, 0.1, 0.1, 1.0], dtype=np.float32)


def _floor_grid(model, data, qpos, spacing=0.5, margin=4.0, width=0.012):
    """Scene geoms of a floor at z = 0 around the motion, for a model without a plane geom
    (e.g. the bare biped): a light slab with grid lines every ``spacing`` m, so that motion is
    visible from a tracking camera. Few geoms on purpose (each costs ~0.4 ms a frame with a
    software renderer). Returns ``[(mjtGeom, size (3,), pos (3,), rgba (4,) float32), ...]``."""
    import mujoco

    if np.any(model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE) or model.nbody < 2:
        return []
    xy = []
    for q in qpos:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        xy += [data.xpos[1:, :2].min(axis=0), data.xpos[1:, :2].max(axis=0)]
    lo = np.floor((np.min(xy, axis=0) - margin) / spacing) * spacing
    hi = np.ceil((np.max(xy, axis=0) + margin) / spacing) * spacing
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    box = mujoco.mjtGeom.mjGEOM_BOX
    slab = np.array([0.8, 0.82, 0.85, 1.0], dtype=np.float32)
    line = np.array([0.55, 0.58, 0.62, 1.0], dtype=np.float32)
    out = [(box, np.array([half[0], half[1], 0.001]), np.array([mid[0], mid[1], -0.002]), slab)]
    for x in np.arange(lo[0], hi[0] + spacing / 2, spacing):
        out.append((box, np.array([width / 2, half[1], 0.0005]), np.array([x, mid[1], -0.0005]), line))
    for y in np.arange(lo[1], hi[1] + spacing / 2, spacing):
        out.append((box, np.array([half[0], width / 2, 0.0005]), np.array([mid[0], y, -0.0005]), line))
    return out


def _directional_lights(model) -> np.ndarray:
    """Indices of the model's directional lights that cast shadows (MuJoCo 3.2: light_directional;
    later: light_type)."""
    import mujoco

    if hasattr(model, "light_type"):
        directional = np.asarray(model.light_type) == int(mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
    else:  # pragma: no cover - MuJoCo < 3.3
        directional = np.asarray(model.light_directional).astype(bool)
    return np.flatnonzero(directional & np.asarray(model.light_castshadow).astype(bool))


class _Caption:
    """Draws a frame's caption (:func:`biped.viz.timeline.overlay_text`) with Pillow: simulated
    time and playback speed top left, the title top right, events bottom left, each on a dark
    translucent box so it reads on any background."""

    def __init__(self, width: int, height: int, font_file: str | None):
        from PIL import ImageFont

        size = max(10, round(height / 26))
        self.small = max(9, round(size * 0.8))
        self.font: Any
        self.font_small: Any
        if font_file:
            self.font = ImageFont.truetype(font_file, size)
            self.font_small = ImageFont.truetype(font_file, self.small)
        else:  # pragma: no cover - matplotlib always ships DejaVu Sans
            self.font = ImageFont.load_default()
            self.font_small = self.font
        self.pad = max(3, size // 4)
        self.w, self.h, self.size = width, height, size

    def _block(self, draw, xy, lines, font, anchor_right=False, anchor_bottom=False):
        """The box ``(x0, y0, x1, y1)`` of a block of text lines at ``xy`` and where each line
        goes, or None for no lines."""
        lines = [ln for ln in lines if ln]
        if not lines:
            return None
        boxes = [draw.textbbox((0, 0), ln, font=font) for ln in lines]
        lh = max(b[3] - b[1] for b in boxes) + self.pad
        bw = max(b[2] - b[0] for b in boxes) + 2 * self.pad
        bh = lh * len(lines) + self.pad
        x, y = xy
        if anchor_right:
            x -= bw
        if anchor_bottom:
            y -= bh
        places = [((x + self.pad, y + self.pad // 2 + i * lh), ln) for i, ln in enumerate(lines)]
        return (x, y, x + bw, y + bh), places, font

    def draw(self, frame: np.ndarray, caption: dict, title: str) -> np.ndarray:
        """The frame with its caption: each block on a dark translucent box (the frame's pixels
        there times 105/255, what black at alpha 150 gives), white text on top. Only the boxes'
        pixels are touched (compositing the whole frame cost ~5 ms a frame)."""
        from PIL import Image, ImageDraw

        img = Image.fromarray(frame)
        draw = ImageDraw.Draw(img)
        m = self.pad * 2
        blocks = [
            self._block(draw, (m, m), [caption["time"], caption["speed"]], self.font),
            self._block(draw, (self.w - m, m), [title], self.font_small, anchor_right=True)
            if title
            else None,
            self._block(draw, (m, self.h - m), caption["events"], self.font, anchor_bottom=True),
        ]
        out = np.array(frame, dtype=np.uint8, copy=True)
        for b in blocks:
            if b is not None:
                x0, y0, x1, y1 = (max(0, int(v)) for v in b[0])
                region = out[y0 : y1 + 1, x0 : x1 + 1]
                region[:] = (region.astype(np.uint16) * 105 // 255).astype(np.uint8)
        img = Image.fromarray(out)
        draw = ImageDraw.Draw(img)
        for b in blocks:
            if b is not None:
                for xy, text in b[1]:
                    draw.text(xy, text, font=b[2], fill=(255, 255, 255))
        return np.asarray(img)


def _preload() -> None:
    """Import what :func:`_render_job` needs (a child started ahead, waiting for its job)."""
    import imageio_ffmpeg  # noqa: F401
    import mujoco  # noqa: F401
    from PIL import Image, ImageDraw, ImageFont  # noqa: F401


def _render_job(workdir: pathlib.Path) -> int:
    """Child process: render ``workdir/job.json`` (started by :func:`render_video`); prints
    ``frame n`` on stdout after each frame."""
    import imageio_ffmpeg
    import mujoco

    cfg = json.loads((workdir / "job.json").read_text())
    model = mujoco.MjModel.from_binary_path(str(workdir / "model.mjb"))
    qpos = np.load(workdir / "qpos.npy")
    w, h = cfg["width"], cfg["height"]
    model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), w)
    model.vis.global_.offheight = max(int(model.vis.global_.offheight), h)
    lights = _directional_lights(model)
    if cfg["shadows"] == "follow" and lights.size:
        # a shadow box of shadow_radius around the light, which is moved above the camera target
        extent = float(model.stat.extent) if model.stat.extent > 0 else 1.0
        model.vis.map.shadowclip = min(float(model.vis.map.shadowclip), cfg["shadow_radius"] / extent)
        # the small box needs no 4096-texel map (2048 over 6 m: 3 mm a texel); with Mesa's
        # software renderer a 1280 x 720 frame takes 0.86 as long (benchmarks/video.py)
        model.vis.quality.shadowsize = min(int(model.vis.quality.shadowsize), _SHADOW_TEXELS)
    if cfg.get("msaa") is not None:
        model.vis.quality.offsamples = int(cfg["msaa"])
    data = mujoco.MjData(model)

    cam = mujoco.MjvCamera()
    if cfg["body_id"] >= 0:
        cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
        cam.trackbodyid = cfg["body_id"]
    else:
        cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        cam.lookat[:] = cfg["lookat"] if cfg.get("lookat") is not None else model.stat.center
    cam.distance, cam.azimuth, cam.elevation = cfg["distance"], cfg["azimuth"], cfg["elevation"]

    renderer = mujoco.Renderer(model, h, w)
    floor = _floor_grid(model, data, qpos)
    if model.nlight == 0:  # only the headlight: make it bright enough to see the floor
        model.vis.headlight.ambient[:] = 0.35
        model.vis.headlight.diffuse[:] = 0.65
    arrows = np.load(workdir / "arrows.npy") if (workdir / "arrows.npy").exists() else None
    captions = cfg.get("captions")
    caption = _Caption(w, h, cfg.get("font")) if captions else None
    writer = imageio_ffmpeg.write_frames(
        cfg["out"],
        (w, h),
        fps=cfg["fps"],
        codec="libx264",
        pix_fmt_out="yuv420p",
        quality=7,
        macro_block_size=2,
        ffmpeg_log_level="error",
        output_params=["-preset", "veryfast"],  # ~40 % less CPU than x264's default, smaller here
    )
    writer.send(None)
    try:
        for k, q in enumerate(qpos):
            data.qpos[:] = q
            data.qvel[:] = 0.0
            mujoco.mj_forward(model, data)
            if cfg["shadows"] == "follow" and lights.size:
                if cam.type == mujoco.mjtCamera.mjCAMERA_TRACKING:
                    target = data.subtree_com[cam.trackbodyid]
                else:
                    target = cam.lookat
                data.light_xpos[lights, :2] = np.asarray(target)[:2]
            renderer.update_scene(data, camera=cam)
            scn = renderer.scene
            if cfg["shadows"] == "off":
                scn.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
            if not cfg.get("reflection", True):
                scn.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
            for gtype, size, pos, rgba in floor[: scn.maxgeom - scn.ngeom]:
                mujoco.mjv_initGeom(scn.geoms[scn.ngeom], gtype, size, pos, _EYE, rgba)
                scn.ngeom += 1
            if arrows is not None and np.isfinite(arrows[k]).all() and scn.ngeom < scn.maxgeom:
                g = scn.geoms[scn.ngeom]  # the perturbation's arrow (a push, the tether)
                mujoco.mjv_initGeom(
                    g, mujoco.mjtGeom.mjGEOM_ARROW, np.zeros(3), np.zeros(3), _EYE, _ARROW_RGBA
                )
                mujoco.mjv_connector(g, mujoco.mjtGeom.mjGEOM_ARROW, 0.02, arrows[k, 0], arrows[k, 1])
                scn.ngeom += 1
            img = renderer.render()
            if caption is not None:
                img = caption.draw(img, captions[k], cfg["title"])
            writer.send(np.ascontiguousarray(img))
            print("frame", k + 1, flush=True)
    finally:
        writer.close()
        renderer.close()
    return 0
