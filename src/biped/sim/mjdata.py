"""MuJoCo's C side for compiled code (:mod:`biped.sim.fused`): ``mj_step`` as a numba first-class
function, and where ``ncon`` and the contacts sit in an ``mjData`` struct.

The bindings do not expose either address: :func:`mjdata_layout` finds them on a probe model (a
ball resting on a plane), checks them against what the bindings report, and returns None (the
reason in :data:`last_failure`) for a MuJoCo whose layout does not pass, so the caller can fall
back to the Python loop.
"""

from __future__ import annotations

import ctypes

import mujoco
import numpy as np
from numba import types

from biped.control.mj_functions import STEP_SIG, mj_function

__all__ = [
    "FORCE_SIG",
    "STEP_SIG",
    "contact_frames",
    "last_failure",
    "mj_function",
    "mj_step_function",
    "mjdata_layout",
]

#: mj_contactForce(const mjModel*, const mjData*, int id, mjtNum result[6]) (the pointer as an integer)
FORCE_SIG = types.void(types.uintp, types.uintp, types.int32, types.uintp)


def mj_step_function():
    """MuJoCo's ``mj_step`` (:func:`mj_function`), or None if libmujoco cannot be found."""
    return mj_function("mj_step", STEP_SIG)


_PROBE_XML = """<mujoco><worldbody><geom name="floor" type="plane" size="1 1 .1"/>
<body pos="0 0 .05"><freejoint/><geom name="ball" size=".1"/></body></worldbody></mujoco>"""


def _struct_views(data, size: int):
    raw = np.ctypeslib.as_array((ctypes.c_uint8 * size).from_address(int(data._address)))
    return raw[: size // 4 * 4].view(np.int32), raw[: size // 8 * 8].view(np.uint64)


#: how far past ``ncon`` the probe looks for the ``contact`` pointer [bytes]
_SCAN_BYTES = 4096


def _offsets():
    """Byte offsets in ``mjData`` of ``ncon``, the ``arena`` and ``contact`` pointers, and the
    geom pair in ``mjContact`` and its size, found on a probe (a ball resting on a plane) and
    checked against what the bindings report; a string saying which check failed otherwise.

    The struct's pointer fields come in mjdata.h's order: ``buffer``, ``arena``, then the buffer's
    arrays from ``qpos`` on, then the arena's from ``contact`` on. A pointer equal to the
    contacts' address before ``qpos`` is ``arena``; after it, ``contact`` is the one followed by
    ``efc_type``'s address (an empty array at the end of the buffer may point there too, before
    ``contact``). The probe reads the struct word by word and stops there: nothing past the
    struct's end is read (reading a fixed 4 KB past ``ncon`` did, and once found a stray match
    in the heap beyond it)."""
    m = mujoco.MjModel.from_xml_string(_PROBE_XML)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    if d.ncon < 1:
        return f"the probe has {d.ncon} contacts"
    base = int(d._address)
    timer = d.timer.duration
    ncon_at = timer.ctypes.data - base + timer.shape[0] * timer.strides[0]
    if ncon_at % 8:
        return f"ncon at byte {ncon_at}, not 8-aligned"
    s32, _ = _struct_views(d, ncon_at + 8)
    if s32[ncon_at // 4] != d.ncon:
        return f"the int after timer[] is {s32[ncon_at // 4]}, not ncon = {d.ncon}"
    contact0 = d.contact.dist.ctypes.data  # dist is mjContact's first field
    qpos, efc = d.qpos.ctypes.data, d.efc_type.ctypes.data
    # read word by word and stop at ``contact`` (the contacts' address followed by efc_type's,
    # mjdata.h's first two arena arrays), so that nothing past the struct's end is ever read
    arena_at = contact_at = qpos_at = None
    seen: list[int] = []
    for off in range(ncon_at + 8, ncon_at + _SCAN_BYTES, 8):
        w = ctypes.c_uint64.from_address(base + off).value
        if w == qpos:  # ``buffer`` (qpos is its first array), then ``qpos`` itself
            qpos_at, arena_at = off, (seen[-1] if seen else None)
        elif w == contact0:
            if qpos_at is not None and ctypes.c_uint64.from_address(base + off + 8).value == efc:
                contact_at = off
                break
            seen.append(off)
    if qpos_at is None or arena_at is None or contact_at is None:
        return f"pointer fields: qpos at {qpos_at}, arena at {arena_at}, contact at {contact_at}"
    geom, pos = d.contact.geom, d.contact.pos
    if pos.strides != (geom.strides[0], 8):
        return f"contact.pos strides {pos.strides}, geom stride {geom.strides[0]}"
    frame = d.contact.frame
    if frame.strides != (geom.strides[0], 8):
        return f"contact.frame strides {frame.strides}, geom stride {geom.strides[0]}"
    return (
        ncon_at // 4,
        arena_at,
        contact_at,
        geom.ctypes.data - contact0,
        geom.strides[0],
        pos.ctypes.data - contact0,
        frame.ctypes.data - contact0,
    )


_OFFSETS: list = []
#: Why :func:`mjdata_layout` last returned None (for diagnosis), or None.
last_failure: str | None = None


def mjdata_layout(model, data):
    """(int32 view of ``data``'s struct, uint64 view of it, index of the ``contact`` pointer in
    the second, the contacts' address, (capacity, 2) int32 view of their geom pairs, (capacity, 3)
    float64 view of their positions), or None
    (the reason in :data:`last_failure`) when this MuJoCo's layout does not pass
    :func:`_offsets`' checks or ``data`` disagrees with the bindings."""
    global last_failure
    if not _OFFSETS:
        found = _offsets()
        if isinstance(found, str):  # not cached: the next run probes again
            last_failure = found
            return None
        _OFFSETS.append(found)
    ncon_i, arena_at, contact_at, geom_at, stride, pos_at, _ = _OFFSETS[0]
    s32, s64 = _struct_views(data, contact_at + 8)  # up to the contact pointer, within the struct
    if s32[ncon_i] != data.ncon:
        last_failure = f"ncon read as {s32[ncon_i]}, the bindings say {data.ncon}"
        return None
    contact0 = int(s64[arena_at // 8])
    capacity = max(1, int(model.narena) // stride)
    arena = (ctypes.c_uint8 * (capacity * stride)).from_address(contact0)
    geom = np.ndarray((capacity, 2), dtype=np.int32, buffer=arena, offset=geom_at, strides=(stride, 4))
    pos = np.ndarray((capacity, 3), dtype=np.float64, buffer=arena, offset=pos_at, strides=(stride, 8))
    n = data.ncon
    if n and (
        int(s64[contact_at // 8]) != contact0
        or not np.array_equal(geom[:n], data.contact.geom)
        or not np.array_equal(pos[:n], data.contact.pos)
    ):
        last_failure = "the contacts are not at the start of the arena"
        return None
    return s32, s64, contact_at // 8, contact0, geom, pos


def contact_frames(model, data, contact0: int) -> np.ndarray:
    """(capacity, 9) float64 view of the contacts' frames (mjContact.frame: the normal, then the
    two tangents, as rows) of ``data``, whose contacts start at ``contact0`` (from
    :func:`mjdata_layout`, which must have passed)."""
    stride, frame_at = _OFFSETS[0][4], _OFFSETS[0][6]
    capacity = max(1, int(model.narena) // stride)
    arena = (ctypes.c_uint8 * (capacity * stride)).from_address(contact0)
    frames = np.ndarray((capacity, 9), dtype=np.float64, buffer=arena, offset=frame_at, strides=(stride, 8))
    n = data.ncon
    if n and not np.array_equal(frames[:n], data.contact.frame):
        raise LookupError("the contact frames are not where the probe found them")
    return frames
