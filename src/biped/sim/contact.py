"""Contacts of the push scene: restitution calibration, foot events, block hit and fall detection.

Restitution
-----------
W's simulator (*Impulse*, Mirtich 1996) resolves contacts with impulses and a coefficient of
restitution e = 0.2. MuJoCo has no restitution coefficient: a contact is a soft constraint whose
reference acceleration is ``a_ref = -b v - k r`` (penetration r, normal velocity v) with, for a
positive ``solref = (timeconst, dampratio)``, ``b = 2 / (d_max timeconst)`` and
``k = 1 / (d_max^2 timeconst^2 dampratio^2)`` (MuJoCo documentation, "Solver parameters").
These are accelerations, so the contact behaves as a *mass-normalized* linear spring-damper: the
bounce does not depend on the masses in contact. We make the impedance constant
(``solimp = (0.95, 0.95, ...)``, :data:`CONTACT_SOLIMP`) so that the spring-damper is linear and the
bounce does not depend on the impact speed either. What is left is a function e(dampratio) for a
given ``timeconst / timestep``; :func:`dampratio_for_restitution` finds the dampratio that gives the
wanted e by bisection on a measured drop of a sphere (MuJoCo itself, no formula), averaged over
the phase of the first contacting step. The unilateral constraint releases the body as soon as its
force reaches zero, so e(dampratio) lies above the closed form ``exp(-pi z / sqrt(1 - z^2))`` of
a two-sided spring-damper: e = 0.2 needs dampratio about 0.65, not 0.46.

``tests/test_sim_contact.py`` then measures e on the real scene's pairs (a 73 kg rigid biped
dropped flat on its soles; the 1.8 kg block thrown at the fixed trunk), which the calibration never
saw.

Events
------
:class:`ContactMonitor` classifies every MuJoCo contact by the roles of its two geoms (sole part,
other biped geom, block, floor) and reports per-foot, per-part ``lift_off`` / ``touch_down``
transitions, the first block-biped contact and falls (a biped geom other than a sole on the floor).
A foot that collides as one box (``physics = "fast"``, :func:`biped.sim.scene.scene_spec`) has
its contacts told apart by the side of the heel/toe seam they lie on.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numba import njit, types

from biped._numba_cache import compile_once

#: Constant impedance (d0 = d_width): a linear contact spring-damper; see the module docstring.
CONTACT_SOLIMP = (0.95, 0.95, 0.001, 0.5, 2.0)

#: (foot, part) of each sole geom of the shipped biped, in the order of :attr:`ContactMonitor.flags`.
SOLE_GEOMS = (("left", "heel"), ("left", "toe"), ("right", "heel"), ("right", "toe"))


# ---------------------------------------------------------------------------------------------
# restitution calibration


def _drop_rig(timestep: float, timeconst: float):
    """A 1 kg sphere of radius 5 cm over a plane, no gravity (the calibration rig)."""
    spec = mujoco.MjSpec()
    spec.modelname = "restitution_rig"
    spec.option.timestep = timestep
    spec.option.gravity = [0.0, 0.0, 0.0]
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    kw = {"solref": [timeconst, 1.0], "solimp": list(CONTACT_SOLIMP)}
    spec.worldbody.add_geom(name="plane", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1, 1, 0.1], **kw)
    body = spec.worldbody.add_body(name="ball", pos=[0, 0, 0.05])
    body.add_freejoint()
    body.add_geom(name="ball", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.05, 0, 0], mass=1.0, **kw)
    model = spec.compile()
    return model, mujoco.MjData(model)


def measure_drop_restitution(model, data, dampratio: float, phase: float, speed: float = 1.0):
    """e = v_after / v_before of the rig's sphere hitting the plane at ``speed`` [m/s], the first
    contacting step reached at fraction ``phase`` in [0, 1) of a step."""
    timeconst = model.geom_solref[0, 0]
    model.geom_solref[:, :] = (timeconst, dampratio)
    mujoco.mj_resetData(model, data)
    data.qpos[2] = 0.05 + (1.0 - phase) * speed * model.opt.timestep
    data.qvel[2] = -speed
    touched = False
    for _ in range(100000):
        mujoco.mj_step(model, data)
        if data.ncon:
            touched = True
        elif touched:
            return data.qvel[2] / speed
    raise RuntimeError("restitution rig: the sphere never left the plane")  # pragma: no cover


@functools.lru_cache(maxsize=32)
def dampratio_for_restitution(
    restitution: float, timeconst: float, timestep: float, phases: int = 8
) -> float:
    """MuJoCo ``solref`` dampratio giving coefficient of restitution ``restitution`` (bisection
    on :func:`measure_drop_restitution`, averaged over ``phases`` contact phases).

    ``restitution`` in [0, 0.8]; ``timeconst`` [s] >= 2 ``timestep`` [s]. e = 0 returns the
    smallest dampratio that gives no bounce within 1e-3.
    """
    model, data = _drop_rig(timestep, timeconst)
    ph = (np.arange(phases) + 0.5) / phases

    def e_of(z):
        return float(np.mean([measure_drop_restitution(model, data, z, p) for p in ph]))

    lo, hi = 0.05, 20.0  # e decreases with the damping ratio
    if restitution >= e_of(lo):
        raise ValueError(
            f"restitution {restitution} is above what timeconst {timeconst} s at "
            f"timestep {timestep} s can give ({e_of(lo):.3f})"
        )
    target = max(restitution, 1e-3)
    for _ in range(40):
        mid = math.sqrt(lo * hi)
        if e_of(mid) > target:
            lo = mid
        else:
            hi = mid
        if hi / lo < 1 + 1e-4:
            break
    return math.sqrt(lo * hi)


def contact_solref(restitution: float, timeconst: float, timestep: float) -> tuple[float, float]:
    """``solref = (timeconst, dampratio)`` for the wanted restitution (see the module docstring)."""
    return (
        float(timeconst),
        dampratio_for_restitution(float(restitution), float(timeconst), float(timestep)),
    )


# ---------------------------------------------------------------------------------------------
# events


@dataclass(frozen=True)
class ContactEvent:
    """A foot part leaving (``lift_off``) or reaching (``touch_down``) the floor at ``time_s``."""

    time_s: float
    foot: str  # "left" | "right"
    part: str  # "heel" | "toe"
    kind: str  # "lift_off" | "touch_down"

    def to_dict(self) -> dict:
        return {"time_s": self.time_s, "foot": self.foot, "part": self.part, "kind": self.kind}


def heel_timeline(events, block_contact_time_s: float | None) -> dict[str, float | None]:
    """W's event timeline (section 4) from a run's foot events [s]: ``"block hits the body"``,
    then per foot ``"<foot> heel rises"`` (its heel's first lift-off after the hit) and
    ``"<foot> heel back"`` (the touch-down ending the heel's longest lift-off after the hit: the
    stance on the toes). Brief heel bounces of a few ms before or after it are contact chatter,
    not events W reports. None where it did not happen (no hit, a heel that never rose or never
    came back within the run)."""
    out: dict[str, float | None] = {"block hits the body": block_contact_time_s}
    for foot in ("left", "right"):
        out[f"{foot} heel rises"] = out[f"{foot} heel back"] = None
        if block_contact_time_s is None:
            continue
        heel = [e for e in events if e.foot == foot and e.part == "heel" and e.time_s >= block_contact_time_s]
        longest = -1.0
        for i, e in enumerate(heel):
            if e.kind != "lift_off":
                continue
            if out[f"{foot} heel rises"] is None:
                out[f"{foot} heel rises"] = e.time_s
            down = next((x.time_s for x in heel[i + 1 :] if x.kind == "touch_down"), None)
            length = math.inf if down is None else down - e.time_s
            if length > longest:
                longest, out[f"{foot} heel back"] = length, down
    return out


# Bits of a contact pair's code (:attr:`ContactMonitor.pair_codes`): bit i (0-3) sole part i of
# SOLE_GEOMS on the floor, then the block on the biped, then another biped geom on the floor;
# _SPLIT_BIT marks a foot's one collision box on the floor (Scene.sole_boxes): its code carries
# both the heel's and the toe's bit, and the contact's side of the seam keeps one of them.
_BLOCK_BIT = 1 << len(SOLE_GEOMS)
_LYING_BIT = 1 << (len(SOLE_GEOMS) + 1)
_SPLIT_BIT = 1 << (len(SOLE_GEOMS) + 2)
_SOLE_MASK = _BLOCK_BIT - 1
#: Each foot's sole bits: SOLE_GEOMS lists the left foot's heel and toe, then the right's (the one
#: definition; the compiled loop's kernels import them).
_LEFT_MASK, _RIGHT_MASK = 0b0011, 0b1100
#: Both feet flat: every sole part of SOLE_GEOMS on the floor (the contacts a delayed controller
#: sees before its first sensed row, biped.sim.neuro; the compiled loop's kernel imports it).
STANDING = _SOLE_MASK


def _flag_arrays() -> tuple[np.ndarray, ...]:
    """The 16 possible (4,) sole-flag arrays, read-only, indexed by their bits."""
    out = []
    for bits in range(1 << len(SOLE_GEOMS)):
        a = np.array([bool(bits >> i & 1) for i in range(len(SOLE_GEOMS))])
        a.flags.writeable = False
        out.append(a)
    return tuple(out)


_FLAGS = _flag_arrays()
#: (left foot, right foot) on the floor (heel or toe) for each value of the sole bits.
_FEET = tuple((bool(b & _LEFT_MASK), bool(b & _RIGHT_MASK)) for b in range(1 << len(SOLE_GEOMS)))


def feet_of_bits(bits: int) -> tuple[bool, bool]:
    """(left, right) foot on the floor (heel or toe) of the contact monitor's ``bits``."""
    return _FEET[bits & _SOLE_MASK]


# One explicit signature: MuJoCo's ``data.contact.geom`` / ``.pos`` are strided views (layout
# "A"), but C-contiguous ones when ncon == 1, which would otherwise compile a second version in
# the middle of a run. Compiled (or loaded from numba's cache) on first use by
# :func:`compile_kernel`, not at import, so that :mod:`biped.sim.jit` can tell whether it is cold
# and say so before it compiles.
_KERNEL_SIGNATURE = types.int64(
    types.int32[:, :], types.float64[:, :], types.int64[:, ::1], types.float64[:, ::1], types.float64[:, ::1],
    types.float64[:, ::1],
)  # fmt: skip


@njit(cache=True, nogil=True, inline="always")
def contact_code(codes, g0, g1, pos, seams, gxpos, gxmat):  # pragma: no cover - compiled
    """The code of one contact between geoms ``g0`` and ``g1`` at ``pos`` (3,): ``codes[g0, g1]``,
    except that a foot's one collision box on the floor keeps only the heel's or the toe's bit,
    by the side of the seam the contact lies on (``seams[g]`` = (seam on the box's x axis [m],
    the heel's side +1/-1); ``gxpos`` / ``gxmat``: MuJoCo's ``geom_xpos`` / ``geom_xmat``)."""
    c = codes[g0, g1]
    if c & _SPLIT_BIT:
        g = g1 if np.isnan(seams[g0, 0]) else g0
        x = (
            (pos[0] - gxpos[g, 0]) * gxmat[g, 0]
            + (pos[1] - gxpos[g, 1]) * gxmat[g, 3]
            + (pos[2] - gxpos[g, 2]) * gxmat[g, 6]
        )
        sole = c & _SOLE_MASK
        heel = sole & -sole  # SOLE_GEOMS lists a foot's heel before its toe
        part = heel if (x - seams[g, 0]) * seams[g, 1] > 0.0 else sole ^ heel
        c = (c & ~(_SPLIT_BIT | _SOLE_MASK)) | part
    return c


@njit(cache=True, nogil=True)
def _contact_bits(geom, pos, codes, seams, gxpos, gxmat):  # pragma: no cover - compiled
    """OR of :func:`contact_code` over MuJoCo's contacts: their geom pairs ``geom`` (ncon, 2) and
    positions ``pos`` (ncon, 3)."""
    bits = 0
    for k in range(geom.shape[0]):
        bits |= contact_code(codes, geom[k, 0], geom[k, 1], pos[k], seams, gxpos, gxmat)
    return bits


def compile_kernel() -> None:
    """Compile :func:`_contact_bits` for its one signature (or load it from numba's cache) and
    allow no other; a no-op once done, or when numba's JIT is disabled."""
    compile_once(_contact_bits, _KERNEL_SIGNATURE)


class ContactMonitor:
    """Watches the contacts of a push scene (see :mod:`biped.sim.scene`).

    ``update(time_s, data)`` classifies the current contacts and records transitions; it must be
    called at a fixed rate (the control rate) from the start. Attributes after the run:
    ``events`` (list of :class:`ContactEvent`), ``block_contact_time_s`` (first block-biped contact
    or None), ``fall_time_s`` / ``fall_reason`` (None if no fall), ``flags`` (4,) bool of the
    current sole-part contacts in :data:`SOLE_GEOMS` order (read-only; a new array when they change),
    ``feet`` (left, right) bools: the foot's heel or toe is on the floor.

    ``sole_boxes`` (:attr:`biped.sim.scene.Scene.sole_boxes`): a foot that collides as one box
    (``physics = "fast"``) has its heel or toe on the floor when a contact of that box lies on the
    heel's or the toe's side of their seam.

    Cost: every geom pair's meaning is tabulated once (``pair_codes`` (ngeom, ngeom), symmetric);
    an update ORs the codes of MuJoCo's ``data.contact.geom`` pairs in one compiled call (a few
    microseconds, next to ~20 us per MuJoCo step) and does Python work only when something changes.
    """

    def __init__(
        self,
        model,
        *,
        floor_geom: int,
        block_geom: int,
        sole_geoms,
        biped_geoms,
        central_body: int,
        fall_height_m: float,
        sole_boxes=(),
    ):
        ng = model.ngeom
        biped = np.zeros(ng, dtype=bool)
        biped[list(biped_geoms)] = True
        soles = list(sole_geoms)
        codes = np.zeros((ng, ng), dtype=np.int64)
        for i, g in enumerate(soles):
            codes[floor_geom, g] |= 1 << i
        plain = biped.copy()  # biped geoms other than the soles (and not the floor or block)
        plain[soles] = False
        plain[[floor_geom, block_geom]] = False
        seams = np.full((ng, 2), np.nan)
        for g, foot, seam, side in sole_boxes:  # a foot's heel and toe as one box (Scene.sole_boxes)
            codes[floor_geom, g] |= _SPLIT_BIT | 0b11 << 2 * foot
            plain[g] = False
            seams[g] = seam, side
        codes[floor_geom, plain] |= _LYING_BIT
        on_biped = biped.copy()
        on_biped[soles] = True
        on_biped[[floor_geom, block_geom]] = False
        codes[block_geom, on_biped] |= _BLOCK_BIT
        self.pair_codes = np.ascontiguousarray(codes | codes.T)  # do not modify
        #: (ngeom, 2): (seam [m], heel side) of each foot's one collision box, NaN for the others
        self.seams = seams
        compile_kernel()
        self._floor = floor_geom
        self._plain = plain
        self._central = central_body
        self._fall_height = fall_height_m
        self._geom_names = [model.geom(i).name for i in range(ng)]
        self._bits = 0
        self.flags = _FLAGS[0]
        self.feet = _FEET[0]
        self.events: list[ContactEvent] = []
        self.block_contact_time_s: float | None = None
        self.fall_time_s: float | None = None
        self.fall_reason: str | None = None
        self._started = False

    @classmethod
    def of_scene(cls, scene, fall_height_m: float) -> ContactMonitor:
        """The monitor of a push scene (:class:`biped.sim.scene.Scene`): its floor, block, soles
        (one box a foot: ``scene.sole_boxes``), biped geoms and central body, the scene's fields of
        the same names; a fall below ``fall_height_m`` [m] (the scenario's)."""
        fields = ("floor_geom", "block_geom", "sole_geoms", "biped_geoms", "central_body", "sole_boxes")
        return cls(scene.model, fall_height_m=fall_height_m, **{f: getattr(scene, f) for f in fields})

    def _lying_geom(self, data) -> str:
        """Name of the biped geom (not a sole) of the first contact, in MuJoCo's order, that
        touches the floor."""
        g = np.asarray(data.contact.geom[: data.ncon])
        a, b = g[:, 0], g[:, 1]
        hit = ((a == self._floor) & self._plain[b]) | ((b == self._floor) & self._plain[a])
        j = int(np.flatnonzero(hit)[0])
        return self._geom_names[b[j] if a[j] == self._floor else a[j]]

    def classify(self, data) -> tuple[np.ndarray, bool, str | None]:
        """(sole-part flags (4,), block touches the biped, name of a non-sole geom on the floor)."""
        bits = self._bits_of(data)
        lying = self._lying_geom(data) if bits & _LYING_BIT else None
        return _FLAGS[bits & _SOLE_MASK].copy(), bool(bits & _BLOCK_BIT), lying

    def update(self, time_s: float, data) -> bool:
        """Record the contact state at ``time_s``; returns True once the biped has fallen."""
        return self.record(time_s, self._bits_of(data), data.xipos[self._central, 2], data)

    def feet_of(self, data) -> tuple[bool, bool]:
        """(left, right): which feet touch the floor in ``data`` (:func:`feet_of_bits`)."""
        return feet_of_bits(self._bits_of(data))

    def _bits_of(self, data) -> int:
        """OR of the contacts' codes (:func:`contact_code`) in ``data``."""
        if not data.ncon:
            return 0
        c = data.contact
        return _contact_bits(c.geom, c.pos, self.pair_codes, self.seams, data.geom_xpos, data.geom_xmat)

    def record(self, time_s: float, bits: int, z: float, data) -> bool:
        """:meth:`update` with the contacts already classified: ``bits`` is the OR of
        :func:`contact_code` over the contacts, ``z`` the central body's COM height [m] at
        ``time_s``; ``data`` is read only to name a lying geom. (The compiled loop of
        :mod:`biped.sim.fused` records its bits and feeds the changes through here.)"""
        bits = int(bits)
        changed = (bits ^ self._bits) & _SOLE_MASK
        if changed:
            if self._started:
                t = round(float(time_s), 9)
                for i in range(len(SOLE_GEOMS)):
                    if changed >> i & 1:
                        foot, part = SOLE_GEOMS[i]
                        self.events.append(
                            ContactEvent(t, foot, part, "touch_down" if bits >> i & 1 else "lift_off")
                        )
            self.flags = _FLAGS[bits & _SOLE_MASK]
            self.feet = _FEET[bits & _SOLE_MASK]
        self._started = True
        self._bits = bits
        if bits & _BLOCK_BIT and self.block_contact_time_s is None:
            self.block_contact_time_s = float(time_s)
        if self.fall_time_s is None:
            if bits & _LYING_BIT:
                self.fall_time_s = float(time_s)
                self.fall_reason = f"{self._lying_geom(data)} touched the floor"
            elif z < self._fall_height:
                self.fall_time_s = float(time_s)
                self.fall_reason = f"central-body COM at {z:.3f} m, below {self._fall_height} m"
        return self.fall_time_s is not None

    @property
    def bits(self) -> int:
        """The last recorded OR of :attr:`pair_codes` over the contacts."""
        return self._bits
