"""Extinction policies beyond lifetime: dim, distant, or in a kill volume.

Lifetime is enforced inside the fused step kernel. Each policy here marks particles to
kill in the store's ``keep`` mask; the system compacts once for all of them. A kill
volume is a collider with ``response="kill"`` (see :mod:`motes.collide`).
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .. import _validate as check
from .._jit import block_bounds, block_count, parallel_kernel


@parallel_kernel
def _mark_dim(n, color, threshold, use_alpha_only, keep):
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            if use_alpha_only:
                value = color[3, i]
            else:
                # Rec. 709 luminance of the colour, weighted by its opacity.
                value = (
                    0.2126 * color[0, i] + 0.7152 * color[1, i] + 0.0722 * color[2, i]
                ) * color[3, i]
            if value < threshold:
                keep[i] = False


@parallel_kernel
def _mark_far(n, pos, cx, cy, cz, radius2, keep):
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            dx = pos[0, i] - cx
            dy = pos[1, i] - cy
            dz = pos[2, i] - cz
            if dx * dx + dy * dy + dz * dz > radius2:
                keep[i] = False


class Extinction:
    """Base class: ``mark(store)`` writes False into ``store.keep`` for particles to kill."""

    reads: tuple[str, ...] = ()

    def bind(self, store) -> None:
        store.require(*self.reads)

    def mark(self, store) -> None:
        raise TypeError(f"{type(self).__name__} is abstract")


class IntensityBelow(Extinction):
    """Kill particles whose intensity (luminance × alpha) falls below ``threshold``."""

    reads = ("color",)

    def __init__(self, threshold: float):
        self.threshold = check.non_negative("threshold", threshold)

    def mark(self, store) -> None:
        _mark_dim(store.count, store.raw("color"), self.threshold, False, store.keep)


class AlphaBelow(IntensityBelow):
    """Kill particles whose alpha falls below ``threshold`` (they have faded out)."""

    def mark(self, store) -> None:
        _mark_dim(store.count, store.raw("color"), self.threshold, True, store.keep)


class DistanceFrom(Extinction):
    """Kill particles farther than ``distance`` [m] from ``center``."""

    reads = ("position",)

    def __init__(self, center, distance: float):
        self.center = check.vector("center", center)
        self.distance = check.positive("distance", distance)

    def mark(self, store) -> None:
        c = self.center
        _mark_far(
            store.count,
            store.raw("position"),
            c[0],
            c[1],
            c[2],
            np.float64(self.distance) ** 2,
            store.keep,
        )
