"""Compiled kernels that pack a system's particles into a viewer frame: a million
particles in two passes over blocks, on every core (NumPy took 110 ms a frame at 10⁶,
twice the fire's step).

Every ``stride``-th particle is taken (``m = ceil(n / stride)`` of them); the first
pass counts the particles each block shows in each size class (a particle's class is
the number of ``edges`` its radius reaches) and their bounding box, the second writes
the shown ones' offsets from the box's centre and their 8-bit sRGB colours, the classes
one after the other and within a class each block at the place the counts before it
give, so the output keeps the particles' order within a class and does not depend on
the thread count.

``mode`` says how colours are made: :data:`WHITE` (no colour field), :data:`OPAQUE`
(the colour as it is) or :data:`LIGHT` (additive: the hue at a brightness falling with
the light only down to half, particles giving less than ``dim`` left out; see
:func:`motes.view.packet._points_of`).
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit import BLOCK, block_count, device, parallel_kernel

WHITE, OPAQUE, LIGHT = 0, 1, 2

#: Start of a block's bounding box (beyond any position).
FAR = 1e300

#: Entries of the linear-to-sRGB table: a linear value v in [0, 1] is encoded as
#: ``SRGB8[round(v · (SRGB_LEVELS - 1))]``, within one 8-bit level of the exact encoding
#: (the steepest part of the curve, near 0, moves 0.8 levels a step).
SRGB_LEVELS = 4096


def srgb8_table() -> np.ndarray:
    """(SRGB_LEVELS,) uint8: 8-bit sRGB of evenly spaced linear values 0 … 1."""
    from ..color import linear_to_srgb

    linear = np.linspace(0.0, 1.0, SRGB_LEVELS)
    return np.round(linear_to_srgb(linear) * 255.0).astype(np.uint8)


@device
def _light(color, p, intensity):
    """Colour × alpha × intensity of particle ``p``, and its brightest channel."""
    scale = color[3, p] * intensity
    r, g, b = color[0, p] * scale, color[1, p] * scale, color[2, p] * scale
    return r, g, b, max(r, max(g, b))


@device
def _size_class(radius, edges, p):
    """How many of the ascending ``edges`` [m] particle ``p``'s radius reaches."""
    r = radius[p]
    k = 0
    for e in range(edges.shape[0]):
        if r >= edges[e]:
            k += 1
    return k


@device
def _shown(color, p, mode, intensity, dim):
    if mode != LIGHT:
        return True
    return _light(color, p, intensity)[3] >= dim


@parallel_kernel
def brightest(color, stride, intensity, peaks):
    """``peaks[b]``: the brightest channel of colour × alpha × intensity over block ``b``
    of the taken particles (0 for none)."""
    m = (color.shape[1] + stride - 1) // stride
    for b in prange(block_count(m)):
        peak = 0.0
        for q in range(b * BLOCK, min(m, (b + 1) * BLOCK)):
            peak = max(peak, _light(color, q * stride, intensity)[3])
        peaks[b] = peak


@parallel_kernel
def count_shown(positions, color, radius, edges, stride, mode, intensity, dim, counts, low,
                high):  # fmt: skip
    """Per block of the taken particles: ``counts[b, k]`` shown of size class ``k``
    (``counts`` (blocks, len(edges) + 1)), their box ``low[b]``, ``high[b]`` (3,)
    (±:data:`FAR` for an empty block)."""
    m = (positions.shape[1] + stride - 1) // stride
    for b in prange(block_count(m)):
        start, stop = b * BLOCK, min(m, (b + 1) * BLOCK)
        lo = np.full(3, FAR)  # finite: the kernels' fast math assumes no infinities
        hi = np.full(3, -FAR)
        for q in range(start, stop):
            p = q * stride
            if _shown(color, p, mode, intensity, dim):
                counts[b, _size_class(radius, edges, p)] += 1
                for c in range(3):
                    x = np.float64(positions[c, p])
                    lo[c] = min(lo[c], x)
                    hi[c] = max(hi[c], x)
        low[b] = lo
        high[b] = hi


@parallel_kernel
def pack(positions, color, radius, edges, stride, mode, intensity, dim, first, origin, table,
         offsets, rgb):  # fmt: skip
    """The shown particles' ``offsets`` (k, 3) float32 from ``origin`` (3,) and ``rgb``
    (k, 3) uint8, block ``b``'s particles of size class ``c`` from row ``first[b, c]``;
    ``table``: :func:`srgb8_table`."""
    m = (positions.shape[1] + stride - 1) // stride
    top = table.shape[0] - 1
    for b in prange(block_count(m)):
        start, stop = b * BLOCK, min(m, (b + 1) * BLOCK)
        rows = first[b].copy()
        for q in range(start, stop):
            p = q * stride
            if not _shown(color, p, mode, intensity, dim):
                continue
            k = _size_class(radius, edges, p)
            row = rows[k]
            rows[k] += 1
            for c in range(3):
                offsets[row, c] = np.float64(positions[c, p]) - origin[c]
            if mode == WHITE:
                r = g = v = 1.0
            elif mode == OPAQUE:
                r, g, v = color[0, p], color[1, p], color[2, p]
            else:
                r, g, v, peak = _light(color, p, intensity)
                brightness = (0.5 + 0.5 * min(peak, 1.0)) / peak
                r, g, v = r * brightness, g * brightness, v * brightness
            rgb[row, 0] = table[int(min(max(r, 0.0), 1.0) * top + 0.5)]
            rgb[row, 1] = table[int(min(max(g, 0.0), 1.0) * top + 0.5)]
            rgb[row, 2] = table[int(min(max(v, 0.0), 1.0) * top + 0.5)]
