"""Row views without a reference count, for the compiled loop's calls of the component kernels.

The kernels take rows of the ensemble's parameter and state arrays (``a_p[i, c]``, ``y[i]``, ...).  Numba
makes each such view share its parent's reference count: an atomic increment when the view is made and an
atomic decrement when it dies, twice per kernel call per car per step.  In the benchmark batch those two
instructions were a third of the loop's own time.  :func:`row` makes the same view (same data pointer, shape
and strides) with no owner: the arrays all belong to the Python caller of the loop and outlive it, so nothing
needs counting, and the (still emitted) count calls return at once for a view without an owner.  Reading and
writing through it are those of the ordinary view; the kernels themselves are unchanged and may still
allocate."""
from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array


@intrinsic
def row(typingctx, a, i):
    """``a[i]`` for a C-contiguous array ``a`` of 2 or more dimensions and an integer ``i`` (not checked
    against the bounds, as the loop's plain indexing is not), as a view without a reference count."""
    if not isinstance(a, types.Array) or a.ndim < 2 or a.layout != "C" or not isinstance(i, types.Integer):
        return None
    ret = a.copy(ndim=a.ndim - 1, layout="C")

    def codegen(context, builder, sig, args):
        aty = sig.args[0]
        arr = make_array(aty)(context, builder, args[0])
        shapes = cgutils.unpack_tuple(builder, arr.shape)
        strides = cgutils.unpack_tuple(builder, arr.strides)
        idx = context.cast(builder, args[1], sig.args[1], types.intp)
        zero = context.get_constant(types.intp, 0)
        ptr = cgutils.get_item_pointer2(context, builder, data=arr.data, shape=shapes, strides=strides,
                                        layout=aty.layout, inds=[idx] + [zero] * (aty.ndim - 1))
        out = make_array(sig.return_type)(context, builder)
        populate_array(out, data=ptr, shape=cgutils.pack_array(builder, shapes[1:]),
                       strides=cgutils.pack_array(builder, strides[1:]), itemsize=arr.itemsize, meminfo=None)
        return out._getvalue()

    return ret(a, i), codegen
