"""SIMD helpers that Numba does not give: a small float32 buffer on the stack, a row of
RGB pixels brightened four floats at a time, and a row of a smooth sprite's weights
eight pixels at a time.

Numba leaves LLVM's SLP vectoriser off, so straight-line code (an unrolled row of a
sprite's footprint) stays scalar: adding a colour to a row of interleaved RGB pixels
costs three loads, three fused multiply-adds and three stores per pixel.
:func:`add_rgb_row` does the same arithmetic as ``<4 x float>`` vectors: one load, one
fused multiply-add and one store per four floats. Each float gets the very operation the
scalar code gave it (``fma(colour, weight, old)``, rounded once), so the results are
bit-identical. :func:`smooth_row` and :func:`depth_row` likewise compute a row of a
smooth footprint's weights and their depth test as ``<8 x float>`` vectors, each lane the
operations of the scalar :func:`~motes.render._footprint.profile_weight` and
:func:`~motes.render._footprint.depth_factor` in the same order (``max`` and ``min`` as
the same comparisons and selects).

All run as plain Python where there is no compiler (``NUMBA_DISABLE_JIT=1``).
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, overload

from ._jit import fma

#: Floats in a :func:`stack_floats` buffer: eight rows of :data:`LANES`.
STACK_FLOATS = 64

#: Pixels per vector of :func:`smooth_row` and :func:`depth_row`.
LANES = 8


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
            rgb[q] = fma(colour[c], np.float32(weights[k]), rgb[q])


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


def smooth_row(out, offset, col0, sx, dy, inv_rf2) -> None:
    """``out[offset + k]`` = the unit-peak smooth profile ``max(1 - r² / R², 0)²`` at the
    centre of pixel column ``col0 + k``, ``k < LANES``, ``r² = dx² + dy²`` with ``dx =
    col0 + k + 0.5 - sx`` [px] (float32 throughout, as the drawing loops round them)."""
    dy2 = np.float32(dy * dy)
    for k in range(LANES):
        dx = np.float32(np.float32(col0 + k) + np.float32(0.5)) - np.float32(sx)
        r2 = fma(dx, dx, dy2)
        a = fma(-r2, np.float32(inv_rf2), np.float32(1.0))
        s = np.float32(0.0) if np.float32(0.0) > a else a
        out[offset + k] = np.float32(s * s)


def depth_row(weights, profile, offset, depth, pixel, count, scale, d, inv_soft) -> None:
    """``weights[k] = profile[offset + k] · scale · clamp((depth[pixel + k] - d) ·
    inv_soft, 0, 1)`` for ``k < LANES`` (:func:`~motes.render._footprint.depth_factor`);
    ``depth`` is read only where ``k < count`` (the others weigh 0)."""
    for k in range(LANES):
        if k >= count:
            weights[k] = np.float32(0.0)
            continue
        f = np.float32(np.float32(depth[pixel + k] - np.float32(d)) * np.float32(inv_soft))
        f = np.float32(0.0) if np.float32(0.0) > f else f
        f = np.float32(1.0) if np.float32(1.0) < f else f
        weights[k] = np.float32(np.float32(profile[offset + k] * np.float32(scale)) * f)


def _vector_of(builder, ty, value, lanes):
    """``lanes`` copies of the scalar ``value`` as a vector of ``ty``."""
    vector = ir.Constant(ir.VectorType(ty, lanes), None)
    for lane in range(lanes):
        vector = builder.insert_element(vector, value, ir.Constant(ir.IntType(32), lane))
    return vector


def _fma_vector(builder, vector_type):
    return cgutils.get_or_insert_function(
        builder.module,
        ir.FunctionType(vector_type, [vector_type] * 3),
        f"llvm.fma.v{vector_type.count}f32",
    )


def _pointer_suffix(pointer_type) -> str:
    """An intrinsic's name suffix for a pointer argument: ``p0v8f32`` for a typed
    ``<8 x float>*``, ``p0`` where llvmlite builds opaque pointers (``ptr``)."""
    text = str(pointer_type)
    return "p0" if text == "ptr" else f"p0v{pointer_type.pointee.count}f32"


def _clamp_low(builder, value, low):
    """``max(value, low)`` as Numba compiles it: ``low if low > value else value``."""
    return builder.select(builder.fcmp_ordered(">", low, value), low, value)


@intrinsic
def _smooth_row(typingctx, out, offset, col0, sx, dy, inv_rf2):
    if not (
        _float32_array(out)
        and isinstance(offset, types.Integer)
        and isinstance(col0, types.Integer)
        and all(v == types.float32 for v in (sx, dy, inv_rf2))
    ):
        return None

    def codegen(context, builder, signature, args):
        out_type, offset_type, col_type = signature.args[:3]
        real = ir.FloatType()
        vector = ir.VectorType(real, LANES)
        i64 = ir.IntType(64)
        data = context.make_array(out_type)(context, builder, args[0]).data
        offset_value = context.cast(builder, args[1], offset_type, types.int64)
        col = context.cast(builder, args[2], col_type, types.int64)
        sx_value, dy_value, inv_rf2_value = args[3:6]
        columns = builder.add(
            _vector_of(builder, i64, col, LANES),
            ir.Constant(ir.VectorType(i64, LANES), list(range(LANES))),
        )
        half = _vector_of(builder, real, ir.Constant(real, 0.5), LANES)
        centre = builder.fadd(builder.sitofp(columns, vector), half)
        dx = builder.fsub(centre, _vector_of(builder, real, sx_value, LANES))
        dy2 = _vector_of(builder, real, builder.fmul(dy_value, dy_value), LANES)
        fma = _fma_vector(builder, vector)
        r2 = builder.call(fma, [dx, dx, dy2])
        one = _vector_of(builder, real, ir.Constant(real, 1.0), LANES)
        inv_rf2_lanes = _vector_of(builder, real, inv_rf2_value, LANES)
        a = builder.call(fma, [builder.fneg(r2), inv_rf2_lanes, one])
        s = _clamp_low(builder, a, ir.Constant(vector, [0.0] * LANES))
        address = builder.bitcast(builder.gep(data, [offset_value]), vector.as_pointer())
        builder.store(builder.fmul(s, s), address, align=4)
        return context.get_dummy_value()

    return types.void(out, offset, col0, sx, dy, inv_rf2), codegen


@overload(smooth_row, inline="always")
def _smooth_row_compiled(out, offset, col0, sx, dy, inv_rf2):
    if _float32_array(out):
        return lambda out, offset, col0, sx, dy, inv_rf2: _smooth_row(
            out, offset, col0, sx, dy, inv_rf2
        )
    return None


@intrinsic
def _depth_row(typingctx, weights, profile, offset, depth, pixel, count, scale, d, inv_soft):
    if not (
        _float32_array(weights)
        and _float32_array(profile)
        and _float32_array(depth)
        and all(isinstance(v, types.Integer) for v in (offset, pixel, count))
        and all(v == types.float32 for v in (scale, d, inv_soft))
    ):
        return None

    def codegen(context, builder, signature, args):
        types_ = signature.args
        real = ir.FloatType()
        vector = ir.VectorType(real, LANES)
        i64 = ir.IntType(64)
        mask_type = ir.VectorType(ir.IntType(1), LANES)
        weights_data = context.make_array(types_[0])(context, builder, args[0]).data
        profile_data = context.make_array(types_[1])(context, builder, args[1]).data
        depth_data = context.make_array(types_[3])(context, builder, args[3]).data
        offset_value = context.cast(builder, args[2], types_[2], types.int64)
        pixel = context.cast(builder, args[4], types_[4], types.int64)
        count = context.cast(builder, args[5], types_[5], types.int64)
        scale, d, inv_soft = args[6:9]
        lanes = ir.Constant(ir.VectorType(i64, LANES), list(range(LANES)))
        mask = builder.icmp_signed("<", lanes, _vector_of(builder, i64, count, LANES))
        masked_load = cgutils.get_or_insert_function(
            builder.module,
            ir.FunctionType(vector, [vector.as_pointer(), ir.IntType(32), mask_type, vector]),
            f"llvm.masked.load.v{LANES}f32.{_pointer_suffix(vector.as_pointer())}",
        )
        depth_address = builder.bitcast(builder.gep(depth_data, [pixel]), vector.as_pointer())
        zero = ir.Constant(vector, [0.0] * LANES)
        align = ir.Constant(ir.IntType(32), 4)
        opaque = builder.call(masked_load, [depth_address, align, mask, zero])
        f = builder.fmul(
            builder.fsub(opaque, _vector_of(builder, real, d, LANES)),
            _vector_of(builder, real, inv_soft, LANES),
        )
        f = _clamp_low(builder, f, zero)
        one = ir.Constant(vector, [1.0] * LANES)
        f = builder.select(builder.fcmp_ordered("<", one, f), one, f)  # min(f, 1)
        profile_address = builder.bitcast(
            builder.gep(profile_data, [offset_value]), vector.as_pointer()
        )
        w = builder.fmul(
            builder.load(profile_address, align=4), _vector_of(builder, real, scale, LANES)
        )
        w = builder.select(mask, builder.fmul(w, f), zero)
        builder.store(w, builder.bitcast(weights_data, vector.as_pointer()), align=4)
        return context.get_dummy_value()

    sig = types.void(weights, profile, offset, depth, pixel, count, scale, d, inv_soft)
    return sig, codegen


@overload(depth_row, inline="always")
def _depth_row_compiled(weights, profile, offset, depth, pixel, count, scale, d, inv_soft):
    if _float32_array(weights) and _float32_array(profile) and _float32_array(depth):
        return lambda weights, profile, offset, depth, pixel, count, scale, d, inv_soft: _depth_row(
            weights, profile, offset, depth, pixel, count, scale, d, inv_soft
        )
    return None


__all__ = ["LANES", "STACK_FLOATS", "add_rgb_row", "depth_row", "smooth_row", "stack_floats"]
