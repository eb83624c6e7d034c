"""The perturbation's arrow in the 3D replay (a push while it acts, a tether while it holds):
the page carries the arrows the video draws, shows them only while the scenario's force acts
(its keys, not the code's rows, say when), the pixels of the arrow's colour appear in Chromium
then and only then, and a replay without an arrow inlines the viewer unchanged (W's block)."""

from __future__ import annotations

import base64
import dataclasses
import html
import json
import re

import numpy as np
import pytest
from _helpers import run_chromium

from biped.errors import StateError
from biped.sim import Scenario, build_scene
from biped.sim.perturbations import of
from biped.sim.push import controller_policy, run_closed_loop
from biped.viz import Replay, replay_from_mujoco, write_replay
from biped.viz.replay import _HERE, ARROW_RGBA

START_S, PULSE_S = 0.1, 0.15


def _page_data(path) -> dict:
    page = path.read_text(encoding="utf-8")
    m = re.search(r'<script type="application/json" id="replay-data">(.*?)</script>', page, re.DOTALL)
    return json.loads(m[1])


def _f32(b64: str) -> np.ndarray:
    return np.frombuffer(base64.b64decode(b64), dtype="<f4").astype(float)


@pytest.fixture(scope="module")
def force_push(tmp_path_factory):
    """A 0.4 s force pulse run (60 N backward at the pelvis from 0.1 s for 0.15 s) and the
    replay.html `biped push` writes of it."""
    from biped.outputs.push import write_outputs

    sc = Scenario(physics="fast", perturbation="force", force_start_s=START_S, force_duration_s=PULSE_S,
                  duration_s=0.4)  # fmt: skip
    scene = build_scene(sc)
    result = run_closed_loop(sc, scene, controller_policy(sc, scene))
    out = tmp_path_factory.mktemp("force")
    write_outputs(result, out, figures=False, video=False, scene=scene, log=lambda m: None)
    return sc, scene, result, out / "replay.html"


def test_push_replay_carries_the_video_arrows_while_the_force_acts(force_push):
    sc, scene, result, page = force_push
    D = _page_data(page)
    times = D["t0"] + _f32(D["times"])
    tail = _f32(D["arrow"]["tail"]).reshape(-1, 3)
    tip = _f32(D["arrow"]["tip"]).reshape(-1, 3)
    assert D["arrow"]["rgba"] == list(ARROW_RGBA)
    # the frames with an arrow are those at which the scenario's pulse acts, the first at its start
    on = np.isfinite(tail[:, 0])
    assert np.array_equal(on, (times >= START_S - 1e-6) & (times < START_S + PULSE_S - 1e-6))
    assert np.isnan(tip[~on]).all()
    assert times[on][0] == pytest.approx(START_S, abs=1e-6)
    # each equals the arrow the video draws at that sample (float32 in the page)
    want = of(sc).arrows(scene, result)
    k = np.searchsorted(result.times, times - 1e-7)
    assert np.allclose(result.times[k], times, atol=1e-5)
    np.testing.assert_allclose(tail[on], want[k[on], 0], atol=1e-5)
    np.testing.assert_allclose(tip[on], want[k[on], 1], atol=1e-5)
    # along the force (-x), 0.4 m long at the peak of the rectangular pulse
    d = tip[on] - tail[on]
    np.testing.assert_allclose(d, np.tile([-0.4, 0.0, 0.0], (on.sum(), 1)), atol=1e-5)


@pytest.mark.browser
def test_chromium_draws_the_arrow_while_the_force_acts_and_not_after(force_push, tmp_path):
    """Pixels of the arrow's colour (sRGB 217 26 26, drawn unlit) in a screenshot mid-pulse,
    none after the pulse (the biped's own red trunk is shaded, never that colour)."""
    from PIL import Image

    page = force_push[3]
    rgb = np.round(255 * np.array(ARROW_RGBA[:3]))
    counts = {}
    for t in (START_S + PULSE_S / 2, START_S + PULSE_S + 0.1):
        png = tmp_path / f"shot{t:.3f}.png"
        run_chromium(tmp_path, f"--screenshot={png}", url=f"{page.as_uri()}#t={t!r}")
        img = np.asarray(Image.open(png).convert("RGB"), dtype=float)[:530]  # above the control bar
        counts[t] = int(np.all(np.abs(img - rgb) <= 8, axis=-1).sum())
    during, after = counts.values()
    assert during > 60, counts
    assert after == 0, counts
    # and the page with an arrow still loads nothing from the network (the probe of the viewer)
    dom = run_chromium(tmp_path, "--dump-dom", url=f"{page.as_uri()}#t={START_S + 0.05!r}&probe=1")
    assert 'data-ready="1"' in dom, dom[-3000:]
    probe = json.loads(
        html.unescape(re.search(r'<pre id="probe" style="[^"]*">(.*?)</pre>', dom, re.DOTALL)[1])
    )
    assert probe["violations"] == []
    assert all(u.startswith(("blob:", "file:")) for u in probe["resources"]), probe["resources"]


def test_a_replay_without_arrow_inlines_the_viewer_unchanged(force_push, tmp_path):
    """W's block has no arrow: the page's data has no arrow and its script is replay_viewer.js
    as it is (so W's default replay.html is the one of before arrows)."""
    sc, scene, result, page = force_push
    assert of(Scenario()).arrows(scene, result) is None  # the block
    rep = replay_from_mujoco(scene.model, result.times[:50], result.qpos[:50])
    f = write_replay(rep, tmp_path / "plain.html")
    assert "arrow" not in _page_data(f)
    text = f.read_text(encoding="utf-8")
    assert (
        '<script type="module">' + (_HERE / "replay_viewer.js").read_text(encoding="utf-8") + "</script>"
        in text
    )
    assert "makeArrow" not in text and "makeArrow" in page.read_text(encoding="utf-8")


def test_thinning_keeps_a_pulse_shorter_than_a_frame(force_push):
    """A 4 ms arrow in a 500 Hz trajectory thinned to 100 frames/s still shows, from its start."""
    _, scene, result, _ = force_push
    n = 100
    t = result.times[:n]
    arrow = np.full((n, 2, 3), np.nan)
    arrow[23:25] = [[0.0, 0.0, 1.0], [0.1, 0.0, 1.0]]
    rep = replay_from_mujoco(scene.model, t, result.qpos[:n], arrow=arrow)
    on = np.isfinite(rep.arrow[:, 0, 0])
    assert rep.times.size < n / 3
    assert rep.times[on][0] == t[23] and rep.times[on][-1] == t[24]
    assert not on[np.searchsorted(rep.times, t[25])]


@pytest.mark.parametrize(
    ("arrow", "words"),
    [
        (np.zeros((3, 3)), "arrow must have shape (T, 2, 3)"),
        (np.full((4, 2, 3), np.inf), "arrow frame 0 must be all finite"),
        (np.where(np.arange(6).reshape(2, 3) == 0, np.nan, 0.0)[None].repeat(4, 0), "or all NaN"),
    ],
)
def test_bad_arrows_are_refused(force_push, arrow, words):
    _, scene, result, _ = force_push
    rep = replay_from_mujoco(scene.model, result.times[:4], result.qpos[:4], max_rate_hz=None)
    with pytest.raises(StateError, match=re.escape(words)):
        dataclasses.replace(rep, arrow=arrow)
    assert isinstance(dataclasses.replace(rep, arrow=np.full((4, 2, 3), np.nan)), Replay)
