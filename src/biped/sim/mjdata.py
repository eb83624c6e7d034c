"""MuJoCo's C side for compiled code (:mod:`biped.sim.fused`): ``mj_step`` as a numba first-class
function, and where ``ncon`` and the contacts sit in an ``mjData`` struct.

The bindings do not expose either address: :func:`mjdata_layout` finds them on a probe model (a
ball resting on a plane), checks them against what the bindings report, and returns None (the
reason in :data:`last_failure`) for a MuJoCo whose layout does not pass, so the caller can fall
back to the Python loop.
"""

from __future__ import annotations

import ctypes
import os

import mujoco
import numpy as np
from numba import types

__all__ = ["STEP_SIG", "last_failure", "mj_step_function", "mjdata_layout"]

STEP_SIG = types.void(types.uintp, types.uintp)  # mj_step(const mjModel*, mjData*)


class _MjStep(types.WrapperAddressProtocol):
    """MuJoCo's C ``mj_step`` as a numba first-class function (its address is an argument, so the
    compiled loop can be cached)."""

    def __init__(self):
        lib = ctypes.CDLL(os.path.join(os.path.dirname(mujoco.__file__), _libname()))
        self._address = ctypes.cast(lib.mj_step, ctypes.c_void_p).value

    def __wrapper_address__(self):
        return self._address

    def signature(self):
        return STEP_SIG


def _libname() -> str:
    names = [f for f in os.listdir(os.path.dirname(mujoco.__file__)) if f.startswith("libmujoco.so")]
    return sorted(names, key=len)[-1] if names else "libmujoco.so"


_STEP: list = []


def mj_step_function():
    """The :class:`_MjStep` of this process (made once), or None if libmujoco cannot be found."""
    if not _STEP:
        try:
            _STEP.append(_MjStep())
        except (OSError, AttributeError):
            _STEP.append(None)
    return _STEP[0]


_PROBE_XML = """<mujoco><worldbody><geom name="floor" type="plane" size="1 1 .1"/>
<body pos="0 0 .05"><freejoint/><geom name="ball" size=".1"/></body></worldbody></mujoco>"""


def _struct_views(data, size: int):
    raw = np.ctypeslib.as_array((ctypes.c_uint8 * size).from_address(int(data._address)))
    return raw[: size // 4 * 4].view(np.int32), raw[: size // 8 * 8].view(np.uint64)


def _offsets():
    """Byte offsets in ``mjData`` of ``ncon``, the ``arena`` and ``contact`` pointers, and the
    geom pair in ``mjContact`` and its size, found on a probe (a ball resting on a plane) and
    checked against what the bindings report; a string saying which check failed otherwise.

    The struct's pointer fields come in mjdata.h's order: ``buffer``, ``arena``, then the buffer's
    arrays from ``qpos`` on, then the arena's from ``contact`` on. A pointer equal to the
    contacts' address before ``qpos`` is ``arena``; the last one after it is ``contact`` (an
    empty array at the end of the buffer may point there too, before ``contact``)."""
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
    s32, s64 = _struct_views(d, ncon_at + 4096)
    if s32[ncon_at // 4] != d.ncon:
        return f"the int after timer[] is {s32[ncon_at // 4]}, not ncon = {d.ncon}"
    contact0 = d.contact.dist.ctypes.data  # dist is mjContact's first field
    qpos = np.flatnonzero(s64 == np.uint64(d.qpos.ctypes.data)) * 8  # buffer (qpos first), qpos
    at = np.flatnonzero(s64 == np.uint64(contact0)) * 8
    if len(qpos) == 0 or not np.any(at < qpos[-1]) or not np.any(at > qpos[-1]):
        return f"pointer fields: qpos at {qpos.tolist()}, the contacts' address at {at.tolist()}"
    arena_at, contact_at = int(at[at < qpos[-1]][-1]), int(at[-1])
    geom = d.contact.geom
    return ncon_at // 4, arena_at, contact_at, geom.ctypes.data - contact0, geom.strides[0]


_OFFSETS: list = []
#: Why :func:`mjdata_layout` last returned None (for diagnosis), or None.
last_failure: str | None = None


def mjdata_layout(model, data):
    """(int32 view of ``data``'s struct, uint64 view of it, index of the ``contact`` pointer in
    the second, the contacts' address, (capacity, 2) int32 view of their geom pairs), or None
    (the reason in :data:`last_failure`) when this MuJoCo's layout does not pass
    :func:`_offsets`' checks or ``data`` disagrees with the bindings."""
    global last_failure
    if not _OFFSETS:
        found = _offsets()
        if isinstance(found, str):  # not cached: the next run probes again
            last_failure = found
            return None
        _OFFSETS.append(found)
    ncon_i, arena_at, contact_at, geom_at, stride = _OFFSETS[0]
    s32, s64 = _struct_views(data, ncon_i * 4 + 4096)
    if s32[ncon_i] != data.ncon:
        last_failure = f"ncon read as {s32[ncon_i]}, the bindings say {data.ncon}"
        return None
    contact0 = int(s64[arena_at // 8])
    capacity = max(1, int(model.narena) // stride)
    arena = (ctypes.c_uint8 * (capacity * stride)).from_address(contact0)
    geom = np.ndarray((capacity, 2), dtype=np.int32, buffer=arena, offset=geom_at, strides=(stride, 4))
    if data.ncon and (
        int(s64[contact_at // 8]) != contact0 or not np.array_equal(geom[: data.ncon], data.contact.geom)
    ):
        last_failure = "the contacts are not at the start of the arena"
        return None
    return s32, s64, contact_at // 8, contact0, geom
