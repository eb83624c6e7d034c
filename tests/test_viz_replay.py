"""The 3D browser replay: geometry against MuJoCo and the MJCF, the page in headless Chromium.

Oracles: MuJoCo's body poses and the MJCF's ``fromto`` endpoints (not the geom poses the replay
records), the model's design statement that W's initial posture puts both soles flat 5 mm above
the floor, closed-form world bounding boxes of each shape compared with what three.js actually
built in the browser, and the pixels of a Chromium screenshot.
"""

from __future__ import annotations

import dataclasses
import html
import json
import re
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest
from _helpers import run_chromium

from biped.errors import BipedError, ModelError, StateError
from biped.viz import Replay, ReplayGeom, replay_from_mujoco, write_replay

EVIL = "</script><script>alert(1)</script>"
EVIL_IMG = "<img src=x onerror=\"document.title='PWNED'\">&amp;\u2028"


def _rot(q):
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, np.asarray(q, dtype=float))
    return R.reshape(3, 3)


def _moving_qpos(model, T=4):
    """(T, nq): W's initial posture; the root slides 0.3 m in -x and both knees bend further."""
    q = np.tile(model.key_qpos[0], (T, 1))
    q[:, 0] -= np.linspace(0.0, 0.3, T)
    for j in ("left_knee", "right_knee"):
        q[:, model.joint(j).qposadr[0]] += np.linspace(0.0, -0.4, T)
    return q


@pytest.fixture(scope="module")
def biped_replay(wendlandt_mj):
    q = _moving_qpos(wendlandt_mj)
    times = np.arange(q.shape[0]) / 60.0
    return replay_from_mujoco(
        wendlandt_mj,
        times,
        q,
        title="W's biped, keyframe 0",
        info={"recovered": True, "final_com_error_m": 0.00123, "frames": 4},
        markers=[
            {"time_s": 0.02, "label": "block hit"},
            {"time_s": 0.04, "foot": "left", "part": "heel", "kind": "lift_off"},
        ],
    )


# ------------------------------------------------------------------------------------------
# Geometry recorded from MuJoCo
# ------------------------------------------------------------------------------------------


def test_soles_flat_5mm_above_floor_in_initial_posture(biped_replay):
    """The model was built so that W's posture puts both soles flat, 0.005 m above the floor."""
    names = [g.name for g in biped_replay.geoms]
    bottoms = []
    for name in ("left_heel", "left_toe", "right_heel", "right_toe"):
        g = names.index(name)
        h = np.array(biped_replay.geoms[g].size)
        R = _rot(biped_replay.quat[0, g])
        corners = [
            biped_replay.pos[0, g] + R @ (h * np.array([sx, sy, sz]))
            for sx in (-1, 1)
            for sy in (-1, 1)
            for sz in (-1, 1)
        ]
        z = np.sort([c[2] for c in corners])
        bottoms.append(z[:4])
    bottoms = np.array(bottoms)
    np.testing.assert_allclose(bottoms, 0.005, atol=2e-5)


def test_capsules_lie_along_local_z_between_the_mjcf_fromto_points(
    wendlandt_mj, wendlandt_path, biped_replay
):
    """Capsule centre +- half_length * (local z) = the MJCF's ``fromto`` endpoints, mapped to the
    world with MuJoCo's *body* poses (so the check is independent of the geom poses recorded)."""
    m = wendlandt_mj
    d = mujoco.MjData(m)
    q = _moving_qpos(m)
    names = [g.name for g in biped_replay.geoms]
    checked = 0
    for body in ET.parse(wendlandt_path).getroot().iter("body"):
        for geom in body.findall("geom"):
            if "fromto" not in geom.attrib:
                continue
            a, b = np.array(geom.attrib["fromto"].split(), dtype=float).reshape(2, 3)
            g = names.index(geom.attrib["name"])
            bid = m.body(body.attrib["name"]).id
            for t in (0, q.shape[0] - 1):
                d.qpos[:] = q[t]
                mujoco.mj_kinematics(m, d)
                Rb = d.xmat[bid].reshape(3, 3)
                ends = {tuple(np.round(d.xpos[bid] + Rb @ p, 12)) for p in (a, b)}
                c, R = biped_replay.pos[t, g], _rot(biped_replay.quat[t, g])
                hl = biped_replay.geoms[g].size[1]
                mine = [c + R[:, 2] * hl, c - R[:, 2] * hl]
                ends = np.array(sorted(ends))
                mine = np.array(sorted(map(tuple, mine)))
                np.testing.assert_allclose(mine, ends, atol=1e-9)
                assert biped_replay.geoms[g].size[0] == pytest.approx(float(geom.attrib["size"]))
                checked += 1
    assert checked == 2 * 6  # two arms, two thighs, two shanks, at two frames


def test_replay_records_every_visible_geom_with_mjcf_names_and_colours(wendlandt_mj, biped_replay):
    m = wendlandt_mj
    assert [g.name for g in biped_replay.geoms] == [m.geom(i).name for i in range(m.ngeom)]
    for i, g in enumerate(biped_replay.geoms):
        assert g.rgba == pytest.approx(tuple(m.geom_rgba[i]))
    assert biped_replay.pos.shape == (4, m.ngeom, 3) and biped_replay.quat.shape == (4, m.ngeom, 4)
    # the trunk follows the root: 0.3 m in -x over the run
    trunk = [g.name for g in biped_replay.geoms].index("trunk")
    assert biped_replay.pos[-1, trunk, 0] - biped_replay.pos[0, trunk, 0] == pytest.approx(-0.3)
    # nothing in group 5: no geom left to draw, and the message says which groups exist
    with pytest.raises(ModelError, match=r"groups \[0\]"):
        replay_from_mujoco(m, [0.0], m.key_qpos[:1], geom_groups=[5])


def test_a_checkered_floor_gets_its_average_colour_and_invisible_geoms_are_left_out():
    """MuJoCo's builtin checker texture is half rgb1, half rgb2: the page's plane (no textures)
    gets the material's rgba times their mean; alpha-0 and group-3 geoms are not drawn."""
    m = mujoco.MjModel.from_xml_string("""
    <mujoco><asset>
      <texture name="grid" type="2d" builtin="checker" rgb1=".2 .4 .6" rgb2=".6 .8 1"
               width="64" height="64"/>
      <material name="floor" texture="grid" rgba="1 1 .5 1"/></asset>
      <worldbody><geom name="floor" type="plane" size="3 2 .1" material="floor"/>
        <geom name="ghost" type="sphere" size=".1" rgba="1 0 0 0"/>
        <geom name="hidden" type="sphere" size=".1" group="3"/>
        <body><freejoint/><geom name="ball" type="ellipsoid" size=".1 .2 .3"/></body>
      </worldbody></mujoco>""")
    r = replay_from_mujoco(m, [0.0], m.qpos0[None])
    assert [g.name for g in r.geoms] == ["floor", "ball"]
    floor = r.geoms[0]
    assert floor.kind == "plane" and floor.size == (3.0, 2.0)
    np.testing.assert_allclose(floor.rgba, [0.4, 0.6, 0.4, 1.0], atol=2 / 255)
    assert r.geoms[1].kind == "ellipsoid" and r.geoms[1].size == pytest.approx((0.1, 0.2, 0.3))


def test_a_500_hz_trajectory_becomes_a_100_frames_per_second_replay(wendlandt_mj):
    m = wendlandt_mj
    times = np.arange(1501) / 500.0 + 0.25  # 3 s at the control rate
    q = np.tile(m.key_qpos[0], (times.size, 1))
    q[:, 0] = times  # the root moves 1 m/s in x
    r = replay_from_mujoco(m, times, q)
    np.testing.assert_allclose(r.times, 0.25 + np.arange(301) / 100.0, atol=1e-12)
    trunk = [g.name for g in r.geoms].index("trunk")
    np.testing.assert_allclose(r.pos[:, trunk, 0] - r.times, r.pos[0, trunk, 0] - 0.25, atol=1e-12)
    assert replay_from_mujoco(m, times, q, max_rate_hz=None).times.size == 1501


def test_bad_input_is_rejected_with_a_clear_message(wendlandt_mj):
    m = wendlandt_mj
    q = np.tile(m.key_qpos[0], (3, 1))
    with pytest.raises(StateError, match=r"\(T, nq\) = \(3, 19\)"):
        replay_from_mujoco(m, [0, 1, 2], q[:, :5])
    bad = q.copy()
    bad[1, 4] = np.nan
    with pytest.raises(StateError, match="frame 1, coordinate 4"):
        replay_from_mujoco(m, [0, 1, 2], bad)
    with pytest.raises(StateError, match="strictly increasing"):
        replay_from_mujoco(m, [0, 1, 1], q)
    with pytest.raises(ModelError, match="valid kinds: 'box'"):
        ReplayGeom("x", "cone", (1, 1))
    with pytest.raises(ModelError, match="capsule needs 2"):
        ReplayGeom("x", "capsule", (1, 1, 1))
    with pytest.raises(ModelError, match="valid follow geoms: .*'trunk'"):
        replay_from_mujoco(m, [0, 1, 2], q, follow="torso")
    with pytest.raises(BipedError, match="marker 0: time_s must be a finite"):
        replay_from_mujoco(m, [0, 1, 2], q, markers=[{"time_s": float("nan"), "label": "x"}])
    with pytest.raises(StateError, match="unit quaternions"):
        Replay((ReplayGeom("a", "sphere", (1,)),), [0.0], np.zeros((1, 1, 3)), np.ones((1, 1, 4)))


def test_three_s_at_100_hz_of_25_geoms_fits_in_a_few_mb(tmp_path):
    """Issue 3/5 size budget: 300 frames x 25 geoms stays well under 3 MB (three.js included)."""
    T, G = 300, 25
    rng = np.random.default_rng(0)
    quat = rng.normal(size=(T, G, 4))
    quat /= np.linalg.norm(quat, axis=-1, keepdims=True)
    geoms = tuple(ReplayGeom(f"g{i}", "box", (0.1, 0.1, 0.1)) for i in range(G))
    r = Replay(geoms, np.arange(T) / 100.0, rng.normal(size=(T, G, 3)), quat)
    size = write_replay(r, tmp_path / "big.html").stat().st_size
    assert size < 2.0e6, f"{size / 1e6:.2f} MB"


# ------------------------------------------------------------------------------------------
# The HTML page: escaping and no network, read as text
# ------------------------------------------------------------------------------------------


def _evil_replay(biped_replay) -> Replay:
    """The biped plus one shape of each kind, with hostile strings in every embedded name."""
    T = biped_replay.times.size
    extra = (
        ReplayGeom(EVIL, "ellipsoid", (0.05, 0.1, 0.15), (0.6, 0.6, 0.6, 1)),
        ReplayGeom(EVIL_IMG, "cylinder", (0.05, 0.12), (0.6, 0.6, 0.6, 1)),
        ReplayGeom("sphere", "sphere", (0.07,), (0.6, 0.6, 0.6, 1)),
        ReplayGeom("plate", "plane", (0.2, 0.1), (0.6, 0.6, 0.6, 0.5)),
    )
    rng = np.random.default_rng(1)
    q = rng.normal(size=(T, len(extra), 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    p = np.array([0.0, 1.2, 0.5]) + 0.3 * rng.normal(size=(T, len(extra), 3))
    return dataclasses.replace(
        biped_replay,
        geoms=biped_replay.geoms + extra,
        pos=np.concatenate([biped_replay.pos, p], axis=1),
        quat=np.concatenate([biped_replay.quat, q], axis=1),
        title=EVIL,
        info={EVIL: EVIL_IMG, "ok": 1.5},
        markers=({"time_s": 0.03, "label": EVIL},),
        follow="trunk",
    )


def _data_element(page: str) -> dict:
    m = re.search(r'<script type="application/json" id="replay-data">(.*?)</script>', page, re.DOTALL)
    return json.loads(m.group(1))


def test_page_escapes_every_embedded_string(biped_replay, tmp_path):
    page = write_replay(_evil_replay(biped_replay), tmp_path / "evil.html").read_text()
    assert EVIL not in page and "<img" not in page
    assert len(re.findall(r"<script\b", page, re.IGNORECASE)) == 5  # the template's own, nothing more
    data = _data_element(page)  # the JSON decodes back to the exact strings
    assert data["title"] == EVIL and data["info"][0] == [EVIL, EVIL_IMG]
    assert data["markers"][0]["label"] == EVIL
    assert [g["name"] for g in data["geoms"]][-4:-2] == [EVIL, EVIL_IMG]
    title = re.search(r"<title>(.*?)</title>", page, re.DOTALL).group(1)
    assert html.unescape(title) == EVIL


def test_page_loads_nothing_from_the_network(biped_replay, tmp_path):
    page = write_replay(biped_replay, tmp_path / "r.html").read_text()
    # a CSP that forbids every fetch: any attempt by inlined code is blocked by the browser
    assert re.search(r"http-equiv=\"Content-Security-Policy\" content=\"default-src 'none';", page)
    csp = re.search(r'Content-Security-Policy" content="([^"]*)"', page).group(1)
    assert "http" not in csp and "*" not in csp
    # outside the inlined, vendored three.js, the page names no http(s) URL at all
    ours = re.sub(
        r'<script type="text/plain" id="(three-core|three-module|orbit-controls)">'
        r".*?</script>",
        "",
        page,
        flags=re.DOTALL,
    )
    assert not re.search(r"https?://", ours)
    assert not re.search(r"<(link|iframe|img|object|embed)\b|\bsrc\s*=|@import|\burl\(", ours, re.IGNORECASE)


# ------------------------------------------------------------------------------------------
# In headless Chromium
# ------------------------------------------------------------------------------------------


def _world_aabb(geom: ReplayGeom, pos, quat):
    """Closed-form world bounding box (min, max) of a shape with MuJoCo's size semantics."""
    R, s = _rot(quat), np.array(geom.size)
    A = np.abs(R)
    if geom.kind == "box":
        h = A @ s
    elif geom.kind == "sphere":
        h = np.full(3, s[0])
    elif geom.kind == "capsule":
        h = A[:, 2] * s[1] + s[0]
    elif geom.kind == "cylinder":
        h = A[:, 2] * s[1] + s[0] * np.sqrt(np.clip(1 - R[:, 2] ** 2, 0, 1))
    elif geom.kind == "ellipsoid":
        h = np.sqrt((R**2) @ (s**2))
    else:  # plane: a rectangle in the local xy plane
        h = A[:, :2] @ s
    return pos - h, pos + h


@pytest.mark.browser
def test_chromium_builds_each_shape_where_mujoco_puts_it(biped_replay, tmp_path):
    """Halfway between frames 1 and 2, three.js's world bounding box of every mesh equals the
    closed-form box of the MuJoCo shape at the pose interpolated by scipy (positions linearly,
    orientations by Slerp); tolerance: the tessellation of round shapes. The hostile strings
    show as text; the page requested nothing from the network and the CSP blocked nothing."""
    from scipy.spatial.transform import Rotation, Slerp

    rep = _evil_replay(biped_replay)
    f = write_replay(rep, tmp_path / "evil.html")
    t = float(rep.times[1] + rep.times[2]) / 2
    dom = run_chromium(tmp_path, "--dump-dom", url=f"{f.as_uri()}#t={t!r}&probe=1")
    assert 'data-ready="1"' in dom, dom[-3000:]
    assert "<img" not in dom and "&lt;img src=x" in dom  # the name shows as text only
    assert len(re.findall(r"<script\b", dom, re.IGNORECASE)) == 5
    probe = re.search(r'<pre id="probe" style="[^"]*">(.*?)</pre>', dom, re.DOTALL)[1]
    probe = json.loads(html.unescape(probe))
    assert probe["h1"] == EVIL and probe["title"] == EVIL
    assert probe["violations"] == []
    assert all(u.startswith(("blob:", "file:")) for u in probe["resources"]), probe["resources"]
    assert [b["name"] for b in probe["boxes"]] == [g.name for g in rep.geoms]
    for g, (geom, box) in enumerate(zip(rep.geoms, probe["boxes"], strict=True)):
        pos = (rep.pos[1, g] + rep.pos[2, g]) / 2
        q12 = rep.quat[1:3, g][:, [1, 2, 3, 0]]  # scipy wants (x, y, z, w)
        quat = Slerp([0.0, 1.0], Rotation.from_quat(q12))(0.5).as_quat()[[3, 0, 1, 2]]
        lo, hi = _world_aabb(geom, pos, quat)
        round_ = geom.kind in ("sphere", "capsule", "cylinder", "ellipsoid")
        tol = 2e-4 + (0.03 * max(geom.size) if round_ else 0.0)
        np.testing.assert_allclose(box["min"], lo, atol=tol, err_msg=geom.name)
        np.testing.assert_allclose(box["max"], hi, atol=tol, err_msg=geom.name)


@pytest.mark.browser
def test_chromium_screenshot_shows_the_biped(biped_replay, tmp_path):
    """The screenshot shows the red trunk above the blue legs (colours of the MJCF)."""
    from PIL import Image

    f = write_replay(biped_replay, tmp_path / "replay.html")
    png = tmp_path / "shot.png"
    run_chromium(tmp_path, f"--screenshot={png}", url=f.as_uri())
    img = np.asarray(Image.open(png).convert("RGB"), dtype=float)
    assert img.shape == (600, 800, 3)
    img = img[:530]  # above the control bar (its blue ticks and checkboxes)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    trunk = (r > 80) & (r > 1.6 * g) & (r > 1.6 * b)  # rgba 0.8 0.35 0.3, shaded
    legs = (b > 60) & (b > 1.25 * r) & (b > g)  # rgba 0.35 0.45 0.65, shaded
    assert trunk.sum() > 1500, f"only {trunk.sum()} trunk-coloured pixels: is the biped drawn?"
    assert legs.sum() > 1000, f"only {legs.sum()} leg-coloured pixels"
    ys_trunk, ys_legs = np.nonzero(trunk)[0], np.nonzero(legs)[0]
    assert ys_trunk.mean() < ys_legs.mean() - 50, "the trunk should be drawn above the legs"


@pytest.mark.browser
def test_chromium_lists_events_in_time_order(biped_replay, tmp_path):
    """Events given out of order (as a push run lists them: block hit, then each foot's events)
    appear in the page's event list sorted by time, read back from the DOM Chromium built."""
    given = [
        {"time_s": 0.05, "label": "block hits the body"},
        {"time_s": 0.048, "label": "right toe lift off"},
        {"time_s": 0.01, "label": "left heel lift off"},
        {"time_s": 0.05, "label": "left heel touch down"},
    ]  # same time: given order kept
    rep = dataclasses.replace(biped_replay, markers=tuple(given))
    f = write_replay(rep, tmp_path / "events.html")
    dom = run_chromium(tmp_path, "--dump-dom", url=f"{f.as_uri()}#probe=1")
    assert 'data-ready="1"' in dom, dom[-3000:]
    box = dom[dom.index('id="events"') :]
    box = box[: box.index("</div></div>") + 6]  # the list: rows of plain text divs
    rows = [html.unescape(r) for r in re.findall(r"<div[^>]*>([^<]*)</div>", box)]
    assert rows == [
        "0.010 s  left heel lift off",
        "0.048 s  right toe lift off",
        "0.050 s  block hits the body",
        "0.050 s  left heel touch down",
    ], rows
