"""Morton codes and a stable radix sort: the order both spatial trees start from.

A Morton code interleaves the bits of the three quantised coordinates (x lowest), 21 bits
each, 63 bits per point (Morton 1966; as used for trees by Warren & Salmon 1993): points
close in space are close in this order. The radix sort takes stable least-significant-
digit passes of 8 bits, each a counting sort (per-block histograms in parallel, one scan,
a parallel scatter); passes whose digit is the same for every key are skipped. A stable
sort has one result, so the order does not depend on the thread count.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import parallel_kernel, serial_kernel

#: Bits per coordinate in a Morton code (3 x 21 = 63 bits: a positive int64).
BITS = 21
#: Keys per block of the radix sort's histograms and scatter.
SORT_BLOCK = 1 << 16
_RADIX = 8
_DIGITS = 1 << _RADIX


@numba.njit(inline="always")
def _spread(v):
    """The 21 low bits of ``v`` moved to bits 0, 3, 6, ... 60."""
    v &= 0x1FFFFF
    v = (v | (v << 32)) & 0x1F00000000FFFF
    v = (v | (v << 16)) & 0x1F0000FF0000FF
    v = (v | (v << 8)) & 0x100F00F00F00F00F
    v = (v | (v << 4)) & 0x10C30C30C30C30C3
    v = (v | (v << 2)) & 0x1249249249249249
    return v


@parallel_kernel
def morton_codes(x, y, z, origin, scale, out):
    """``out[i]``: Morton code of point ``i`` quantised as ``(p - origin) * scale``.

    ``scale`` maps the bounding cube onto ``[0, 2^21)``; coordinates are clamped into it.
    """
    n = x.shape[0]
    top = (1 << BITS) - 1
    for i in numba.prange(n):
        qx = min(max(np.int64((x[i] - origin[0]) * scale), 0), top)
        qy = min(max(np.int64((y[i] - origin[1]) * scale), 0), top)
        qz = min(max(np.int64((z[i] - origin[2]) * scale), 0), top)
        out[i] = _spread(qx) | (_spread(qy) << 1) | (_spread(qz) << 2)


@parallel_kernel
def _histograms(keys, shift, counts):
    n = keys.shape[0]
    for block in numba.prange(counts.shape[0]):
        row = counts[block]
        row[:] = 0
        for i in range(block * SORT_BLOCK, min(n, (block + 1) * SORT_BLOCK)):
            row[(keys[i] >> shift) & (_DIGITS - 1)] += 1


@serial_kernel
def _offsets(counts, n):
    """Exclusive scan, digit-major then block; returns whether the pass can be skipped."""
    total = 0
    for d in range(_DIGITS):
        for block in range(counts.shape[0]):
            c = counts[block, d]
            counts[block, d] = total
            total += c
            if c == n:
                return True
    return False


@parallel_kernel
def _scatter(keys, index, shift, offsets, keys_out, index_out):
    n = keys.shape[0]
    for block in numba.prange(offsets.shape[0]):
        row = offsets[block]
        for i in range(block * SORT_BLOCK, min(n, (block + 1) * SORT_BLOCK)):
            d = (keys[i] >> shift) & (_DIGITS - 1)
            slot = row[d]
            row[d] = slot + 1
            keys_out[slot] = keys[i]
            index_out[slot] = index[i]


def radix_sort(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stable sort of non-negative int64 ``keys`` (n,): ``(sorted keys, order)``.

    ``order[s]`` is the index of the key in slot ``s`` (int64).
    """
    n = keys.shape[0]
    keys = np.array(keys, dtype=np.int64)  # a copy: the passes reuse it
    index = np.arange(n, dtype=np.int64)
    if n < 2:
        return keys, index
    counts = np.empty(((n + SORT_BLOCK - 1) // SORT_BLOCK, _DIGITS), np.int64)
    keys_out, index_out = np.empty_like(keys), np.empty_like(index)
    top = int(keys.max()).bit_length()
    for shift in range(0, top, _RADIX):
        _histograms(keys, shift, counts)
        if _offsets(counts, n):
            continue
        _scatter(keys, index, shift, counts, keys_out, index_out)
        keys, keys_out = keys_out, keys
        index, index_out = index_out, index
    return keys, index
