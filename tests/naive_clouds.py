"""Slow, obviously-correct NumPy twins of the cloud kernels (:mod:`motes.clouds.kernels`).

- :func:`splat`: every particle's kernel evaluated on every cell centre of a grid padded
  wide enough to hold each particle whole, normalised by its sum there, then cropped to
  the real grid: no spans, no bins, no planes.
- :func:`worley`: Worley's F1 by brute force over the 125 cells around a point (the
  kernel searches 27).
- :func:`cumulus`: the cloud density's equations, written out in NumPy on the kernel's
  own noise functions (called one cell at a time from Python).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from motes.clouds import kernels
from motes.clouds.splat import MIN_KERNEL_CELLS


def axis_weight(u: np.ndarray) -> np.ndarray:
    """The splat kernel's factor along one axis at ``u`` = offset / R."""
    s = kernels.SIGMAS
    floor = math.exp(-0.5 * s * s)
    w = (np.exp(-0.5 * s * s * u * u) - floor) / (1.0 - floor)
    return np.where(np.abs(u) < 1.0, w, 0.0)


def splat(positions, radius, density, resolution, cell, origin) -> np.ndarray:
    """(nz, ny, nx) float64 grid of the particles (3, n) splatted as documented."""
    nx, ny, nz = resolution
    positions = np.asarray(positions, dtype=np.float64)
    radius = np.broadcast_to(np.asarray(radius, dtype=np.float64), positions.shape[1])
    density = np.broadcast_to(np.asarray(density, dtype=np.float64), positions.shape[1])
    kernel = np.maximum(radius, MIN_KERNEL_CELLS * cell)
    out = np.zeros((nz, ny, nx))
    for p in range(positions.shape[1]):
        mass = density[p] * 4.0 / 3.0 * math.pi * radius[p] ** 3
        local = positions[:, p] - np.asarray(origin, dtype=np.float64)
        # a box of cells around the particle wide enough to hold its whole kernel
        lo = np.floor(local / cell).astype(int) - math.ceil(kernel[p] / cell) - 1
        hi = np.floor(local / cell).astype(int) + math.ceil(kernel[p] / cell) + 2
        axes = [np.arange(lo[a], hi[a]) for a in range(3)]
        centres = [((m + 0.5) * cell - local[a]) / kernel[p] for a, m in enumerate(axes)]
        wx, wy, wz = (axis_weight(c) for c in centres)
        w = wz[:, None, None] * wy[None, :, None] * wx[None, None, :]
        if mass == 0.0 or w.sum() == 0.0:
            continue
        w *= mass / (cell**3 * w.sum())
        inside = [(m >= 0) & (m < n) for m, n in zip(axes, (nx, ny, nz), strict=True)]
        out[np.ix_(axes[2][inside[2]], axes[1][inside[1]], axes[0][inside[0]])] += w[
            np.ix_(inside[2], inside[1], inside[0])
        ]
    return out


def worley(x: float, y: float, z: float, key) -> float:
    """Distance to the nearest feature point among the 125 cells around ``(x, y, z)``."""
    cx, cy, cz = math.floor(x), math.floor(y), math.floor(z)
    best = math.inf
    for dx, dy, dz in itertools.product(range(-2, 3), repeat=3):
        h = int(kernels._cell_hash(cx + dx, cy + dy, cz + dz, np.uint64(key)))
        fx = cx + dx + ((h & 1023) + 0.5) / 1024
        fy = cy + dy + (((h >> 10) & 1023) + 0.5) / 1024
        fz = cz + dz + (((h >> 20) & 1023) + 0.5) / 1024
        best = min(best, math.dist((x, y, z), (fx, fy, fz)))
    return best


def _smoothstep(a, b, t):
    s = np.clip((t - a) / (b - a), 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def cumulus(resolution, cell, *, origin, base, top, scale, detail_scale, coverage, erosion,
            density, octaves, detail_octaves, offset, detail_offset, hash_pairs, ramp_pairs,
            key) -> np.ndarray:  # fmt: skip
    """(nz, ny, nx) density from the equations of :func:`motes.clouds.kernels.cloud_density`."""
    nx, ny, nz = resolution
    k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    x = origin[0] + (i + 0.5) * cell
    y = origin[1] + (j + 0.5) * cell
    z = origin[2] + (k + 0.5) * cell
    h = (y - base) / (top - base)
    g = _smoothstep(0.0, kernels.BOTTOM, h) * (1.0 - _smoothstep(1.0 - kernels.TOP, 1.0, h))
    g = np.where((h > 0.0) & (h < 1.0), g, 0.0)
    fbm = np.vectorize(lambda a, b, c: kernels._fbm(hash_pairs, ramp_pairs, a, b, c, octaves))
    billows = np.vectorize(lambda a, b, c: kernels._billows(a, b, c, key, detail_octaves))
    b = np.clip(
        0.5
        + kernels.CONTRAST
        * fbm(
            (x + offset[0]) / scale,
            (y + offset[1]) / (kernels.STRETCH * scale),
            (z + offset[2]) / scale,
        ),
        0.0,
        1.0,
    )
    d = np.maximum(b * g - (1.0 - coverage), 0.0)
    shift = np.add(offset, detail_offset)
    detail = billows(
        (x + shift[0]) / detail_scale, (y + shift[1]) / detail_scale, (z + shift[2]) / detail_scale
    )
    e = erosion * detail
    d = np.where(d > 0.0, np.maximum((d - e) / (1.0 - e), 0.0), 0.0)
    return density * np.minimum(h / kernels.BASE_SOFTNESS, 1.0) * d
