"""SIMD helpers that Numba does not give: a small float32 buffer on the stack, and a row
of RGB pixels brightened four floats at a time.

Numba leaves LLVM's SLP vectoriser off, so straight-line code (an unrolled row of a
sprite's footprint) stays scalar: adding a colour to a row of interleaved RGB pixels
costs three loads, three fused multiply-adds and three stores per pixel.
:func:`add_rgb_row` does the same arithmetic as ``<4 x float>`` vectors: one load, one
fused multiply-add and one store per four floats. Each float gets the very operation the
scalar code gave it (``fma(colour, weight, old)``, rounded once), so the results are
bit-identical.

Both run as plain Python where there is no compiler (``NUMBA_DISABLE_JIT=1``).
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, overload

#: Floats in a :func:`stack_floats` buffer.
STACK_FLOATS = 8


def stack_floats() -> np.ndarray:
    """A scratch (STACK_FLOATS,) float32 buffer: on the stack in compiled code, where
    LLVM keeps it in registers once loops over it are unrolled (a heap array would cost
    an allocation per call). Its values are undefined until written."""
    return np.empty(STACK_FLOATS, np.float32)


@intrinsic
def _stack_floats(typingctx):
    array_type = types.Array(types.float32, 1, "C")

    def codegen(context, builder, signature, args):
        real = ir.FloatType()
        data = cgutils.alloca_once(builder, real, size=STACK_FLOATS)
        array = context.make_array(array_type)(context, builder)
        itemsize = context.get_constant(types.intp, 4)
        context.populate_array(
            array,
            data=data,
            shape=[context.get_constant(types.intp, STACK_FLOATS)],
            strides=[itemsize],
            itemsize=itemsize,
            meminfo=None,
        )
        return array._getvalue()

    return array_type(), codegen


@overload(stack_floats, inline="always")
def _stack_floats_compiled():
    return lambda: _stack_floats()


def add_rgb_row(rgb, start, weights, count, red, green, blue) -> None:
    """``rgb[start + 3 k + c] = fma(colour[c], weights[k], rgb[start + 3 k + c])`` for
    pixels ``k < count`` and channels ``c`` (red, green, blue).

    ``rgb``: a C-contiguous float32 array of interleaved RGB pixels (a frame's colour,
    flattened); ``start``: the first pixel's first float; ``weights``: float32, at least
    ``count`` values. Compiled, the ``3 count`` floats go four at a time through
    ``llvm.fma.v4f32``, the last ``3 count mod 4`` one by one; ``count`` a constant of the
    caller (a window's width) unrolls it into straight-line code.
    """
    colour = (np.float32(red), np.float32(green), np.float32(blue))
    for k in range(count):
        for c in range(3):
            q = start + 3 * k + c
            rgb[q] = np.float32(np.float64(colour[c]) * np.float64(weights[k]) + np.float64(rgb[q]))


def _float32_array(value) -> bool:
    return (
        isinstance(value, types.Array)
        and value.ndim == 1
        and value.layout == "C"
        and value.dtype == types.float32
    )


@intrinsic
def _add_rgb_row(typingctx, rgb, start, weights, count, red, green, blue):
    if not (
        _float32_array(rgb)
        and _float32_array(weights)
        and isinstance(start, types.Integer)
        and isinstance(count, types.Integer)
        and all(v == types.float32 for v in (red, green, blue))
    ):
        return None

    def codegen(context, builder, signature, args):
        rgb_type, start_type, weights_type, count_type = signature.args[:4]
        real = ir.FloatType()
        four = ir.VectorType(real, 4)
        i64 = ir.IntType(64)
        i32 = ir.IntType(32)
        module = builder.module
        fma4 = cgutils.get_or_insert_function(
            module, ir.FunctionType(four, [four, four, four]), "llvm.fma.v4f32"
        )
        fma1 = cgutils.get_or_insert_function(
            module, ir.FunctionType(real, [real, real, real]), "llvm.fma.f32"
        )
        data = context.make_array(rgb_type)(context, builder, args[0]).data
        weight_data = context.make_array(weights_type)(context, builder, args[2]).data
        first = context.cast(builder, args[1], start_type, types.int64)
        count = context.cast(builder, args[3], count_type, types.int64)
        colour = args[4:7]
        floats = builder.mul(count, ir.Constant(i64, 3))
        whole = builder.and_(floats, ir.Constant(i64, -4))
        three = ir.Constant(i64, 3)

        def lane_values(f):
            """Weight and colour of float ``f`` of the row (pixel f // 3, channel f % 3)."""
            weight = builder.load(builder.gep(weight_data, [builder.udiv(f, three)]), typ=real)
            channel = builder.urem(f, three)
            value = builder.select(
                builder.icmp_unsigned("==", channel, ir.Constant(i64, 0)),
                colour[0],
                builder.select(
                    builder.icmp_unsigned("==", channel, ir.Constant(i64, 1)), colour[1], colour[2]
                ),
            )
            return weight, value

        with cgutils.for_range_slice(builder, ir.Constant(i64, 0), whole, ir.Constant(i64, 4)) as (
            f,
            _,
        ):
            weight4 = ir.Constant(four, None)
            colour4 = ir.Constant(four, None)
            for lane in range(4):
                weight, value = lane_values(builder.add(f, ir.Constant(i64, lane)))
                weight4 = builder.insert_element(weight4, weight, ir.Constant(i32, lane))
                colour4 = builder.insert_element(colour4, value, ir.Constant(i32, lane))
            address = builder.bitcast(builder.gep(data, [builder.add(first, f)]), four.as_pointer())
            old = builder.load(address, align=4)
            builder.store(builder.call(fma4, [colour4, weight4, old]), address, align=4)
        with cgutils.for_range_slice(builder, whole, floats, ir.Constant(i64, 1)) as (f, _):
            weight, value = lane_values(f)
            address = builder.gep(data, [builder.add(first, f)])
            old = builder.load(address, typ=real)
            builder.store(builder.call(fma1, [value, weight, old]), address)
        return context.get_dummy_value()

    return types.void(rgb, start, weights, count, red, green, blue), codegen


@overload(add_rgb_row, inline="always")
def _add_rgb_row_compiled(rgb, start, weights, count, red, green, blue):
    if _float32_array(rgb) and _float32_array(weights):
        return lambda rgb, start, weights, count, red, green, blue: _add_rgb_row(
            rgb, start, weights, count, red, green, blue
        )
    return None


__all__ = ["STACK_FLOATS", "add_rgb_row", "stack_floats"]
