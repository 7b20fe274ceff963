"""Helpers shared by the kernels' workers: exact bit counts, the stop flag, the CSW
claim test, the unique rule's distinctness test and the left-right check of a pixel."""

import llvmlite.ir as ir
import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic, overload

from ..contract import dtype_name, dtype_of  # noqa: F401 (the workers' modules use them)
from .options import SERIAL


def ctpop(value):
    """Number of set bits of an unsigned integer, in its own type.  Compiled, this is
    LLVM's ctpop, which vectorises to byte lookups (AVX2 has no vector popcount)."""
    return type(value)(int(value).bit_count())


@intrinsic
def _ctpop(typingctx, value):
    def codegen(context, builder, signature, args):
        return builder.ctpop(args[0])

    return value(value), codegen


@overload(ctpop)
def _ctpop_compiled(value):
    return lambda value: _ctpop(value)


def prefetch(array, index):
    """Ask the CPU to bring array[index] into its caches soon, for loops that walk memory
    downwards, where its own prefetchers don't follow (index: an integer, or a tuple of
    one a dimension: no view is made, as array[x][k] would make one, with its reference
    counting).  Compiled, this is LLVM's prefetch (an instruction, no call); with
    NUMBA_DISABLE_JIT, nothing."""


def prefetch_write(array, index):
    """As prefetch, for an element about to be written: its line is asked for as a
    store asks for it (owned), so that the store does not wait for it."""


def _prefetch_codegen(write):
    def codegen(context, builder, signature, args):
        array_type, index_type = signature.args
        array = context.make_array(array_type)(context, builder, args[0])
        indices = cgutils.unpack_tuple(builder, args[1]) \
            if isinstance(index_type, types.BaseTuple) else [args[1]]
        pointer = cgutils.get_item_pointer(context, builder, array_type, array, indices)
        kind = ir.FunctionType(ir.VoidType(), [ir.IntType(8).as_pointer()] +
                               [ir.IntType(32)] * 3)
        function = builder.module.declare_intrinsic("llvm.prefetch", fnty=kind)
        # read or write, keep in every cache level, data
        flag = [ir.Constant(ir.IntType(32), v) for v in (int(write), 3, 1)]
        builder.call(function, [builder.bitcast(pointer, ir.IntType(8).as_pointer()), *flag])
        return context.get_dummy_value()

    return codegen


@intrinsic
def _prefetch(typingctx, array, index):
    return types.void(array, index), _prefetch_codegen(False)


@intrinsic
def _prefetch_write(typingctx, array, index):
    return types.void(array, index), _prefetch_codegen(True)


@overload(prefetch)
def _prefetch_compiled(array, index):
    return lambda array, index: _prefetch(array, index)


@overload(prefetch_write)
def _prefetch_write_compiled(array, index):
    return lambda array, index: _prefetch_write(array, index)


def stop_requested(stop):
    """stop[0] != 0.  stop: uint8 (1,), set by another thread to stop a run.  Compiled, it
    is an atomic load (see _atomic_flag); with NUMBA_DISABLE_JIT, this plain read."""
    return stop[0] != 0


@intrinsic
def _atomic_flag(typingctx, stop):
    """stop[0] != 0 read with an atomic load: a plain load of an array the loop never
    writes may be hoisted out of the loop by LLVM (it was: a stop set mid-run went
    unseen until the run's end)."""
    def codegen(context, builder, signature, args):
        array = context.make_array(signature.args[0])(context, builder, args[0])
        value = builder.load_atomic(array.data, "monotonic", 1)
        return builder.icmp_unsigned("!=", value, value.type(0))

    return types.boolean(stop), codegen


@overload(stop_requested)
def _stop_requested_compiled(stop):
    return lambda stop: _atomic_flag(stop)


@njit(**SERIAL)
def blocked(claim, x, slack):
    """Whether a claim (the claimant's column, or -1) blocks pixel x: x - claimant > slack."""
    return claim >= 0 and x - claim > slack


@njit(**SERIAL)
def lr_agrees(d, back, limit, invalid):
    """The left-right check of one pixel: its disparity d and its right pixel's own
    match back are both valid (not ``invalid``) and differ by at most limit."""
    return d != invalid and back != invalid and abs(d - back) <= limit


@njit(**SERIAL)
def is_distinct(best, second, csw_margin):
    """The unique rule's test: a second-best cost exists and beats best by csw_margin %."""
    return second >= 0 and second * 100 > best * (100 + csw_margin)


@njit(**SERIAL)
def keep_or_take(kept, k, take):
    """int16: k where ``take``, else ``kept``, as a bit blend: the select of the right
    map's running argmin written so that LLVM keeps it in 16-bit SIMD lanes on AVX2
    (a conditional expression there compiled to a scalar loop, 3x slower)."""
    mask = np.int16(-1) if take else np.int16(0)
    return np.int16((kept & ~mask) | (np.int16(k) & mask))
