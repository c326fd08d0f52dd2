"""Compiled kernels of :mod:`motes.render.bloom`: the light above a threshold, a pyramid of
2 × 2 means, separable Gaussian blurs, and bilinear doubling. Images are (height, width,
3) float32; every kernel runs rows in parallel and each row's work is independent, so
results do not depend on the thread count.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit import device, parallel_kernel


@device
def _reflect(i, n):
    """Index ``i`` reflected into ``[0, n)`` (``-1 -> 0``, ``n -> n - 1``)."""
    while i < 0 or i >= n:
        i = -1 - i if i < 0 else 2 * n - 1 - i
    return i


@parallel_kernel
def halve_above(color, threshold, dst):
    """``dst`` = means over ``color``'s 2 × 2 blocks of ``max(color - threshold, 0)`` (an
    odd last row or column held twice); returns whether any light was above."""
    height, width = color.shape[:2]
    h, w = dst.shape[:2]
    zero = np.float32(0.0)
    found = np.zeros(h, np.uint8)
    for y in prange(h):
        y0 = 2 * y
        y1 = min(y0 + 1, height - 1)
        some = zero
        for x in range(w):
            x0 = 2 * x
            x1 = min(x0 + 1, width - 1)
            for c in range(3):
                v = np.float32(0.25) * (
                    (
                        max(color[y0, x0, c] - threshold, zero)
                        + max(color[y0, x1, c] - threshold, zero)
                    )
                    + (
                        max(color[y1, x0, c] - threshold, zero)
                        + max(color[y1, x1, c] - threshold, zero)
                    )
                )
                dst[y, x, c] = v
                some = max(some, v)
        found[y] = some > zero
    return found.any()


@parallel_kernel
def halve(src, dst):
    """``dst`` = means of ``src``'s 2 × 2 blocks (an odd last row or column held twice)."""
    height, width = src.shape[:2]
    h, w = dst.shape[:2]
    for y in prange(h):
        y0 = 2 * y
        y1 = min(y0 + 1, height - 1)
        for x in range(w):
            x0 = 2 * x
            x1 = min(x0 + 1, width - 1)
            for c in range(3):
                dst[y, x, c] = np.float32(0.25) * (
                    (src[y0, x0, c] + src[y0, x1, c]) + (src[y1, x0, c] + src[y1, x1, c])
                )


@parallel_kernel
def blur_rows(src, weights, dst):
    """``dst`` = ``src`` convolved along x with ``weights`` (odd length, centred),
    reflected at the edges (``-1 -> 0``, ``w -> w - 1``)."""
    height, width = src.shape[:2]
    half = weights.size // 2
    for y in prange(height):
        row = src[y]
        for x in range(width):
            r = g = b = np.float32(0.0)
            if half <= x < width - half:  # inside: no reflection (the loop vectorises)
                for k in range(weights.size):
                    i = x + k - half
                    r += weights[k] * row[i, 0]
                    g += weights[k] * row[i, 1]
                    b += weights[k] * row[i, 2]
            else:
                for k in range(weights.size):
                    i = _reflect(x + k - half, width)
                    r += weights[k] * row[i, 0]
                    g += weights[k] * row[i, 1]
                    b += weights[k] * row[i, 2]
            dst[y, x, 0], dst[y, x, 1], dst[y, x, 2] = r, g, b


@parallel_kernel
def blur_columns(src, weights, dst):
    """As :func:`blur_rows`, along y."""
    height, width = src.shape[:2]
    half = weights.size // 2
    for y in prange(height):
        for x in range(width):
            dst[y, x, 0] = dst[y, x, 1] = dst[y, x, 2] = 0.0
        for k in range(weights.size):
            j = _reflect(y + k - half, height)
            w = weights[k]
            for x in range(width):
                for c in range(3):
                    dst[y, x, c] += w * src[j, x, c]


@parallel_kernel
def double_add(coarse, fine, scale, threshold):
    """``fine += scale · (up - max(fine - threshold, 0))`` with ``up`` = ``coarse``
    doubled bilinearly (between the coarse pixels' centres, held at the edges); ``fine``
    is at most twice ``coarse`` each way. A huge ``threshold``: ``fine += scale · up``."""
    h, w = coarse.shape[:2]
    height, width = fine.shape[:2]
    for y in prange(height):
        cy = min(max((y + 0.5) * 0.5 - 0.5, 0.0), h - 1.0)
        y0 = int(cy)
        y1 = min(y0 + 1, h - 1)
        ty = np.float32(cy - y0)
        for x in range(width):
            cx = min(max((x + 0.5) * 0.5 - 0.5, 0.0), w - 1.0)
            x0 = int(cx)
            x1 = min(x0 + 1, w - 1)
            tx = np.float32(cx - x0)
            for c in range(3):
                top = coarse[y0, x0, c] + tx * (coarse[y0, x1, c] - coarse[y0, x0, c])
                bottom = coarse[y1, x0, c] + tx * (coarse[y1, x1, c] - coarse[y1, x0, c])
                here = fine[y, x, c]
                fine[y, x, c] = here + scale * (
                    (top + ty * (bottom - top)) - max(here - threshold, np.float32(0.0))
                )
