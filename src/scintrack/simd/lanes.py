"""``Lanes``: LANES float64 values, one per trial, as one LLVM vector inside compiled code.

The SIMD type the lane kernels are written with (every tracker kernel runs
``LANES`` trials side by side, trial on the last axis of its arrays), and its
operations: load and store (:func:`lane_load`, :func:`lane_store`), broadcast
(:func:`lane_splat`), IEEE ``+ - * /``, unary ``-``, ``min``, ``max``,
``math.sqrt`` and ``abs`` lane by lane, integer powers, the lane-wise select
:func:`select_less` (numbers and Lanes alike), :func:`floor` (numbers and Lanes
alike), :func:`lanes_any_zero`, 64-byte aligned work arrays
(:func:`lanes_empty`) and the trial of each lane of a block of trials
(:func:`lane_trials`).  Every operation is, per lane, the one numba emits for a
float64, so a block written once in Python (:mod:`scintrack.trackers.blocks`,
:mod:`scintrack.estimators.formulas`, :mod:`scintrack.trackers.trig`) compiles
for numbers and for Lanes and gives each lane the bits of the scalar call.
"""

from __future__ import annotations

import math
import operator

import numpy as np
from llvmlite import ir as llvm_ir
from numba import njit, types
from numba.core import cgutils
from numba.core.errors import TypingError
from numba.extending import intrinsic, models, overload, register_model

from . import LANES

# LANES trials side by side, as SIMD vectors.
#
# The arrays of the lane blocks carry the trial on their LAST axis: x (n, LANES),
# P (n, n, LANES), per-trial scalars (LANES,), all C-contiguous float64.  The
# LANES values of one entry form one ``Lanes`` value, an LLVM ``<LANES x double>``
# vector (LANES = 32: four AVX-512 registers, eight AVX2 ones; LLVM splits it),
# loaded (:func:`lane_load`),
# combined with + - * / and unary - (IEEE fadd, fsub, fmul, fdiv and numba's
# ``-0.0 - v`` negation on every lane, without fast-math flags: no FMA
# contraction, no reassociation) and stored (:func:`lane_store`).  Each lane so
# evaluates exactly the scalar expression, in the same order: its bits are those
# of the one-trial formula.  (Why explicit vectors: numba leaves LLVM's SLP
# vectoriser off and cannot tell LLVM that the arrays of a loop over lanes do not
# alias, so a plain loop over the lanes stays scalar or pays run-time
# alias checks on every matrix entry, several times slower.)  32 lanes: the
# AEKF-AR ran 11, 16, 20 and 20 M filter-epochs/s with 8, 16, 32 and 64 (the
# per-vector overheads amortise up to 32; 64 only adds padding and cache).

# LANES (32) is defined in the package's __init__, apart from numba: light code sizes its batches by it


class Lanes(types.Type):
    """LANES float64 values, one per trial (an LLVM vector; only inside compiled code)."""

    def __init__(self):
        super().__init__(name=f"Lanes{LANES}xf64")


lanes_t = Lanes()
_VEC = llvm_ir.VectorType(llvm_ir.DoubleType(), LANES)


@register_model(Lanes)
class _LanesModel(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, _VEC)


def _check_array(arr):
    if not (isinstance(arr, types.Array) and arr.dtype == types.float64 and arr.layout == "C"):
        raise TypingError(f"lane_load / lane_store need a C-contiguous float64 array, got {arr}")


def _lane_ptr(context, builder, aty, arr, offset):
    data = context.make_array(aty)(context, builder, arr).data
    return builder.bitcast(builder.gep(data, [offset]), _VEC.as_pointer())


@intrinsic
def lane_load(typingctx, arr, offset):
    """The LANES values ``arr.flat[offset : offset + LANES]`` (``offset`` in elements, unchecked)."""
    _check_array(arr)

    def codegen(context, builder, sig, args):
        return builder.load(_lane_ptr(context, builder, sig.args[0], args[0], args[1]), align=8)

    return lanes_t(arr, offset), codegen


@intrinsic
def lane_store(typingctx, arr, offset, value):
    """``arr.flat[offset : offset + LANES] = value`` (unchecked)."""
    _check_array(arr)

    def codegen(context, builder, sig, args):
        builder.store(args[2], _lane_ptr(context, builder, sig.args[0], args[0], args[1]), align=8)
        return context.get_dummy_value()

    return types.none(arr, offset, lanes_t), codegen


_I32 = llvm_ir.IntType(32)


def _splat(builder, value):
    undef = llvm_ir.Constant(_VEC, None)
    one = builder.insert_element(undef, value, llvm_ir.Constant(_I32, 0))
    return builder.shuffle_vector(one, undef, llvm_ir.Constant(llvm_ir.VectorType(_I32, LANES), [0] * LANES))


def _is_operand(ty):
    return ty == lanes_t or isinstance(ty, (types.Float, types.Integer))


def _lanes_args(*tys):
    """True when the arguments are Lanes and plain numbers, at least one Lanes."""
    return any(t == lanes_t for t in tys) and all(_is_operand(t) for t in tys)


def _as_lanes(context, builder, ty, value):
    """A Lanes value as is; a number as numba's scalar arithmetic converts it (to float64), on every lane."""
    return value if ty == lanes_t else _splat(builder, context.cast(builder, value, ty, types.float64))


@intrinsic
def lane_splat(typingctx, value):
    """``value`` (a number, converted to float64) on every lane."""
    if _is_operand(value) and value != lanes_t:
        return lanes_t(value), lambda context, builder, sig, args: _as_lanes(context, builder, sig.args[0], args[0])


def _lanes_intrinsic(n_args, emit):
    """An intrinsic on Lanes of ``n_args`` arguments (numbers broadcast): ``emit(builder, *vectors)``."""

    def typer(*args):
        if _lanes_args(*args):

            def codegen(context, builder, sig, vals):
                return emit(builder, *(_as_lanes(context, builder, t, v) for t, v in zip(sig.args, vals)))

            return lanes_t(*args), codegen
        return None

    if n_args == 1:
        return intrinsic(lambda typingctx, a: typer(a))
    if n_args == 2:
        return intrinsic(lambda typingctx, a, b: typer(a, b))
    return intrinsic(lambda typingctx, a, b, c, d: typer(a, b, c, d))


def _overload_lanes(pyfunc, op, n_args):
    if n_args == 1:

        @overload(pyfunc)
        def _impl1(a):
            if _lanes_args(a):
                return lambda a: op(a)

    else:

        @overload(pyfunc)
        def _impl2(a, b):
            if _lanes_args(a, b):
                return lambda a, b: op(a, b)


def _llvm_intrinsic(name):
    def emit(builder, *vals):
        fnty = llvm_ir.FunctionType(_VEC, [_VEC] * len(vals))
        return builder.call(cgutils.get_or_insert_function(builder.module, fnty, f"{name}.v{LANES}f64"), vals)

    return emit


# IEEE operations on every lane, exactly as numba lowers them on one float64 (never fast-math):
# a + b, a - b, a * b, a / b (a zero divisor is the caller's check), -a (-0.0 - a,
# mathimpl.negate_real), max(a, b) = (b if b > a else a), min(a, b) = (b if b < a else a)
# (ordered compares, builtins.do_minmax), math.sqrt and abs (llvm.sqrt, llvm.fabs).  So the
# scalar blocks' Python functions compile unchanged for Lanes arguments (one formula).
for _pyfunc, _n, _emit in (
    (operator.add, 2, lambda b, x, y: b.fadd(x, y)),
    (operator.sub, 2, lambda b, x, y: b.fsub(x, y)),
    (operator.mul, 2, lambda b, x, y: b.fmul(x, y)),
    (operator.truediv, 2, lambda b, x, y: b.fdiv(x, y)),
    (operator.neg, 1, lambda b, x: b.fsub(llvm_ir.Constant(_VEC, [-0.0] * LANES), x)),
    (max, 2, lambda b, x, y: b.select(b.fcmp_ordered(">", y, x), y, x)),
    (min, 2, lambda b, x, y: b.select(b.fcmp_ordered("<", y, x), y, x)),
    (math.sqrt, 1, _llvm_intrinsic("llvm.sqrt")),
    (abs, 1, _llvm_intrinsic("llvm.fabs")),
):
    _overload_lanes(_pyfunc, _lanes_intrinsic(_n, _emit), _n)


@overload(operator.pow)
def _lanes_pow(a, b):
    """``a ** k``, k a literal integer >= 0, by numba's unrolled squaring (cpython.numbers.static_power_impl)."""
    if a == lanes_t and isinstance(b, types.IntegerLiteral) and b.literal_value >= 0:
        k = b.literal_value

        def impl(a, b):
            res = lane_splat(1.0)
            val = a
            e = k
            while e != 0:
                if e & 1:
                    res = res * val
                e >>= 1
                val = val * val
            return res

        return impl


#: ``where(a < b, x, y)`` on every lane (ordered compare); numbers are broadcast
lane_where_less = _lanes_intrinsic(4, lambda b, a_, b_, x, y: b.select(b.fcmp_ordered("<", a_, b_), x, y))


def select_less(a, b, x, y):
    """``x if a < b else y`` on numbers, and lane by lane on Lanes (:data:`lane_where_less`).

    Ordered compare: a NaN ``a`` or ``b`` selects ``y``.  The one lane-wise
    select of the scalar blocks (a block that must compile for both numbers
    and Lanes cannot branch per lane), e.g. the "not estimable" NaN of
    :func:`s4_corrected` and the AEKF-AR's hold of the last estimable S4.
    """
    return x if a < b else y


@overload(select_less)
def _select_less(a, b, x, y):
    if _lanes_args(a, b, x, y):
        return lambda a, b, x, y: lane_where_less(a, b, x, y)
    if all(isinstance(t, (types.Float, types.Integer)) for t in (a, b, x, y)):
        return lambda a, b, x, y: x if a < b else y
    return None


@njit(cache=True)
def lanes_empty(shape):
    """``np.empty(shape)`` (float64, C order) starting on a 64-byte boundary.

    numba aligns arrays to 32 bytes; a lane vector (LANES x 8 bytes, a multiple
    of 64) that straddles cache lines costs a second access on every load and
    store (measured: ar_predict 60 % slower).
    """
    size = 1
    for s in shape:
        size *= s
    buf = np.empty(size + 8)
    off = (64 - buf.ctypes.data % 64) % 64 // 8
    return buf[off : off + size].reshape(shape)




@intrinsic
def lanes_any_zero(typingctx, v):
    """True when some lane of ``v`` (Lanes) is +-0: the zero-divisor test of numba's scalar division, on every lane."""
    if v == lanes_t:

        def codegen(context, builder, sig, args):
            mask = builder.fcmp_ordered("==", args[0], llvm_ir.Constant(_VEC, [0.0] * LANES))
            bits = builder.bitcast(mask, llvm_ir.IntType(LANES))
            return builder.icmp_unsigned("!=", bits, llvm_ir.Constant(llvm_ir.IntType(LANES), 0))

        return types.boolean(v), codegen
    return None


lane_floor = _lanes_intrinsic(1, _llvm_intrinsic("llvm.floor"))


def floor(x):
    """The largest integer <= ``x`` as a float64 (``np.floor``), on numbers and lane by lane on Lanes (``llvm.floor``).

    A float result (unlike ``math.floor``'s int) so that one formula compiles for
    both; NaN and +-inf are returned as they are.
    """
    return np.floor(x)


@overload(floor)
def _floor(x):
    if x == lanes_t:
        return lambda x: lane_floor(x)
    if isinstance(x, (types.Float, types.Integer)):
        return lambda x: np.floor(x)
    return None


@njit(cache=True)
def lane_trials(c0, n_tr, trial):
    """The trial of every lane of the block of ``LANES`` trials starting at trial ``c0``, into ``trial`` (LANES,) int64.

    A short last block repeats its last trial in the lanes past it (computed,
    never written out); returns how many lanes are real trials.
    """
    for ln in range(LANES):
        trial[ln] = min(c0 + ln, n_tr - 1)
    return min(LANES, n_tr - c0)
