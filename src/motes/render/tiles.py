"""Screen tiles: bin screen-space boxes so tiles can be drawn in parallel without races.

Rasterising many small items (sprites, triangles, line segments) into one image in
parallel would race on shared pixels. Instead the image is cut into square tiles of
:data:`TILE` pixels; each item is listed in every tile its pixel box overlaps, and each
tile is drawn by one thread, visiting its items in input order. Output is therefore
deterministic and independent of the thread count, and alpha-over blending keeps the
caller's (sorted) order.

Binning runs in three compiled passes over fixed chunks of items: count per
(chunk, tile), an exclusive scan over chunks within each tile, and a fill where each
chunk writes at its own offsets, which keeps input order inside every tile.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import parallel_kernel, serial_kernel

#: Tile side [px].
TILE = 32
#: Items per binning chunk (one parallel work item).
CHUNK = 16384


def interleaved(count: int, stride: int = 8) -> np.ndarray:
    """``0 .. count - 1`` interleaved (int64): ``0, stride, 2 stride, ..., 1, 1 + stride,
    ...``, the order in which to visit tiles (or rows) in a ``prange``.

    ``prange`` gives each thread a contiguous run of iterations; in row-major order that
    would be a band of the image, and the work is rarely spread evenly over bands (a
    ground fills the bottom half, a flame the middle). Interleaved, each thread's share
    spreads over the whole image. The order changes which thread draws a tile, never
    what is drawn.
    """
    return np.concatenate([np.arange(s, count, stride) for s in range(stride)]).astype(np.int64)


class TileBins:
    """Items listed per tile: ``items[starts[t]:starts[t + 1]]`` are tile ``t``'s, in order.

    Tiles are numbered row-major: tile ``t`` covers columns ``(t % tiles_x) * TILE`` onward
    and rows ``(t // tiles_x) * TILE`` onward. ``order`` lists the tiles interleaved
    (:func:`interleaved`), for the kernels that draw them in parallel.
    """

    def __init__(self, starts, items, tiles_x, tiles_y):
        self.starts = starts
        self.items = items
        self.tiles_x = tiles_x
        self.tiles_y = tiles_y

    @property
    def order(self) -> np.ndarray:
        return interleaved(self.tiles_x * self.tiles_y)


@parallel_kernel
def _count(x0, y0, x1, y1, tiles_x, tile, counts):
    n = x0.shape[0]
    chunks = counts.shape[0]
    for c in numba.prange(chunks):
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            if x1[i] < x0[i] or y1[i] < y0[i]:
                continue
            for ty in range(y0[i] // tile, y1[i] // tile + 1):
                for tx in range(x0[i] // tile, x1[i] // tile + 1):
                    counts[c, ty * tiles_x + tx] += 1


@serial_kernel
def scan_counts(counts, starts):
    """Per-(chunk, list) counts -> write offsets (in place); ``starts[t]`` = list t's first slot.

    List-major, chunk-minor: list ``t``'s slots hold chunk 0's items, then chunk 1's...
    which, with each chunk filled in order, keeps the caller's order within every list.
    """
    chunks, tiles = counts.shape
    total = 0
    for t in range(tiles):
        starts[t] = total
        for c in range(chunks):
            k = counts[c, t]
            counts[c, t] = total
            total += k
    starts[tiles] = total


@parallel_kernel
def _fill(x0, y0, x1, y1, tiles_x, tile, offsets, items):
    n = x0.shape[0]
    chunks = offsets.shape[0]
    for c in numba.prange(chunks):
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            if x1[i] < x0[i] or y1[i] < y0[i]:
                continue
            for ty in range(y0[i] // tile, y1[i] // tile + 1):
                for tx in range(x0[i] // tile, x1[i] // tile + 1):
                    t = ty * tiles_x + tx
                    items[offsets[c, t]] = i
                    offsets[c, t] += 1


def bin_boxes(x0, y0, x1, y1, width: int, height: int) -> TileBins:
    """List items per tile from their inclusive pixel boxes.

    Parameters
    ----------
    x0, y0, x1, y1 : (n,) int32
        Inclusive column and row range of each item, already clipped to the image
        ``[0, width) × [0, height)``. An item with ``x1 < x0`` or ``y1 < y0`` is skipped.
    width, height : int
        Image size [px].
    """
    tiles_x = (width + TILE - 1) // TILE
    tiles_y = (height + TILE - 1) // TILE
    chunks = max(1, (len(x0) + CHUNK - 1) // CHUNK)
    counts = np.zeros((chunks, tiles_x * tiles_y), dtype=np.int64)
    _count(x0, y0, x1, y1, tiles_x, TILE, counts)
    starts = np.empty(tiles_x * tiles_y + 1, dtype=np.int64)
    scan_counts(counts, starts)
    items = np.empty(starts[-1], dtype=np.int32)
    _fill(x0, y0, x1, y1, tiles_x, TILE, counts, items)
    return TileBins(starts, items, tiles_x, tiles_y)
