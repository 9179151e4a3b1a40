"""Four cars' controller kernel in one call: float64 values as 4-lane vectors (``F4``), so that a per-car kernel's
unchanged source runs each floating-point operation for four cars at once, one vector instruction
(issue 15: the MRAC kernel, ~450 scalar additions and multiplications per call, was ~0.07× of bare ``mj_step``
in the benchmark batch, a fifth of the closed loop's overhead).

Numba compiles a kernel for the argument types it is called with.  Called with the cars' shared parameter row
``p`` (an ordinary array), their readings and command rows as :func:`lanes4` (four rows indexed together) and
their states as :func:`block4` (a lane-interleaved (k, 4) array: ``st[j]`` is one load or store of four adjacent
numbers), a kernel's ``st[j]`` is an ``F4`` of the four cars' ``st[j]``, ``st[j] = v`` stores lane c into car c,
and ``+ - * /``, unary ``-``, ``min`` and ``max`` work lane by lane; a plain float (a parameter, a constant) is
the same in every lane.  Every lane's result is bit for bit the scalar kernel's for that car: the same IEEE
operations in the same order (no contraction into FMAs, no reassociation: numba gives LLVM no fast-math flags);
``-x`` is ``-0.0 - x`` and ``max(a, b)`` is ``b if b > a else a``, as numba lowers them for floats; a division
raises ``ZeroDivisionError`` when any lane's divisor is zero, as the scalar kernel does for that car.

Only straight-line arithmetic on the lanes types: a branch on a lane value (``if x > 0``), a comparison, ``abs``
or a math function of one does not, so a controller declares that its kernel runs this way
(``Controller.kernel_lanes``).  The loop runs a block of four cars this way when they share the parameter row
(``c_pi``), the common case of a batch; other cars call the scalar kernel (see :func:`lane_block`).

Measured (256 cars of the issue-7 benchmark, one core, load 11–13): the MRAC kernel 0.065 µs per car and call
car by car, 0.041 µs with the states gathered lane by lane from their rows, 0.028 µs lane-interleaved."""
from __future__ import annotations

import operator

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, make_attribute_wrapper, models, overload, register_model
from numba.np.arrayobj import make_array, populate_array

_V = ir.VectorType(ir.DoubleType(), 4)
_I32 = ir.IntType(32)


class F4Type(types.Type):
    """Four float64 lanes (an LLVM ``<4 x double>``)."""

    def __init__(self):
        super().__init__(name="F4")


F4 = F4Type()


@register_model(F4Type)
class _F4Model(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, _V)


class Lanes4Type(types.Type):
    """Four 1-D float64 arrays (four cars' rows), indexed together."""

    def __init__(self, arr):
        self.arr = arr
        super().__init__(name=f"Lanes4({arr})")


@register_model(Lanes4Type)
class _Lanes4Model(models.StructModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, [(f"a{j}", fe_type.arr) for j in range(4)])


for _j in range(4):
    make_attribute_wrapper(Lanes4Type, f"a{_j}", f"a{_j}")


def _is_scalar(t):
    return isinstance(t, (types.Float, types.Integer)) and not isinstance(t, types.Boolean)


def _splat(context, builder, val, ty):
    x = context.cast(builder, val, ty, types.float64)
    v = builder.insert_element(ir.Constant(_V, ir.Undefined), x, ir.Constant(_I32, 0))
    return builder.shuffle_vector(v, ir.Constant(_V, ir.Undefined), ir.Constant(ir.VectorType(_I32, 4), [0, 0, 0, 0]))


def _vec(context, builder, val, ty):
    return val if ty == F4 else _splat(context, builder, val, ty)


@intrinsic
def lanes4(typingctx, a0, a1, a2, a3):
    """Four rows (1-D float64 arrays of the same type) as one ``Lanes4``."""
    if not (isinstance(a0, types.Array) and a0.ndim == 1 and a0.dtype == types.float64 and a0 == a1 == a2 == a3):
        return None
    lt = Lanes4Type(a0)

    def codegen(context, builder, sig, args):
        st = cgutils.create_struct_proxy(lt)(context, builder)
        for j, a in enumerate(args):
            context.nrt.incref(builder, a0, a)
            setattr(st, f"a{j}", a)
        return st._getvalue()

    return lt(a0, a1, a2, a3), codegen


@intrinsic
def pack4(typingctx, x0, x1, x2, x3):
    """Four floats as the lanes of an ``F4``."""
    if not all(_is_scalar(x) for x in (x0, x1, x2, x3)):
        return None

    def codegen(context, builder, sig, args):
        v = ir.Constant(_V, ir.Undefined)
        for j, (x, t) in enumerate(zip(args, sig.args)):
            v = builder.insert_element(v, context.cast(builder, x, t, types.float64), ir.Constant(_I32, j))
        return v

    return F4(x0, x1, x2, x3), codegen


@intrinsic
def lane(typingctx, v, j):
    """Lane ``j`` (a literal 0..3) of an ``F4``."""
    if v != F4 or not isinstance(j, types.IntegerLiteral):
        return None
    k = j.literal_value

    def codegen(context, builder, sig, args):
        return builder.extract_element(args[0], ir.Constant(_I32, k))

    return types.float64(v, j), codegen


def _binary(name):
    @intrinsic
    def op(typingctx, a, b):
        if not ((a == F4 or _is_scalar(a)) and (b == F4 or _is_scalar(b)) and F4 in (a, b)):
            return None

        def codegen(context, builder, sig, args):
            x = _vec(context, builder, args[0], sig.args[0])
            y = _vec(context, builder, args[1], sig.args[1])
            if name == "fdiv":  # ZeroDivisionError when a lane divides by zero, as the scalar division raises it
                zero = builder.fcmp_ordered("==", y, ir.Constant(_V, [0.0] * 4))
                anyz = builder.icmp_unsigned("!=", builder.bitcast(zero, ir.IntType(4)), ir.Constant(ir.IntType(4), 0))
                with cgutils.if_unlikely(builder, anyz):
                    context.error_model.fp_zero_division(builder, ("division by zero",))
            return getattr(builder, name)(x, y)

        return F4(a, b), codegen

    return op


_ADD, _SUB, _MUL, _DIV = (_binary(n) for n in ("fadd", "fsub", "fmul", "fdiv"))


def _pair(a, b):
    return (a == F4 or _is_scalar(a)) and (b == F4 or _is_scalar(b)) and F4 in (a, b)


for _ops, _fn in (((operator.add, operator.iadd), _ADD), ((operator.sub, operator.isub), _SUB),
                  ((operator.mul, operator.imul), _MUL), ((operator.truediv, operator.itruediv), _DIV)):
    for _op in _ops:
        def _make(fn):
            def impl(a, b):
                if _pair(a, b):
                    return lambda a, b: fn(a, b)
            return impl

        overload(_op)(_make(_fn))


@intrinsic
def _neg(typingctx, a):
    if a != F4:
        return None

    def codegen(context, builder, sig, args):  # numba's negate_real: -0.0 - x
        return builder.fsub(ir.Constant(_V, [-0.0] * 4), args[0])

    return F4(a), codegen


@overload(operator.neg)
def _neg_ov(a):
    if a == F4:
        return lambda a: _neg(a)


@overload(operator.pos)
def _pos_ov(a):
    if a == F4:
        return lambda a: a


def _select(pred):
    @intrinsic
    def op(typingctx, a, b):
        if not _pair(a, b):
            return None

        def codegen(context, builder, sig, args):  # numba's do_minmax: select(b OP a, b, a)
            x = _vec(context, builder, args[0], sig.args[0])
            y = _vec(context, builder, args[1], sig.args[1])
            return builder.select(builder.fcmp_ordered(pred, y, x), y, x)

        return F4(a, b), codegen

    return op


_MAX, _MIN = _select(">"), _select("<")


@overload(max)
def _max_ov(a, b):
    if _pair(a, b):
        return lambda a, b: _MAX(a, b)


@overload(min)
def _min_ov(a, b):
    if _pair(a, b):
        return lambda a, b: _MIN(a, b)


@overload(operator.getitem)
def _getitem(l, i):
    if isinstance(l, Lanes4Type) and isinstance(i, types.Integer):
        return lambda l, i: pack4(l.a0[i], l.a1[i], l.a2[i], l.a3[i])


@overload(operator.setitem)
def _setitem(l, i, v):
    if isinstance(l, Lanes4Type) and isinstance(i, types.Integer):
        if v == F4:
            def impl(l, i, v):
                l.a0[i] = lane(v, 0)
                l.a1[i] = lane(v, 1)
                l.a2[i] = lane(v, 2)
                l.a3[i] = lane(v, 3)
            return impl
        if _is_scalar(v):
            def impl(l, i, v):
                l.a0[i] = v
                l.a1[i] = v
                l.a2[i] = v
                l.a3[i] = v
            return impl


class Block4Type(types.Type):
    """Four cars' rows stored lane-interleaved: a C-contiguous (k, 4) float64 array whose entry [j, c] is car c's
    ``st[j]``; indexed as a row of the four cars (entry j: one load or store of four adjacent numbers)."""

    def __init__(self, arr):
        self.arr = arr
        super().__init__(name=f"Block4({arr})")


@register_model(Block4Type)
class _Block4Model(models.StructModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, [("a", fe_type.arr)])


make_attribute_wrapper(Block4Type, "a", "a")


@intrinsic
def block4(typingctx, a):
    """A (k, 4) C-contiguous float64 array (four cars' rows, lane-interleaved) as one ``Block4``."""
    if not (isinstance(a, types.Array) and a.ndim == 2 and a.layout == "C" and a.dtype == types.float64):
        return None
    bt = Block4Type(a)

    def codegen(context, builder, sig, args):
        st = cgutils.create_struct_proxy(bt)(context, builder)
        context.nrt.incref(builder, a, args[0])
        st.a = args[0]
        return st._getvalue()

    return bt(a), codegen


@overload(operator.getitem)
def _b_getitem(l, i):
    if isinstance(l, Block4Type) and isinstance(i, types.Integer):
        return lambda l, i: pack4(l.a[i, 0], l.a[i, 1], l.a[i, 2], l.a[i, 3])


@overload(operator.setitem)
def _b_setitem(l, i, v):
    if isinstance(l, Block4Type) and isinstance(i, types.Integer):
        if v == F4:
            def impl(l, i, v):
                l.a[i, 0] = lane(v, 0)
                l.a[i, 1] = lane(v, 1)
                l.a[i, 2] = lane(v, 2)
                l.a[i, 3] = lane(v, 3)
            return impl
        if _is_scalar(v):
            def impl(l, i, v):
                l.a[i, 0] = v
                l.a[i, 1] = v
                l.a[i, 2] = v
                l.a[i, 3] = v
            return impl


# ---- the compiled loop's lane blocks -------------------------------------------------------------------------
# A block of four cars i = 4b .. 4b + 3 (all four within the ensemble, one controller parameter row) runs its
# controller in one call.  While the loop runs, such a block's four state rows of ``c_st`` (4·k numbers, contiguous)
# hold the same numbers lane-interleaved, as a (k, 4) array (entry [j, c]: car 4b + c's st[j]), so that the
# kernel's st[j] is one load or store of four adjacent numbers; the loop interleaves them when it starts and
# restores the rows before it returns, so outside the loop ``c_st`` is always one row per car.

@numba.njit(inline="always")
def lane_block(c_pi, i, n):
    """Whether car i is in a lane block: the four cars of its block exist and share their parameter row."""
    b = i - i % 4
    return b + 3 < n and c_pi[b + 1] == c_pi[b] and c_pi[b + 2] == c_pi[b] and c_pi[b + 3] == c_pi[b]


@intrinsic
def block_rows(typingctx, a, b):
    """The four rows 4b .. 4b + 3 of a C-contiguous (n, k) float64 array as a (k, 4) C-contiguous view of the
    same memory (no owner, as :func:`~suspension_sim.compiled.views.row`)."""
    if not (isinstance(a, types.Array) and a.ndim == 2 and a.layout == "C" and a.dtype == types.float64
            and isinstance(b, types.Integer)):
        return None
    ret = a.copy(ndim=2, layout="C")

    def codegen(context, builder, sig, args):
        arr = make_array(sig.args[0])(context, builder, args[0])
        k = cgutils.unpack_tuple(builder, arr.shape)[1]
        idx = builder.mul(context.cast(builder, args[1], sig.args[1], types.intp), context.get_constant(types.intp, 4))
        ptr = cgutils.get_item_pointer2(context, builder, data=arr.data, shape=cgutils.unpack_tuple(builder, arr.shape),
                                        strides=cgutils.unpack_tuple(builder, arr.strides), layout="C",
                                        inds=[idx, context.get_constant(types.intp, 0)])
        four = context.get_constant(types.intp, 4)
        out = make_array(sig.return_type)(context, builder)
        populate_array(out, data=ptr, shape=cgutils.pack_array(builder, [k, four]),
                       strides=cgutils.pack_array(builder, [context.get_constant(types.intp, 32),
                                                            context.get_constant(types.intp, 8)]),
                       itemsize=arr.itemsize, meminfo=None)
        return out._getvalue()

    return ret(a, b), codegen


@numba.njit(nogil=True)
def interleave_blocks(c_st, c_pi, n, forward):  # pragma: no cover - compiled
    """Every lane block's four rows of ``c_st`` lane-interleaved (``forward``) or back to one row per car."""
    k = c_st.shape[1]
    tmp = np.empty(4 * k)
    for i in range(0, n - 3, 4):
        if not lane_block(c_pi, i, n):
            continue
        for c in range(4):
            for j in range(k):
                q = j * 4 + c  # the interleaved position of car i + c's st[j]
                if forward:
                    tmp[q] = c_st[i + c, j]
                else:
                    tmp[c * k + j] = c_st[i + q // k, q % k]
        for q in range(4 * k):
            c_st[i + q // k, q % k] = tmp[q]


@numba.njit(inline="always")
def blocked_get(c_st, i, j, blk):
    """Car i's st[j] while the loop runs (lane-interleaved when car i is in a lane block)."""
    if not blk:
        return c_st[i, j]
    b = i - i % 4
    q = j * 4 + (i - b)
    return c_st[b + q // c_st.shape[1], q % c_st.shape[1]]
