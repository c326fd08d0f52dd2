"""The fast path of additive drawing: small footprints sorted by tile, drawn in four phases.

Most particles of an additive effect cover a few pixels. Listing each in every tile its
box touches (:func:`motes.render.tiles.bin_boxes`), copying its record per listing and
clipping it to each tile costs more than drawing it. Instead, the projection gives every
small footprint to one tile, the one holding the centre of its box, provided the box
reaches at most ``MARGIN`` (half a tile) beyond that tile. Then:

1. :func:`motes.render.tiles.scan_counts` turns the per-(chunk, list) counts into write
   offsets; each tile has :data:`LISTS` lists: footprints that fit a 3 × 3 window, a
   4 × 4 one, a 6 × 6 one, and larger;
2. :func:`scatter_records` copies the records into list order (a counting sort, stable:
   each list keeps the caller's order);
3. :func:`splat_kernel` draws the tiles in four phases by the parity of their column and
   row. Tiles of one phase are two tiles apart, so their footprints, which reach half a
   tile beyond them, never share a pixel: each phase runs in parallel over its tiles.

Each pixel therefore receives its contributions in a fixed order (phase, then tile list
order), whatever the number of threads. A particle is drawn whole by one thread, so the
drawing pass also normalises it: its record holds ``rgb · a · intensity · energy`` and
each fragment gets ``weight / sum of the footprint's sampled weights``.
"""

from __future__ import annotations

from functools import cache

import numba
import numpy as np

from .._jit import called, device, fma, parallel_kernel, serial_kernel
from .._vector import LANES, STACK_FLOATS, add_rgb_row, depth_row, smooth_row, stack_floats
from ._footprint import (
    BLUE,
    DEPTH,
    EXACT_AREA,
    GREEN,
    HALF,
    ONE,
    POINT,
    RADIUS,
    RED,
    SMOOTH,
    SX,
    SY,
    TAIL_DEPTH,
    TAIL_X,
    TAIL_Y,
    TWO,
    ZERO,
    depth_factor,
    footprint_bounds,
    footprint_extent,
    footprint_sum,
    profile_area,
    profile_weight,
    segment_offset,
)
from .tiles import CHUNK, TILE

#: Window sizes [px] of the unrolled drawing loops, one list per tile each (footprints
#: whose box fits the window), and 0: the list of larger footprints. Sprites up to 3, 4
#: and 6 px across fit the windows. The 6 px window drew the 117,000 sprites 4-6 px
#: across of ``benchmarks.interactive``'s fire in 6.1 ms where the general loop took 10.4
#: (a 5 px window beside it saved 0.2 ms more, for another kernel to compile).
WINDOWS = (3, 4, 6, 0)
LISTS = len(WINDOWS)
# A window's row is one vector of weights, and its rows share one stack buffer.
assert max(WINDOWS) <= LANES and max(WINDOWS) * LANES <= STACK_FLOATS


@parallel_kernel
def scatter_records(record, tile_of, offsets, out):
    """Copy each fast-path record to its slot: ``out[offsets[chunk, list]++] = record[i]``.

    ``record`` and ``out`` are the float32 records viewed as int64 (two floats a copy:
    1M records 7-9 -> 5-6 ms on one thread); unsigned indices skip Numba's
    negative-index wraparound.
    """
    n = record.shape[0]
    columns = record.shape[1]
    for chunk in numba.prange(offsets.shape[0]):
        row = np.uint64(chunk)
        for i in range(np.uint64(chunk * CHUNK), np.uint64(min(n, (chunk + 1) * CHUNK))):
            t = tile_of[i]
            if t < 0:
                continue
            s = np.uint64(offsets[row, np.uint64(t)])
            offsets[row, np.uint64(t)] = s + np.uint64(1)
            for c in range(columns):
                out[s, c] = record[i, c]


@cache
def splat_kernel(kind: int, streak: bool, window: int):
    """Compile (or fetch) a fast drawing pass for one footprint kind (not textures).

    The returned kernel is ``kernel(records, starts, tiles, inv_soft, texture, depth,
    color, nearest)``: for every tile ``t`` in ``tiles`` (tiles of one parity phase), in
    parallel, it draws the particles of one of the tile's lists, each whole, clipped to
    the image only: list ``b = LISTS * t + l`` is ``records[starts[b]:starts[b + 1]]``,
    where ``l`` is the index of ``window`` in :data:`WINDOWS` (0 = footprints of any
    size). ``nearest`` is :func:`tile_nearest`'s (tiles,) float32 nearest opaque depth
    within reach of each tile. The other arguments are as in
    :func:`.sprite_kernels.draw_kernel` (``texture`` is a dummy); ``color`` and
    ``depth`` must be C-contiguous.

    Each list has its own kernel: with the unrolled and the general loop in one kernel,
    the compiler made the unrolled one 1.8x slower (measured on 1M 3 px sprites).
    """
    which = WINDOWS.index(window)

    @parallel_kernel
    def kernel(records, starts, tiles, inv_soft, texture, depth, color, nearest):
        height, width = depth.shape
        inv_soft = np.float32(inv_soft)
        pixels = depth.reshape(-1)
        rgb = color.reshape(-1)
        for j in numba.prange(tiles.shape[0]):
            b = LISTS * tiles[j] + which
            if window and kind == SMOOTH and not streak:
                _smooth_pairs(
                    records, starts[b], starts[b + 1], window, width, height, inv_soft,
                    nearest[tiles[j]], texture, pixels, rgb,
                )  # fmt: skip
                continue
            for s in range(starts[b], starts[b + 1]):
                if window:
                    _splat_window(
                        records, s, kind, streak, window, width, height, inv_soft, texture,
                        pixels, rgb,
                    )  # fmt: skip
                else:
                    _splat_any(
                        records, s, kind, streak, width, height, inv_soft, texture,
                        pixels, rgb,
                    )  # fmt: skip

    return kernel


@device
def _add(rgb, pixels, pixel, w, d, inv_soft, red, green, blue):
    """Depth-test (or soft-fade) one fragment of weight ``w`` at depth ``d`` and add it."""
    w *= depth_factor(pixels[pixel], d, inv_soft)
    q = pixel * np.uint64(3)
    rgb[q] = fma(red, w, rgb[q])
    rgb[q + np.uint64(1)] = fma(green, w, rgb[q + np.uint64(1)])
    rgb[q + np.uint64(2)] = fma(blue, w, rgb[q + np.uint64(2)])


@device
def _unpack(records, s, streak):
    """Record ``s``: head, radius, colour, tail, and the segment terms both splats use."""
    sx = records[s, SX]
    sy = records[s, SY]
    rf = records[s, RADIUS]
    head_depth = records[s, DEPTH]
    tx, ty, tail_depth = sx, sy, head_depth
    if streak:
        tx = records[s, TAIL_X]
        ty = records[s, TAIL_Y]
        tail_depth = records[s, TAIL_DEPTH]
    segx, segy = sx - tx, sy - ty
    seg2 = segx * segx + segy * segy
    inv_seg2 = ONE / seg2 if seg2 > ZERO else ZERO
    return (
        sx, sy, rf, records[s, RED], records[s, GREEN], records[s, BLUE], tx, ty, tail_depth,
        segx, segy, inv_seg2, ONE / (rf * rf), head_depth - tail_depth,
    )  # fmt: skip


@device
def _splat_window(records, s, kind, streak, window, width, height, inv_soft, texture, pixels, rgb):
    """Normalise and add a footprint whose pixel box fits a ``window`` × ``window`` window.

    The window starts at the box's first row and column; its pixels past the box weigh
    0 (they lie beyond the footprint's reach), and the projection checked that the whole
    window stays within the owning tile's reach. Fixed trip counts unroll into
    straight-line code without masks; a window that crosses the image's edge is drawn by
    the general loop (:func:`_splat_any`, clipped to the image). Flat unsigned pixel
    indices: signed ones make Numba add a negative-index wraparound to every access.
    """
    sx, sy, rf, red, green, blue, tx, ty, tail_depth, segx, segy, inv_seg2, inv_rf2, rise = _unpack(
        records, s, streak
    )
    c0, r0, _, _ = footprint_bounds(kind, sx, sy, tx, ty, rf)
    col0, row0 = int(c0), int(r0)
    if not ((col0 >= 0) & (row0 >= 0) & (col0 + window <= width) & (row0 + window <= height)):
        # A window across the image's edge (few sprites): the general loop, clipped.
        _splat_any(records, s, kind, streak, width, height, inv_soft, texture, pixels, rgb)
        return
    stride = np.uint64(width)
    weights = stack_floats()
    scale = ONE  # the bilinear tent's weights sum to 1 exactly
    if kind != POINT or streak:
        total = ZERO
        for dr in range(window):
            row_total = ZERO
            for dc in range(window):
                dx, dy, _ = segment_offset(
                    streak, np.float32(col0 + dc) + HALF, np.float32(row0 + dr) + HALF, sx, sy,
                    segx, segy, inv_seg2,
                )  # fmt: skip
                row_total += profile_weight(kind, dx, dy, rf, inv_rf2)
            total += row_total
        scale = ONE / total if total > ZERO else ZERO
    # A row's weights go to a stack buffer, and the row's RGB floats are brightened four
    # at a time (add_rgb_row: the same fused multiply-adds, bit for bit).
    for dr in range(window):
        row = row0 + dr
        base = np.uint64(row) * stride
        for dc in range(window):
            col = col0 + dc
            dx, dy, t = segment_offset(
                streak, np.float32(col) + HALF, np.float32(row) + HALF, sx, sy, segx,
                segy, inv_seg2,
            )  # fmt: skip
            w = profile_weight(kind, dx, dy, rf, inv_rf2) * scale
            d = tail_depth + t * rise
            weights[dc] = w * depth_factor(pixels[base + np.uint64(col)], d, inv_soft)
        first = (base + np.uint64(col0)) * np.uint64(3)
        add_rgb_row(rgb, first, weights, window, red, green, blue)


@device
def _smooth_pairs(
    records, first, end, window, width, height, inv_soft, nearest, texture, pixels, rgb
):
    """Draw smooth sprites ``first..end`` of a list (no streaks) in a ``window`` × ``window``
    window, two at a time.

    A sprite's work is one chain of dependent steps (its profile, their sum, its
    reciprocal, the weights, the pixels), too long for the processor to overlap with the
    next sprite's on its own. Both profiles are computed before either sprite is drawn,
    which gives it two chains to interleave (1M 3-4 px sprites on one thread: about 10 %
    faster); the sprites are still drawn in list order, so the pixels get the same bits.
    """
    stride = np.uint64(width)
    profile_a = stack_floats()
    profile_b = stack_floats()
    weights = stack_floats()
    # Two inlined copies of each step, not three (a separate last sprite): less to compile.
    for s in range(first, end, 2):
        pair = s + 1 < end
        a = _smooth_profile(records, s, window, width, height, profile_a)
        b = _smooth_profile(records, s + pair, window, width, height, profile_b)
        _smooth_add(records, s, a, window, profile_a, weights, stride, width, height, inv_soft,
                    nearest, texture, pixels, rgb)  # fmt: skip
        if pair:
            _smooth_add(records, s + 1, b, window, profile_b, weights, stride, width, height,
                        inv_soft, nearest, texture, pixels, rgb)  # fmt: skip


@device
def _smooth_profile(records, s, window, width, height, profile):
    """Sprite ``s``'s smooth profile over its window into ``profile`` (one row of
    :data:`LANES` per window row, eight pixels at a time by :func:`smooth_row`), and
    ``(inside, col0, row0, scale, depth, red, green, blue)``: whether the window lies
    inside the image, its first column and row, the normalisation ``1 / sum of the
    window's weights``, the sprite's depth and colour."""
    sx, sy, rf, red, green, blue, tx, ty, tail_depth, _, _, _, inv_rf2, rise = _unpack(
        records, s, False
    )
    c0, r0, _, _ = footprint_bounds(SMOOTH, sx, sy, tx, ty, rf)
    col0, row0 = int(c0), int(r0)
    inside = (col0 >= 0) & (row0 >= 0) & (col0 + window <= width) & (row0 + window <= height)
    total = ZERO
    for dr in range(window):
        dy = (np.float32(row0 + dr) + HALF) - sy
        smooth_row(profile, dr * LANES, col0, sx, dy, inv_rf2)
        row_total = ZERO
        for dc in range(window):
            row_total += profile[dr * LANES + dc]
        total += row_total
    scale = ONE / total if total > ZERO else ZERO
    return inside, col0, row0, scale, tail_depth + ONE * rise, red, green, blue


@device
def _smooth_add(records, s, prepared, window, profile, weights, stride, width, height, inv_soft,
                nearest, texture, pixels, rgb):  # fmt: skip
    """Add sprite ``s`` from its :func:`_smooth_profile`; a window across the image's edge
    goes to the general loop (:func:`_splat_any`, clipped to the image).

    Where no opaque pixel within the tile's reach is nearer than the sprite by the
    softness (``nearest``: see :func:`tile_nearest`), every depth factor is 1 and the
    depths are not read (the same weights: ``w · 1 = w``)."""
    inside, col0, row0, scale, d, red, green, blue = prepared
    if not inside:
        _splat_any(records, s, SMOOTH, False, width, height, inv_soft, texture, pixels, rgb)
        return
    clear = (nearest - d) * inv_soft >= ONE
    for dr in range(window):
        pixel = np.uint64(row0 + dr) * stride + np.uint64(col0)
        if clear:
            for dc in range(window):
                weights[dc] = profile[dr * LANES + dc] * scale
        else:
            depth_row(weights, profile, dr * LANES, pixels, pixel, window, scale, d, inv_soft)
        add_rgb_row(rgb, pixel * np.uint64(3), weights, window, red, green, blue)


@serial_kernel
def tile_nearest(depth, out):
    """The nearest opaque depth [m] each tile's fast-path footprints can meet.

    ``depth``: (h, w) float32 opaque depth (``inf`` where there is none); ``out``:
    (tiles_y, tiles_x) float32, the least depth over each tile and its eight neighbours
    (a fast-path footprint reaches at most half a tile beyond its tile). A sprite nearer
    than that by the softness has a depth factor of 1 on every pixel it touches. Serial:
    0.4 ms at 1280 x 720, and a parallel kernel compiles a second longer.
    """
    height, width = depth.shape
    tiles_y, tiles_x = out.shape
    own = np.empty((tiles_y, tiles_x), np.float32)
    # Started from a pixel of each tile, not from an infinite constant: the kernels'
    # fast-math flags let the compiler assume that no value is infinite.
    for ty in range(tiles_y):
        for tx in range(tiles_x):
            own[ty, tx] = depth[ty * TILE, tx * TILE]
    for row in range(height):
        ty = row // TILE
        for tx in range(tiles_x):
            least = own[ty, tx]
            for col in range(tx * TILE, min((tx + 1) * TILE, width)):
                least = min(least, depth[row, col])
            own[ty, tx] = least
    for ty in range(tiles_y):
        for tx in range(tiles_x):
            least = own[ty, tx]
            for y in range(max(ty - 1, 0), min(ty + 2, tiles_y)):
                for x in range(max(tx - 1, 0), min(tx + 2, tiles_x)):
                    least = min(least, own[y, x])
            out[ty, tx] = least


@called
def _splat_any(records, s, kind, streak, width, height, inv_soft, texture, pixels, rgb):
    """Normalise and add a footprint of any size (clipped to the image)."""
    sx, sy, rf, red, green, blue, tx, ty, tail_depth, segx, segy, inv_seg2, inv_rf2, rise = _unpack(
        records, s, streak
    )
    c0, r0, c1, r1 = footprint_bounds(kind, sx, sy, tx, ty, rf)
    stride = np.uint64(width)
    e = footprint_extent(kind, rf)
    if kind == POINT and not streak:
        total = 1.0
    elif (abs(segx) + TWO * e) * (abs(segy) + TWO * e) <= EXACT_AREA:
        total = footprint_sum(
            kind, streak, sx, sy, segx, segy, inv_seg2, rf, ONE, ZERO, texture, c0, r0, c1, r1
        )
    else:
        total = profile_area(kind, rf, np.sqrt(float(segx * segx + segy * segy)), 0.0)
    scale = np.float32(1.0 / total) if total > 0 else ZERO
    for row in range(max(int(r0), 0), min(int(r1), height - 1) + 1):
        py = np.float32(row) + HALF
        base = np.uint64(row) * stride
        for col in range(max(int(c0), 0), min(int(c1), width - 1) + 1):
            dx, dy, t = segment_offset(
                streak, np.float32(col) + HALF, py, sx, sy, segx, segy, inv_seg2
            )
            w = profile_weight(kind, dx, dy, rf, inv_rf2)
            if w > ZERO:
                _add(
                    rgb, pixels, base + np.uint64(col), w * scale, tail_depth + t * rise,
                    inv_soft, red, green, blue,
                )  # fmt: skip
