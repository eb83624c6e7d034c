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
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import mujoco
import numpy as np

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
def dampratio_for_restitution(restitution: float, timeconst: float, timestep: float,
                              phases: int = 8) -> float:
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
        raise ValueError(f"restitution {restitution} is above what timeconst {timeconst} s at "
                         f"timestep {timestep} s can give ({e_of(lo):.3f})")
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
    return (float(timeconst), dampratio_for_restitution(float(restitution), float(timeconst),
                                                        float(timestep)))


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


# geom roles
_NONE, _FLOOR, _BLOCK, _BIPED = 0, 1, 2, 3  # sole parts are 10 + index into SOLE_GEOMS


class ContactMonitor:
    """Watches the contacts of a push scene (see :mod:`biped.sim.scene`).

    ``update(time_s, data)`` classifies the current contacts and records transitions; it must be
    called at a fixed rate (the control rate) from the start. Attributes after the run:
    ``events`` (list of :class:`ContactEvent`), ``block_contact_time_s`` (first block-biped contact
    or None), ``fall_time_s`` / ``fall_reason`` (None if no fall), ``flags`` (4,) bool of the
    current sole-part contacts in :data:`SOLE_GEOMS` order.
    """

    def __init__(self, model, *, floor_geom: int, block_geom: int, sole_geoms, biped_geoms,
                 central_body: int, fall_height_m: float):
        role = np.full(model.ngeom, _NONE, dtype=np.int64)
        role[list(biped_geoms)] = _BIPED
        for i, g in enumerate(sole_geoms):
            role[g] = 10 + i
        role[floor_geom] = _FLOOR
        role[block_geom] = _BLOCK
        self._role = role
        self._central = central_body
        self._fall_height = fall_height_m
        self._geom_names = [model.geom(i).name for i in range(model.ngeom)]
        self.flags = np.zeros(len(SOLE_GEOMS), dtype=bool)
        self.events: list[ContactEvent] = []
        self.block_contact_time_s: float | None = None
        self.fall_time_s: float | None = None
        self.fall_reason: str | None = None
        self._started = False

    def classify(self, data) -> tuple[np.ndarray, bool, str | None]:
        """(sole-part flags (4,), block touches the biped, name of a non-sole geom on the floor)."""
        n = data.ncon
        flags = np.zeros(len(SOLE_GEOMS), dtype=bool)
        if n == 0:
            return flags, False, None
        g = np.stack([data.contact.geom1[:n], data.contact.geom2[:n]])
        r = self._role[g]
        floor = (r == _FLOOR).any(axis=0)
        other = np.where(r[0] == _FLOOR, r[1], r[0])
        for k in other[floor]:
            if k >= 10:
                flags[k - 10] = True
        lying = None
        bad = floor & (other == _BIPED)
        if bad.any():
            j = int(np.flatnonzero(bad)[0])
            lying = self._geom_names[g[0, j] if r[0, j] == _BIPED else g[1, j]]
        block = (r == _BLOCK).any(axis=0) & ((r == _BIPED) | (r >= 10)).any(axis=0)
        return flags, bool(block.any()), lying

    def update(self, time_s: float, data) -> bool:
        """Record the contact state at ``time_s``; returns True once the biped has fallen."""
        flags, block, lying = self.classify(data)
        if self._started:
            for i in np.flatnonzero(flags != self.flags):
                foot, part = SOLE_GEOMS[i]
                self.events.append(ContactEvent(round(float(time_s), 9), foot, part,
                                                "touch_down" if flags[i] else "lift_off"))
        self._started = True
        self.flags = flags
        if block and self.block_contact_time_s is None:
            self.block_contact_time_s = float(time_s)
        if self.fall_time_s is None:
            z = data.xipos[self._central, 2]
            if lying is not None:
                self.fall_time_s, self.fall_reason = float(time_s), f"{lying} touched the floor"
            elif z < self._fall_height:
                self.fall_time_s = float(time_s)
                self.fall_reason = f"central-body COM at {z:.3f} m, below {self._fall_height} m"
        return self.fall_time_s is not None
