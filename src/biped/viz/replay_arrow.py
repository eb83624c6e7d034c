"""The perturbation's arrow in the 3D replay (:attr:`biped.viz.replay.Replay.arrow`): a push
while it acts, a tether while it holds, the arrows the video draws
(:meth:`biped.sim.perturbations.base.Perturbation.arrows`).

A replay without an arrow is written exactly as before arrows existed: its page has no ``"arrow"``
data and inlines ``replay_viewer.js`` unchanged (W's default ``biped push`` replay.html is byte
for byte the same). A replay with one gets ``replay_arrow.js`` appended to the viewer and hooked
in at two lines of it (:data:`_SPLICES`; a test renders the result in Chromium).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from biped.errors import BipedError, StateError

#: The arrow's colour (sRGB, drawn unlit), the video's (:mod:`biped.viz.video_render`).
ARROW_RGBA = (0.85, 0.1, 0.1, 1.0)

#: (line of replay_viewer.js, code, put the code "before" or "after" it)
_SPLICES = (
    ("  // ---- camera control ----\n", "  const showArrow = makeArrow(THREE, scene, D.arrow);\n", "before"),
    ("    currentIndex = w < 0.5 ? k : k1;\n", "    showArrow(k, k1, w);\n", "after"),
)


def check_arrow(arrow, T: int) -> np.ndarray | None:
    """Validate :attr:`Replay.arrow`: None, or (T, 2, 3) with each frame either all finite
    (tail, tip) or all NaN (no arrow)."""
    if arrow is None:
        return None
    a = np.asarray(arrow, dtype=float)
    if a.shape != (T, 2, 3):
        raise StateError(
            f"arrow must have shape (T, 2, 3) = {(T, 2, 3)} (tail, tip a frame, m), got {a.shape}"
        )
    flat = a.reshape(T, 6)
    none, some = np.all(np.isnan(flat), axis=1), np.all(np.isfinite(flat), axis=1)
    if not np.all(none | some):
        k = int(np.argmax(~(none | some)))
        raise StateError(
            f"arrow frame {k} must be all finite (tail, tip in m) or all NaN (no arrow), got {a[k].tolist()}"
        )
    return a


def arrow_edges(arrow: np.ndarray) -> np.ndarray:
    """Indices of the samples on both sides of each moment an arrow appears or goes (kept when a
    replay's frames are thinned, so even a push shorter than a frame shows, from its start)."""
    on = np.isfinite(arrow[:, 0, 0]).astype(int)
    edges = np.flatnonzero(np.diff(on)) + 1
    return np.concatenate([edges - 1, edges])


def arrow_payload(arrow: np.ndarray, b64: Callable[[np.ndarray], str]) -> dict:
    """The page's ``"arrow"`` data: its colour and the tails and tips, (T, 3) float32 each."""
    return {"rgba": list(ARROW_RGBA), "tail": b64(arrow[:, 0]), "tip": b64(arrow[:, 1])}


def viewer_text(script_text: Callable[[str], str], with_arrow: bool) -> str:
    """The viewer's JavaScript (``script_text(name)`` reads a checked file of this folder); with
    the arrow's code spliced in when ``with_arrow``."""
    text = script_text("replay_viewer.js")
    if not with_arrow:
        return text
    for anchor, code, where in _SPLICES:
        if text.count(anchor) != 1:  # pragma: no cover - guards edits of replay_viewer.js
            raise BipedError(f"replay_viewer.js lost the line {anchor.strip()!r} the arrow code hooks into")
        text = text.replace(anchor, code + anchor if where == "before" else anchor + code)
    return text + "\n" + script_text("replay_arrow.js")
