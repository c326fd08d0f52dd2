"""The SIMD helpers against the scalar code they replace, bit for bit, and as plain
Python."""

import ctypes
import mmap

import numba
import numpy as np
import pytest

from motes._jit import called
from motes._vector import LANES, STACK_FLOATS, add_rgb_row, depth_row, smooth_row, stack_floats
from motes.render._footprint import HALF, ONE, SMOOTH, ZERO, depth_factor, profile_weight


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


@pytest.mark.parametrize("count", range(1, LANES + 1))
@pytest.mark.parametrize("start", [0, 5])
def test_a_compiled_row_adds_each_channel_once_and_nothing_else(count, start):
    rng = np.random.default_rng(count)
    rgb = rng.uniform(0, 2, 3 * LANES + 16).astype(np.float32)
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


@called
def scalar_smooth_row(col0, sx, dy, inv_rf2, out):
    """The drawing loops' scalar weights of one row (profile_weight, SMOOTH)."""
    for k in range(LANES):
        dx = (np.float32(col0 + k) + HALF) - sx
        out[k] = profile_weight(SMOOTH, dx, dy, ONE, inv_rf2)


@numba.njit
def vector_smooth_row(col0, sx, dy, inv_rf2, out):
    buffer = stack_floats()
    smooth_row(buffer, LANES, col0, sx, dy, inv_rf2)
    for k in range(LANES):
        out[k] = buffer[LANES + k]


@called
def scalar_depth_row(profile, depth, pixel, count, scale, d, inv_soft, out):
    for k in range(LANES):
        w = profile[k] * scale
        out[k] = w * depth_factor(depth[pixel + k], d, inv_soft) if k < count else ZERO


@numba.njit
def vector_depth_row(profile, depth, pixel, count, scale, d, inv_soft, out):
    buffer = stack_floats()
    depth_row(buffer, profile, 0, depth, pixel, count, scale, d, inv_soft)
    for k in range(LANES):
        out[k] = buffer[k]


def test_a_smooth_row_matches_the_scalar_weights_bit_for_bit():
    rng = np.random.default_rng(11)
    f32 = np.float32
    weighed = 0
    for _ in range(300):
        radius = rng.uniform(0.5, 3.5)
        sx = f32(rng.uniform(100, 1200))
        col0 = int(np.floor(sx - radius - 0.5) + 1)
        dy = f32(rng.uniform(-radius, radius))
        args = (col0, sx, dy, f32(1.0) / f32(radius * radius))
        expected, got = np.empty(LANES, f32), np.empty(LANES, f32)
        scalar_smooth_row(*args, expected)
        vector_smooth_row(*args, got)
        np.testing.assert_array_equal(got.view(np.int32), expected.view(np.int32))
        weighed += got.max() > 0
    assert weighed > 250  # rows across the footprint, not beside it
    # And as plain Python (no compiler), to within a float32 rounding.
    plain = np.empty(2 * LANES, f32)
    smooth_row(plain, LANES, *args)
    np.testing.assert_allclose(plain[LANES:], expected, rtol=0, atol=1e-6)


@pytest.mark.parametrize("count", [1, 3, 6, LANES])
@pytest.mark.parametrize("inv_soft", [4.0, 1e30])  # soft, and the hard test's HARD
def test_a_depth_row_matches_the_scalar_depth_test(count, inv_soft):
    rng = np.random.default_rng(count)
    f32 = np.float32
    profile = rng.uniform(0, 1, LANES).astype(f32)
    depth = np.full(20, np.inf, f32)
    depth[3:9] = rng.uniform(4.8, 5.2, 6)  # geometry around the particles' depth
    args = (profile, depth, 2, count, f32(0.37), f32(5.0), f32(inv_soft))
    expected, got = np.empty(LANES, f32), np.empty(LANES, f32)
    scalar_depth_row(*args, expected)
    vector_depth_row(*args, got)
    np.testing.assert_array_equal(got.view(np.int32), expected.view(np.int32))
    assert (got[count:] == 0).all()
    plain = np.empty(LANES, f32)
    depth_row(plain, *args[:1], 0, *args[1:])
    np.testing.assert_allclose(plain, expected, rtol=1e-6)


def test_a_depth_row_reads_no_depth_past_its_count():
    """The masked load: a row of 3 pixels ending at the last float before an unreadable
    page reads nothing past them (an 8-float load would fault)."""
    page = mmap.PAGESIZE
    memory = mmap.mmap(-1, 2 * page, prot=mmap.PROT_READ | mmap.PROT_WRITE)
    start = ctypes.addressof(ctypes.c_char.from_buffer(memory))
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.mprotect(ctypes.c_void_p(start + page), ctypes.c_size_t(page), 0):
        pytest.skip("mprotect is not available")
    depth = np.frombuffer(memory, np.float32, count=3, offset=page - 12)
    depth[:] = np.inf
    profile = np.ones(LANES, np.float32)
    got = np.empty(LANES, np.float32)
    one = np.float32(1.0)
    vector_depth_row(profile, depth, 0, 3, one, one, one, got)
    np.testing.assert_array_equal(got, [1, 1, 1, 0, 0, 0, 0, 0])
