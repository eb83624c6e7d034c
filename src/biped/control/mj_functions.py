"""MuJoCo's C API as numba first-class functions (their addresses in libmujoco, the library the
Python bindings load), for compiled code of the controllers (:mod:`biped.control.swing_kernel`)
and of the push loop (:mod:`biped.sim.mjdata`, :mod:`biped.sim.fused`). Pointers are passed as
integers (``model._address``, ``data._address``, ``array.ctypes.data``), so a kernel that calls
them can be cached."""

from __future__ import annotations

import ctypes
import os

import mujoco
from llvmlite import ir  # type: ignore[import-untyped]
from numba import types
from numba.extending import intrinsic, overload

__all__ = ["STEP_SIG", "call_fullm", "call_jac", "mj_address", "mj_function"]

STEP_SIG = types.void(types.uintp, types.uintp)  # mj_step(const mjModel*, mjData*)


class _MjFunction(types.WrapperAddressProtocol):
    """A function of MuJoCo's C API as a numba first-class function (its address is an argument,
    so the compiled loop can be cached)."""

    def __init__(self, name: str, sig):
        lib = ctypes.CDLL(os.path.join(os.path.dirname(mujoco.__file__), _libname()))
        self._address = ctypes.cast(getattr(lib, name), ctypes.c_void_p).value
        self._sig = sig

    def __wrapper_address__(self):
        return self._address

    def signature(self):
        return self._sig


def _libname() -> str:
    names = [f for f in os.listdir(os.path.dirname(mujoco.__file__)) if f.startswith("libmujoco.so")]
    return sorted(names, key=len)[-1] if names else "libmujoco.so"


_FUNCTIONS: dict = {}


def mj_function(name: str, sig):
    """The :class:`_MjFunction` ``name`` of libmujoco with signature ``sig`` (made once a process),
    or None if libmujoco or the symbol cannot be found."""
    if name not in _FUNCTIONS:
        try:
            _FUNCTIONS[name] = _MjFunction(name, sig)
        except (OSError, AttributeError):
            _FUNCTIONS[name] = None
    return _FUNCTIONS[name]


def mj_address(name: str) -> int:
    """The address of libmujoco's function ``name`` as an integer (for :func:`call_jac`,
    :func:`call_fullm`: a call from Python then unboxes an integer, not a function object, which
    costs ~25 us a call); LookupError if it cannot be found."""
    f = mj_function(name, STEP_SIG)  # (only its address is used)
    if f is None:
        raise LookupError(f"libmujoco's {name} not found")
    return int(f.__wrapper_address__())


def _call(typingctx, args, ints):
    """An intrinsic's (signature, codegen) calling ``void (*args[0])(...)`` with the integer
    arguments ``args[1:]`` (i64, or i32 where ``ints`` says)."""
    if not all(isinstance(t, types.Integer) for t in args):
        return None

    def codegen(context, builder, signature, vals):
        kinds = [ir.IntType(32) if k else ir.IntType(64) for k in ints]
        fnty = ir.FunctionType(ir.VoidType(), kinds)
        ptr = builder.inttoptr(vals[0], fnty.as_pointer())
        conv = [
            builder.trunc(v, t) if t.width < v.type.width else v for v, t in zip(vals[1:], kinds, strict=True)
        ]
        builder.call(ptr, conv)
        return context.get_dummy_value()

    return types.void(*args), codegen


@intrinsic
def _jac_at(typingctx, fn, m, d, jacp, jacr, body):
    return _call(typingctx, (fn, m, d, jacp, jacr, body), (False, False, False, False, True))


@intrinsic
def _fullm_at(typingctx, fn, m, d, dst):
    return _call(typingctx, (fn, m, d, dst), (False, False, False))


_VP = ctypes.c_void_p


def call_jac(fn, m, d, jacp, jacr, body) -> None:
    """``mj_jacBody(m, d, jacp, jacr, body)`` at the integer address ``fn``, pointers as integers
    (the addresses are run-time values: safe in numba's cache). Compiled: a direct call; in
    Python (``NUMBA_DISABLE_JIT=1``): through ctypes."""
    ctypes.CFUNCTYPE(None, _VP, _VP, _VP, _VP, ctypes.c_int)(fn)(m, d, jacp, jacr, int(body))


def call_fullm(fn, m, d, dst) -> None:
    """``mj_fullM(m, d, dst)`` (the argument order of MuJoCo 3.3 on, the installed one's mujoco.h)
    at the integer address ``fn``, pointers as integers; as :func:`call_jac`."""
    ctypes.CFUNCTYPE(None, _VP, _VP, _VP)(fn)(m, d, dst)


@overload(call_jac)
def _call_jac_compiled(fn, m, d, jacp, jacr, body):
    return lambda fn, m, d, jacp, jacr, body: _jac_at(fn, m, d, jacp, jacr, body)  # type: ignore[call-arg]


@overload(call_fullm)
def _call_fullm_compiled(fn, m, d, dst):
    return lambda fn, m, d, dst: _fullm_at(fn, m, d, dst)  # type: ignore[call-arg]
