"""The controller's four flat buffers (ints, model, work, out): their fields, their layout and
the compiled :func:`unpack` that cuts them into named views for the kernel
(:func:`biped.control.recursions.compute_kernel`) and the debugging methods of
:class:`biped.control.WorkspaceController` alike."""

from __future__ import annotations

from collections import namedtuple
from functools import lru_cache
from typing import Any

import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.core.imputils import impl_ret_borrowed
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

# ----------------------------------------------------------------------------- buffers
# The controller's four flat buffers, field by field: (name, shape), "n" = number of links
# (link 0 = W's link 1, the central body), "n-1" = number of joints. ``layout`` turns this table
# into offsets; ``unpack`` (compiled, used by the kernel and by WorkspaceController's debugging
# methods alike) cuts the buffers into these named views, in this order.
_FIELDS: dict[str, tuple[tuple[str, tuple[int | str, ...]], ...]] = {
    "ints": (  # int64: the tree (biped.model.TreeModel) and options
        ("n", (1,)),
        ("feet", (2,)),
        ("mode", (1,)),  # links; left/right foot links; Alg. 5 mode
        ("parent", ("n",)),
        ("qadr", ("n",)),
        ("dadr", ("n",)),  # inboard link; qpos and qvel addresses
        ("leg", ("n",)),
        ("beyond", ("n",)),
    ),  # 0 left, 1 right, -1 neither; 1 outboard of a foot
    "model": (  # float64, constant
        ("H", ("n", 6)),
        ("G0", ("n", 4, 4)),  # joint twists H_k; g_{k.i,k.o}(theta = qref)
        ("mass", ("n",)),
        ("inertia", ("n", 3)),
        ("qref", ("n",)),  # m_k; diag I_k; MJCF qpos0
        ("gravity", (3,)),
        ("root_qbi", (4,)),
        ("big_base", (1,)),
    ),  # world; body->COM frame; Alg. 3
    "work": (  # float64, overwritten by every call
        ("g", ("n", 4, 4)),
        ("gl", ("n", 4, 4)),  # g_{0,k}; g_{k.i,k.o}(theta_k) (Alg. 2)
        ("V", ("n", 6)),
        ("a", ("n", 6)),
        ("b", ("n", 6)),  # V_k^b, a_k, b_k (Alg. 1-2)
        ("P", ("n", 6, 6)),
        ("z", ("n", 6)),
        ("F", ("n", 6)),  # P_k, z_k (Alg. 3); F_k (Alg. 6)
        ("q_root", (4,)),
        ("q01", (4,)),  # root joint quaternion; q_{0,1} of the COM frame (Alg. 1)
        ("E", (4, 4)),  # exp(H_k^ theta_k) (Alg. 2)
        ("PH", (6,)),
        ("c", (6,)),
        ("c_in", (6,)),  # P H; projected P a + z; it in frame k.i (Alg. 3)
        ("Pa", (6, 6)),
        ("Q", (6, 6)),
        ("S", (3, 3)),  # projected P; congruence scratch (Alg. 3)
        ("qd_conj", (4,)),
        ("Re", (3, 3)),  # conj(q_{0,d}); R(q_e) (Alg. 4)
        ("dist_vecs", (3, 6)),
        ("dist_mats", (2, 6, 6)),
        ("R_foot", (2, 3, 3)),
    ),  # Alg. 5 scratch
    "out": (  # float64, the results (ControllerOutput)
        ("tau", ("n-1",)),
        ("P1", (6, 6)),
        ("z1", (6,)),
        ("Fd", (6,)),
        ("Fl_tilde", (6,)),
        ("Fr_tilde", (6,)),
        ("Fl", (6,)),
        ("Fr", (6,)),
        ("X", (6,)),
        ("qe", (4,)),
    ),
}


def _record(name: str, buf: str) -> Any:
    """A namedtuple class with the fields of buffer ``buf`` (typed Any: its fields are data)."""
    return namedtuple(name, [field for field, _ in _FIELDS[buf]])


Ints = _record("Ints", "ints")
Model = _record("Model", "model")
Work = _record("Work", "work")
Out = _record("Out", "out")


@lru_cache(maxsize=8)
def layout(n: int) -> dict[str, dict[str, tuple[int, tuple[int, ...]]]]:
    """Offsets and shapes ``{buffer: {field: (offset, shape)}}`` of the ints, model, work and out
    buffers for ``n`` links; ``{buffer: {"_size": (size, ())}}`` is each buffer's length. Computed
    once per ``n`` (a controller a sweep trial asked for it again, ~1 ms): do not modify it."""
    dims = {"n": n, "n-1": n - 1}
    result = {}
    for buf, fields in _FIELDS.items():
        spans: dict[str, tuple[int, tuple[int, ...]]] = {}
        off = 0
        for name, spec in fields:
            shape = tuple(dims[d] if isinstance(d, str) else d for d in spec)
            spans[name] = (off, shape)
            off += int(np.prod(shape))
        spans["_size"] = (off, ())
        result[buf] = spans
    return result


@njit(cache=True, inline="always")
def _take1(buf, o, d0):
    return buf[o : o + d0], o + d0


@intrinsic
def _c_view(typingctx, buf, o, dims):
    """The C-contiguous array of shape ``dims`` (a tuple of integers) at element ``o`` of the
    C-contiguous 1-d array ``buf``, sharing its memory and its owner (as ``reshape`` of a slice,
    which numba does through a C helper: ~60 ns a view, microseconds for the kernel's ~50). The
    caller checks that the view lies inside ``buf``."""
    if not (
        isinstance(buf, types.Array)
        and buf.ndim == 1
        and buf.layout == "C"
        and isinstance(o, types.Integer)
        and isinstance(dims, types.BaseTuple)
    ):
        return None
    dim_types = getattr(dims, "types", ())  # the tuple's member types
    if not all(isinstance(d, types.Integer) for d in dim_types):
        return None
    nd = len(dim_types)
    retty = buf.copy(ndim=nd, layout="C")

    def codegen(context, builder, signature, args):
        src = make_array(buf)(context, builder, args[0])
        dst = make_array(retty)(context, builder)
        shape = [
            context.cast(builder, v, t, types.intp)
            for v, t in zip(cgutils.unpack_tuple(builder, args[2], nd), dim_types, strict=True)
        ]
        itemsize = context.get_constant(types.intp, context.get_abi_sizeof(context.get_data_type(buf.dtype)))
        strides = [itemsize]
        for d in reversed(shape[1:]):
            strides.insert(0, builder.mul(strides[0], d))
        data = builder.gep(src.data, [context.cast(builder, args[1], o, types.intp)])
        populate_array(dst, data=data, shape=shape, strides=strides, itemsize=itemsize, meminfo=src.meminfo,
                       parent=src.parent)  # fmt: skip
        return impl_ret_borrowed(context, builder, retty, dst._getvalue())

    return retty(buf, o, dims), codegen


@intrinsic
def borrowed(typingctx, arr):
    """``arr`` without its owner (numba's meminfo and parent pointers null): the views cut from it
    are then not reference-counted, where every view of an owned array costs two atomic operations
    (~0.5 us for the kernel's ~50 views, per :func:`unpack`). Only for arrays that outlive every
    use of the result within one compiled call: never return it or a view of it to Python."""
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, signature, args):
        src = make_array(arr)(context, builder, args[0])
        dst = make_array(arr)(context, builder)
        populate_array(dst, data=src.data, shape=src.shape, strides=src.strides, itemsize=src.itemsize,
                       meminfo=None)  # fmt: skip
        return dst._getvalue()

    return arr(arr), codegen


@njit(cache=True, inline="always")
def _take2(buf, o, d0, d1):
    if o < 0 or d0 < 0 or d1 < 0 or o + d0 * d1 > buf.shape[0]:
        raise IndexError("a buffer view past the buffer's end")
    return _c_view(buf, o, (d0, d1)), o + d0 * d1  # type: ignore[call-arg]


@njit(cache=True, inline="always")
def _take3(buf, o, d0, d1, d2):
    if o < 0 or d0 < 0 or d1 < 0 or d2 < 0 or o + d0 * d1 * d2 > buf.shape[0]:
        raise IndexError("a buffer view past the buffer's end")
    return _c_view(buf, o, (d0, d1, d2)), o + d0 * d1 * d2  # type: ignore[call-arg]


@njit(cache=True, inline="always")
def unpack(mi, mf, work, out):
    """Named views ``(Ints, Model, Work, Out)`` of the four flat buffers, field by field as
    :data:`_FIELDS` lists them (``tests/test_control_layout.py`` checks it against :func:`layout`).
    Allocates nothing; callable from Python, where the views share the buffers' memory."""
    n = mi[0]
    o = 0
    v_n, o = _take1(mi, o, 1)
    feet, o = _take1(mi, o, 2)
    mode, o = _take1(mi, o, 1)
    parent, o = _take1(mi, o, n)
    qadr, o = _take1(mi, o, n)
    dadr, o = _take1(mi, o, n)
    leg, o = _take1(mi, o, n)
    beyond, o = _take1(mi, o, n)
    ints = Ints(v_n, feet, mode, parent, qadr, dadr, leg, beyond)
    o = 0
    H, o = _take2(mf, o, n, 6)
    G0, o = _take3(mf, o, n, 4, 4)
    mass, o = _take1(mf, o, n)
    inertia, o = _take2(mf, o, n, 3)
    qref, o = _take1(mf, o, n)
    gravity, o = _take1(mf, o, 3)
    root_qbi, o = _take1(mf, o, 4)
    big_base, o = _take1(mf, o, 1)
    model = Model(H, G0, mass, inertia, qref, gravity, root_qbi, big_base)
    o = 0
    g, o = _take3(work, o, n, 4, 4)
    gl, o = _take3(work, o, n, 4, 4)
    V, o = _take2(work, o, n, 6)
    a, o = _take2(work, o, n, 6)
    b, o = _take2(work, o, n, 6)
    P, o = _take3(work, o, n, 6, 6)
    z, o = _take2(work, o, n, 6)
    F, o = _take2(work, o, n, 6)
    q_root, o = _take1(work, o, 4)
    q01, o = _take1(work, o, 4)
    E, o = _take2(work, o, 4, 4)
    PH, o = _take1(work, o, 6)
    c, o = _take1(work, o, 6)
    c_in, o = _take1(work, o, 6)
    Pa, o = _take2(work, o, 6, 6)
    Q, o = _take2(work, o, 6, 6)
    S, o = _take2(work, o, 3, 3)
    qd_conj, o = _take1(work, o, 4)
    Re, o = _take2(work, o, 3, 3)
    dist_vecs, o = _take2(work, o, 3, 6)
    dist_mats, o = _take3(work, o, 2, 6, 6)
    R_foot, o = _take3(work, o, 2, 3, 3)
    wk = Work(
        g,
        gl,
        V,
        a,
        b,
        P,
        z,
        F,
        q_root,
        q01,
        E,
        PH,
        c,
        c_in,
        Pa,
        Q,
        S,
        qd_conj,
        Re,
        dist_vecs,
        dist_mats,
        R_foot,
    )
    o = 0
    tau, o = _take1(out, o, n - 1)
    P1, o = _take2(out, o, 6, 6)
    z1, o = _take1(out, o, 6)
    Fd, o = _take1(out, o, 6)
    Fl_tilde, o = _take1(out, o, 6)
    Fr_tilde, o = _take1(out, o, 6)
    Fl, o = _take1(out, o, 6)
    Fr, o = _take1(out, o, 6)
    X, o = _take1(out, o, 6)
    qe, o = _take1(out, o, 4)
    res = Out(tau, P1, z1, Fd, Fl_tilde, Fr_tilde, Fl, Fr, X, qe)
    return ints, model, wk, res
