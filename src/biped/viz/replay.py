"""A self-contained 3D replay of a motion, to open in any browser.

A replay is a function of (model, trajectory): :func:`~biped.viz.replay_mujoco.replay_from_mujoco` runs MuJoCo's forward
kinematics over the recorded ``qpos`` and keeps the world pose of every visible geom; then
:func:`write_replay` writes one HTML file that plays it in 3D with three.js (vendored next to this
module, MIT licence, inlined into the page: the page loads nothing from the network).

The page has play / pause, a time scrubber, a speed menu, camera orbit / zoom / pan (mouse drag,
wheel, right drag), a "follow" toggle that keeps the camera on the figure, a floor grid, the event
markers on the timeline (click one to jump to it) and an overlay with ``info``. Keys: space plays or
pauses, left / right step one frame, Home goes back to the start.

>>> import mujoco, numpy as np
>>> from biped import models
>>> from biped.viz import replay_from_mujoco, write_replay
>>> m = mujoco.MjModel.from_xml_path(str(models.path("wendlandt")))
>>> q = np.tile(m.key_qpos[0], (3, 1))
>>> r = replay_from_mujoco(m, [0.0, 0.01, 0.02], q, title="standing")
>>> write_replay(r, "/tmp/standing.html")            # doctest: +SKIP
"""

from __future__ import annotations

import base64
import html
import json
import math
import pathlib
import re
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from biped import files
from biped.errors import BipedError, ModelError, StateError, unknown_name
from biped.viz.replay_arrow import ARROW_RGBA, arrow_payload, check_arrow, viewer_text

__all__ = ["ARROW_RGBA", "GEOM_KINDS", "Replay", "ReplayGeom", "write_replay"]

#: Valid :attr:`ReplayGeom.kind` values and the number of entries of their ``size``.
GEOM_KINDS = {"box": 3, "sphere": 1, "capsule": 2, "cylinder": 2, "ellipsoid": 3, "plane": 2, "mesh": 3}

_HERE = pathlib.Path(__file__).resolve().parent
#: Vendored three.js files (release 0.185.0 from the npm registry, MIT licence in LICENSE.three).
_THREE_FILES = ("three.core.min.js", "three.module.min.js", "OrbitControls.js")


@dataclass(frozen=True)
class ReplayGeom:
    """One rigid shape of the replay, with MuJoCo's size semantics.

    ``size`` in m: box and ellipsoid half-sizes ``(hx, hy, hz)``; sphere ``(r,)``; capsule and
    cylinder ``(r, half_length)`` along the local z axis (a capsule's half length excludes its
    caps); plane ``(half_x, half_y)`` in the local xy plane, ``0`` meaning "large" (MuJoCo's
    infinite plane, drawn 20 m wide); mesh ``(hx, hy, hz)``, its bounding box's half sizes, and
    ``mesh`` the index of its vertices and faces in :attr:`Replay.meshes`. ``rgba`` in [0, 1],
    read as sRGB.
    """

    name: str
    kind: str
    size: tuple
    rgba: tuple = (0.7, 0.7, 0.7, 1.0)
    mesh: int = -1

    def __post_init__(self):
        if not isinstance(self.name, str):
            raise ModelError(f"ReplayGeom name must be a str, got {type(self.name).__name__}")
        if self.kind not in GEOM_KINDS:
            raise ModelError(
                f"ReplayGeom {self.name!r}: unknown kind {self.kind!r}; valid kinds: "
                f"{', '.join(map(repr, GEOM_KINDS))}"
            )
        size = tuple(float(s) for s in np.ravel(self.size))
        n = GEOM_KINDS[self.kind]
        if len(size) != n or not all(math.isfinite(s) and s >= 0 for s in size):
            raise ModelError(
                f"ReplayGeom {self.name!r}: a {self.kind} needs {n} finite non-negative size "
                f"entries (m), got {self.size!r}"
            )
        rgba = tuple(float(c) for c in np.ravel(self.rgba))
        if len(rgba) != 4 or not all(0.0 <= c <= 1.0 for c in rgba):
            raise ModelError(f"ReplayGeom {self.name!r}: rgba needs 4 entries in [0, 1], got {self.rgba!r}")
        if (self.kind == "mesh") != (isinstance(self.mesh, (int, np.integer)) and self.mesh >= 0):
            raise ModelError(
                f"ReplayGeom {self.name!r}: a mesh, and only a mesh, needs mesh >= 0; got {self.mesh!r}"
            )
        object.__setattr__(self, "size", size)
        object.__setattr__(self, "rgba", rgba)


@dataclass(frozen=True)
class Replay:
    """A motion to replay: the shapes and their world poses over time.

    Attributes:
        geoms: the G shapes.
        times: (T,) s, strictly increasing.
        pos: (T, G, 3) world position of each geom centre, m (world z up).
        quat: (T, G, 4) world orientation of each geom, unit quaternions (w, x, y, z).
        title: page title.
        info: name -> value pairs shown in an overlay (numbers, strings, booleans).
        markers: timeline events, each ``{"time_s": float, "label": str}``; kept in time order.
        follow: name of the geom the page's camera follows; ``None`` picks the largest solid
            (by volume), e.g. the trunk.
        arrow: ``None`` (no arrow, the page is as without this field), or (T, 2, 3) one arrow a
            frame, from its tail to its tip (world, m), all NaN where there is none: a push
            while it acts, a tether while it holds (:meth:`biped.sim.perturbations.base.
            Perturbation.arrows`). The page draws frame k's arrow from ``times[k]`` until the
            next frame, moving with the body between two frames that both have one.
        meshes: the mesh geoms' shapes, (vertices (V, 3) [m, geom frame], faces (F, 3)) each.
    """

    geoms: tuple
    times: np.ndarray
    pos: np.ndarray
    quat: np.ndarray
    title: str = "biped replay"
    info: dict = field(default_factory=dict)
    markers: tuple = ()
    follow: str | None = None
    arrow: np.ndarray | None = None
    meshes: tuple = ()

    def __post_init__(self):
        geoms = tuple(self.geoms)
        for g in geoms:
            if not isinstance(g, ReplayGeom):
                raise ModelError(f"Replay geoms must be ReplayGeom, got {type(g).__name__}")
        times = np.asarray(self.times, dtype=float)
        if times.ndim != 1 or times.size < 1:
            raise StateError(f"times must have shape (T,) with T >= 1, got shape {times.shape}")
        if not np.all(np.isfinite(times)):
            raise StateError("times contains NaN or infinite entries")
        if np.any(np.diff(times) <= 0):
            k = int(np.argmax(np.diff(times) <= 0))
            raise StateError(
                f"times must be strictly increasing; times[{k}] = {times[k]} s is followed by "
                f"{times[k + 1]} s"
            )
        T, G = times.size, len(geoms)
        pos = np.asarray(self.pos, dtype=float)
        quat = np.asarray(self.quat, dtype=float)
        if pos.shape != (T, G, 3):
            raise StateError(f"pos must have shape (T, G, 3) = {(T, G, 3)}, got {pos.shape}")
        if quat.shape != (T, G, 4):
            raise StateError(f"quat must have shape (T, G, 4) = {(T, G, 4)}, got {quat.shape}")
        if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(quat))):
            raise StateError("pos or quat contains NaN or infinite entries")
        norms = np.linalg.norm(quat, axis=-1)
        if G and np.max(np.abs(norms - 1.0)) > 1e-3:
            raise StateError(
                f"quat must hold unit quaternions (w, x, y, z); worst norm "
                f"{norms.flat[np.argmax(np.abs(norms - 1))]:.6g}"
            )
        if not isinstance(self.title, str):
            raise BipedError(f"title must be a str, got {type(self.title).__name__}")
        if not isinstance(self.info, Mapping):
            raise BipedError(f"info must be a mapping of name -> value, got {type(self.info).__name__}")
        object.__setattr__(self, "geoms", geoms)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "pos", pos)
        object.__setattr__(self, "quat", quat)
        object.__setattr__(self, "info", dict(self.info))
        object.__setattr__(self, "markers", _check_markers(self.markers))
        object.__setattr__(self, "arrow", check_arrow(self.arrow, T))
        object.__setattr__(self, "meshes", _check_meshes(self.meshes, geoms))
        names = [g.name for g in geoms]
        if self.follow is not None and self.follow not in names:
            raise ModelError(unknown_name("follow geom", self.follow, names))

    def follow_index(self) -> int:
        """Index of the geom the camera follows (:attr:`follow`, else the largest solid); -1 if
        there is none."""
        if self.follow is not None:
            return [g.name for g in self.geoms].index(self.follow)
        vols = [_volume(g) if g.kind != "plane" else -1.0 for g in self.geoms]
        return int(np.argmax(vols)) if vols and max(vols) >= 0 else -1


def _volume(g: ReplayGeom) -> float:
    """Volume of a geom, m^3 (used to choose the geom the camera follows)."""
    s = g.size
    if g.kind in ("box", "ellipsoid", "mesh"):  # a mesh: its bounding box
        return 8 * s[0] * s[1] * s[2] * (math.pi / 6 if g.kind == "ellipsoid" else 1.0)
    if g.kind == "sphere":
        return 4 / 3 * math.pi * s[0] ** 3
    if g.kind == "capsule":
        return math.pi * s[0] ** 2 * (2 * s[1] + 4 / 3 * s[0])
    if g.kind == "cylinder":
        return math.pi * s[0] ** 2 * 2 * s[1]
    return 0.0


def _check_meshes(meshes, geoms) -> tuple:
    """The meshes as (float32 (V, 3), uint32 (F, 3)) pairs, every face's and geom's index valid."""
    out = []
    for k, (v, f) in enumerate(meshes):
        v, f = np.asarray(v, dtype=np.float32), np.asarray(f)
        if v.ndim != 2 or v.shape[1] != 3 or not np.all(np.isfinite(v)):
            raise ModelError(f"mesh {k}: vertices must be a finite (V, 3) array, got shape {v.shape}")
        if f.ndim != 2 or f.shape[1] != 3 or (f.size and (f.min() < 0 or f.max() >= len(v))):
            raise ModelError(f"mesh {k}: faces must be (F, 3) indices into its {len(v)} vertices")
        out.append((v, f.astype(np.uint32)))
    for g in geoms:
        if g.kind == "mesh" and g.mesh >= len(out):
            raise ModelError(f"ReplayGeom {g.name!r}: mesh {g.mesh} not in the replay's {len(out)} meshes")
    return tuple(out)


def _check_markers(markers) -> tuple:
    """Validate timeline events: each a mapping with a finite ``time_s`` and a str ``label``;
    returned in time order (events given at the same time keep their order).

    A mapping without ``label`` (e.g. a ``{time_s, foot, part, kind}`` contact event of
    ``biped push``) gets one made of its other values, in order (``"left heel lift_off"``).
    """
    out = []
    for k, mk in enumerate(markers or ()):
        if not isinstance(mk, Mapping) or "time_s" not in mk:
            raise BipedError(
                f"marker {k} must be a mapping with keys 'time_s' (s) and 'label' (str), got {mk!r}"
            )
        t = mk["time_s"]
        try:
            t = float(t)
        except (TypeError, ValueError):
            t = math.nan
        if not math.isfinite(t):
            raise BipedError(f"marker {k}: time_s must be a finite number of seconds, got {mk['time_s']!r}")
        if "label" in mk:
            label = mk["label"]
            if not isinstance(label, str):
                raise BipedError(f"marker {k}: label must be a str, got {type(label).__name__}")
        else:
            label = " ".join(str(v) for key, v in mk.items() if key != "time_s")
        out.append({"time_s": t, "label": label})
    return tuple(sorted(out, key=lambda m: m["time_s"]))  # stable: equal times keep their order


# --------------------------------------------------------------------------------------------
# To HTML
# --------------------------------------------------------------------------------------------


def _b64_f32(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype="<f4").tobytes()).decode("ascii")


def _info_value(v) -> str:
    """Format one info value for the overlay: numbers to 4 significant digits."""
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return f"{float(v):.4g}"
    if isinstance(v, str):
        return v
    try:
        return json.dumps(v, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o))
    except (TypeError, ValueError):
        return str(v)


def _json_for_script(obj) -> str:
    """JSON that is safe inside an HTML ``<script>`` element: ASCII only, and no ``<``, ``>``
    or ``&`` characters (they become ``\\u003c`` ...), so no ``</script>`` or ``<!--`` can appear.
    """
    s = json.dumps(obj, ensure_ascii=True, allow_nan=False, separators=(",", ":"))
    return s.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def _script_text(name: str) -> str:
    """A vendored JS file, checked to be safe to inline in a ``<script>`` element."""
    text = (_HERE / name).read_text(encoding="utf-8")
    if re.search(r"</script|<!--|<script", text, re.IGNORECASE):  # pragma: no cover
        raise BipedError(f"vendored {name} contains a '<script' or '<!--' sequence; cannot inline it")
    return text


def replay_payload(replay: Replay) -> dict:
    """The JSON-able description of ``replay`` that the page reads (float32 arrays in base64;
    ``"arrow"`` only when the replay has one)."""
    payload = {
        "title": replay.title,
        "info": [[str(k), _info_value(v)] for k, v in replay.info.items()],
        "markers": [{"t": m["time_s"], "label": m["label"]} for m in replay.markers],
        "geoms": [
            {"name": g.name, "kind": g.kind, "size": list(g.size), "rgba": list(g.rgba), "mesh": g.mesh}
            for g in replay.geoms
        ],
        "T": int(replay.times.size),
        "G": len(replay.geoms),
        "follow": replay.follow_index(),
        # times relative to the first frame keep float32 precision; t0 is added back in the page
        "t0": float(replay.times[0]),
        "times": _b64_f32(replay.times - replay.times[0]),
        "pos": _b64_f32(replay.pos),
        "quat": _b64_f32(replay.quat),
    }
    if replay.meshes:
        payload["meshes"] = [
            {
                "verts": _b64_f32(v),
                "faces": base64.b64encode(np.ascontiguousarray(f, "<u4").tobytes()).decode(),
            }
            for v, f in replay.meshes
        ]
    if replay.arrow is not None:  # NaN (no arrow) survives float32 and base64
        payload["arrow"] = arrow_payload(replay.arrow, _b64_f32)
    return payload


def write_replay(replay: Replay, path) -> pathlib.Path:
    """Write ``replay`` as one self-contained HTML file and return its path.

    The page inlines three.js and the data (float32 base64 arrays, about 37 bytes per geom per
    frame); it loads nothing from the network. Every string of the replay (title, geom names,
    info, marker labels) is escaped: the title with HTML entities, the rest as JSON inside a
    ``<script type="application/json">`` element with ``<``, ``>``, ``&`` escaped, and the page
    puts them into the document with ``textContent`` only.

    Args:
        replay: what to draw.
        path: the ``.html`` file to write; missing parent folders are created.
    """
    if not isinstance(replay, Replay):
        raise BipedError(f"write_replay needs a Replay, got {type(replay).__name__}")
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    template = (_HERE / "replay.html").read_text(encoding="utf-8")
    parts = {
        "TITLE": html.escape(replay.title, quote=True),
        "DATA": _json_for_script(replay_payload(replay)),
        "THREE_CORE": _script_text("three.core.min.js"),
        "THREE_MODULE": _script_text("three.module.min.js"),
        "ORBIT_CONTROLS": _script_text("OrbitControls.js"),
        "VIEWER": viewer_text(_script_text, replay.arrow is not None),
    }
    # one pass, so nothing inserted is scanned for placeholders again
    page = re.sub(r"@@([A-Z_]+)@@", lambda m: parts[m.group(1)], template)
    files.write_text(path, page)  # atomic, never through a link
    return path.resolve()
