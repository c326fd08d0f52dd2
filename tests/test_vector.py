"""The SIMD helpers: a compiled row of RGB fused multiply-adds against the plain loop."""

import numba
import numpy as np
import pytest

from motes._vector import STACK_FLOATS, add_rgb_row, stack_floats


@numba.njit
def compiled_row(rgb, start, weights, count, red, green, blue):
    buffer = stack_floats()
    for k in range(count):
        buffer[k] = weights[k]
    add_rgb_row(rgb, start, buffer, count, red, green, blue)


def fused(colour, weight, old):
    """A float32 fused multiply-add through float64: the product is exact there, the sum
    is rounded twice (to float64, then float32), which for rare values differs from one
    rounding; not for these (the compiled ``llvm.fma`` agrees bit for bit)."""
    return np.float32(np.float64(colour) * np.float64(weight) + np.float64(old))


@pytest.mark.parametrize("count", range(1, STACK_FLOATS + 1))
@pytest.mark.parametrize("start", [0, 5])
def test_a_compiled_row_adds_each_channel_once_and_nothing_else(count, start):
    rng = np.random.default_rng(count)
    rgb = rng.uniform(0, 2, 3 * STACK_FLOATS + 16).astype(np.float32)
    weights = rng.uniform(0, 1, count).astype(np.float32)
    colour = [np.float32(v) for v in rng.uniform(0, 3, 3)]
    expected = rgb.copy()
    for k in range(count):
        for c in range(3):
            q = start + 3 * k + c
            expected[q] = fused(colour[c], weights[k], expected[q])
    plain = rgb.copy()
    add_rgb_row(plain, start, weights, count, *colour)
    compiled = rgb.copy()
    compiled_row(compiled, np.uint64(start), weights, count, *colour)
    np.testing.assert_array_equal(plain, expected)
    # Bit for bit the scalar fused multiply-adds; the floats around the row untouched.
    np.testing.assert_array_equal(compiled.view(np.int32), expected.view(np.int32))


def test_the_stack_buffer_holds_what_is_written():
    @numba.njit
    def fill(n):
        buffer = stack_floats()
        for k in range(n):
            buffer[k] = np.float32(k) * np.float32(0.5)
        total = np.float32(0.0)
        for k in range(n):
            total += buffer[k]
        return total, buffer.shape[0]

    total, size = fill(STACK_FLOATS)
    assert size == STACK_FLOATS
    assert total == sum(0.5 * k for k in range(STACK_FLOATS))
