"""Borrowed views of float arrays for the compiled hot loops (internal).

The right-hand sides of :mod:`iwp.models` take a state ``x`` and an output
``dx`` indexed like 1-D arrays. Passing numpy arrays to a compiled function
that is not inlined costs atomic reference counting at every call (about
7 ns each, four per evaluation of the right-hand side), and a numpy view
``A[:, l]`` costs the same and keeps the compiler from vectorising.

A view here is a bare pointer and a stride, passed by value:

* ``vec(a)``: a 1-D array, as the engine (:mod:`iwp.sim.engine`) passes its
  stage vectors to the plant;
* ``lane(A, l)``: column ``l`` of an (n, L) array, one simulation of a block
  advanced side by side (:mod:`iwp.sim.lanes`);
* ``slab_lane(A, s, l)``: column ``l`` of ``A[s]``;
* ``row(A, s)``: row ``s`` of a 2-D array (the RK4 bridge's stages).

And ``tuple_of(a, n)``: the first ``n`` elements of a 1-D array as a tuple,
read element by element (numba's ``to_fixed_tuple`` builds it in a loop
that the compiler spills to the stack, and reloads, at every element: about
1,500 memory operations for the 26 packed parameters, at every bridge across
a kink in the lanes).

A view must not outlive the array it looks into: it is only created and used
inside compiled kernels.
"""

from __future__ import annotations

import operator

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, models, overload, register_model


class LaneViewType(types.Type):
    """Numba type of a borrowed view (float64 elements)."""

    def __init__(self):
        super().__init__(name="LaneView")


lane_view_type = LaneViewType()


@register_model(LaneViewType)
class _LaneViewModel(models.StructModel):
    def __init__(self, dmm, fe_type):
        members = [("ptr", types.CPointer(types.float64)), ("stride", types.intp)]
        super().__init__(dmm, fe_type, members)


def _make(context, builder, aty, arr, offset_indices):
    """Lane view of the last axis of ``arr`` at the given leading indices (all but the last two axes)."""
    a = context.make_array(aty)(context, builder, arr)
    strides = cgutils.unpack_tuple(builder, a.strides, aty.ndim)
    size = ir.Constant(strides[0].type, 8)
    off = offset_indices[-1]  # the lane: last axis, unit stride (C-contiguous)
    for k, idx in enumerate(offset_indices[:-1]):
        off = builder.add(off, builder.mul(idx, builder.sdiv(strides[k], size)))
    v = cgutils.create_struct_proxy(lane_view_type)(context, builder)
    v.ptr = builder.gep(a.data, [off])
    v.stride = builder.sdiv(strides[aty.ndim - 2], size)
    return v._getvalue()


def _is_c_float_array(a, ndim):
    return isinstance(a, types.Array) and a.ndim == ndim and a.dtype == types.float64 and a.layout == "C"


@intrinsic
def vec(typingctx, arr):
    """``vec(a)``: a 1-D C-contiguous float64 array ``a`` as a view."""
    if not _is_c_float_array(arr, 1):
        return None

    def codegen(context, builder, sig, args):
        a = context.make_array(sig.args[0])(context, builder, args[0])
        v = cgutils.create_struct_proxy(lane_view_type)(context, builder)
        v.ptr = a.data
        v.stride = ir.Constant(ir.IntType(64), 1)
        return v._getvalue()

    return lane_view_type(arr), codegen


@intrinsic
def row(typingctx, arr, s):
    """``row(A, s)``: row ``s`` of a C-contiguous float64 array ``A`` of shape (m, n)."""
    if not (_is_c_float_array(arr, 2) and isinstance(s, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        a = context.make_array(sig.args[0])(context, builder, args[0])
        strides = cgutils.unpack_tuple(builder, a.strides, 2)
        si = context.cast(builder, args[1], sig.args[1], types.intp)
        v = cgutils.create_struct_proxy(lane_view_type)(context, builder)
        v.ptr = builder.gep(a.data, [builder.mul(si, builder.sdiv(strides[0], ir.Constant(strides[0].type, 8)))])
        v.stride = ir.Constant(ir.IntType(64), 1)
        return v._getvalue()

    return lane_view_type(arr, s), codegen


@intrinsic
def lane(typingctx, arr, l):
    """``lane(A, l)``: column ``l`` of a C-contiguous float64 array ``A`` of shape (n, L)."""
    if not (_is_c_float_array(arr, 2) and isinstance(l, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        li = context.cast(builder, args[1], sig.args[1], types.intp)
        return _make(context, builder, sig.args[0], args[0], [li])

    return lane_view_type(arr, l), codegen


@intrinsic
def slab_lane(typingctx, arr, s, l):
    """``slab_lane(A, s, l)``: column ``l`` of ``A[s]``, for ``A`` of shape (m, n, L)."""
    if not (_is_c_float_array(arr, 3) and isinstance(s, types.Integer) and isinstance(l, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        si = context.cast(builder, args[1], sig.args[1], types.intp)
        li = context.cast(builder, args[2], sig.args[2], types.intp)
        return _make(context, builder, sig.args[0], args[0], [si, li])

    return lane_view_type(arr, s, l), codegen


@intrinsic
def tuple_of(typingctx, arr, n):
    """``tuple_of(a, n)``: ``(a[0], ..., a[n-1])`` of a 1-D C-contiguous array ``a`` (``n`` a compile-time
    constant, at most ``a.size``: not checked)."""
    if not (isinstance(arr, types.Array) and arr.ndim == 1 and arr.layout == "C"
            and isinstance(n, types.IntegerLiteral)):
        return None
    k = n.literal_value
    tup = types.UniTuple(arr.dtype, k)

    def codegen(context, builder, sig, args):
        a = context.make_array(sig.args[0])(context, builder, args[0])
        items = [builder.load(builder.gep(a.data, [ir.Constant(ir.IntType(64), i)])) for i in range(k)]
        return context.make_tuple(builder, tup, items)

    return tup(arr, n), codegen


@intrinsic
def _get(typingctx, v, i):
    def codegen(context, builder, sig, args):
        s = cgutils.create_struct_proxy(lane_view_type)(context, builder, value=args[0])
        off = builder.mul(s.stride, context.cast(builder, args[1], sig.args[1], types.intp))
        return builder.load(builder.gep(s.ptr, [off]))

    return types.float64(v, i), codegen


@intrinsic
def _set(typingctx, v, i, x):
    def codegen(context, builder, sig, args):
        s = cgutils.create_struct_proxy(lane_view_type)(context, builder, value=args[0])
        off = builder.mul(s.stride, context.cast(builder, args[1], sig.args[1], types.intp))
        builder.store(context.cast(builder, args[2], sig.args[2], types.float64), builder.gep(s.ptr, [off]))
        return context.get_dummy_value()

    return types.none(v, i, x), codegen


@overload(operator.getitem)
def _getitem(v, i):
    if isinstance(v, LaneViewType) and isinstance(i, types.Integer):
        return lambda v, i: _get(v, i)
    return None


@overload(operator.setitem)
def _setitem(v, i, x):
    if isinstance(v, LaneViewType) and isinstance(i, types.Integer) and isinstance(x, (types.Float, types.Integer)):
        return lambda v, i, x: _set(v, i, x)
    return None
