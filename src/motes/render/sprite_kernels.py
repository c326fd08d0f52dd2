"""Projection and the general drawing path of the particle rasteriser.

Launchers live in :mod:`motes.render.sprites`. Every pass is free of write races:

1. :func:`project_kernel`, parallel over fixed chunks of particles: project each particle
   (and its streak tail), cull it and write one record row. Small additive footprints
   go to the fast path (:mod:`.splat_kernels`): the record keeps their energy and the
   tile holding their box's centre is counted. Every other particle is measured here
   (the scale that gives it its energy) and gets its pixel box for tile binning;
2. :func:`gather_rows`, parallel over blocks of slots: copy the general records into the
   order of the tile lists (:func:`motes.render.tiles.bin_boxes`), so the drawing pass
   reads them sequentially instead of with one cache miss per particle;
3. :func:`draw_kernel`, parallel over tiles: each tile visits its particles in list order
   (the caller's order, or back to front for alpha-over) and blends their fragments into
   the tile's own pixels.
"""

from __future__ import annotations

import math
from functools import cache

import numba
import numpy as np

from .._jit import block_bounds, block_count, called, device, fma, parallel_kernel
from ._footprint import (
    ALPHA,
    BAD_COLOR,
    BAD_POSITION,
    BAD_RADIUS,
    BAD_ROTATION,
    BAD_VELOCITY,
    BLUE,
    COS,
    DEPTH,
    DISC,
    EXACT_AREA,
    FLOAT_EXPONENT,
    GREEN,
    HALF,
    MAX_RADIUS_PX,
    NEGATIVE_RADIUS,
    ONE,
    POINT,
    RADIUS,
    RED,
    SIN,
    SMALL,
    SX,
    SY,
    TAIL_DEPTH,
    TAIL_X,
    TAIL_Y,
    TEXTURE,
    TWO,
    ZERO,
    depth_factor,
    footprint_bounds,
    footprint_extent,
    footprint_sum,
    profile_area,
    profile_weight,
    segment_offset,
    texture_sample,
)
from .camera import EYE, FAR, FORWARD, HEIGHT, NEAR, ORTHO, RIGHT, SCALE, UP, WIDTH, to_screen
from .splat_kernels import LISTS, WINDOWS
from .tiles import CHUNK, TILE

#: How far [px] a fast-path footprint may reach beyond the tile that owns it. Tiles of
#: one parity class are two tiles apart, so with a reach of half a tile their footprints
#: never share a pixel and can be drawn in parallel (see :mod:`.splat_kernels`).
MARGIN = TILE // 2

# Per-chunk status columns written by the projection.
PROBLEMS, DRAWN, GENERAL, FRAGMENTS = 0, 1, 2, 3


@cache
def project_kernel(kind: int, streak: bool):
    """Compile (or fetch) the projection pass for one footprint kind, with or without tails.

    The kind and ``streak`` are closure constants, so the compiler folds the branches on
    them (each combination compiles once per machine; Numba's disk cache keys on closure
    contents). The returned kernel is
    ``kernel(cam, positions, colors, radii, rotation, velocities, checks, min_radius,
    shutter, intensity, additive, fast, texture, texture_alpha_mean, record, boxes,
    tile_of, counts, status, listed, deferred, deferred_count)``; see
    :func:`_project_range`.
    """

    @parallel_kernel
    def kernel(
        cam, positions, colors, radii, rotation, velocities, checks, min_radius, shutter,
        intensity, additive, fast, texture, texture_alpha_mean, record, boxes, tile_of,
        counts, status, listed, deferred, deferred_count,
    ):  # fmt: skip
        n = positions.shape[0]
        for chunk in numba.prange(status.shape[0]):
            # The loop index is int64 when Numba types the kernel and uint64 in the parallel
            # body it builds: cast, or the called function compiles twice (4 s each).
            index = np.int64(chunk)
            _project_range(
                index * CHUNK, min(n, (index + 1) * CHUNK), index, cam, positions, colors,
                radii, rotation, velocities, checks, kind, streak, min_radius, shutter,
                intensity, additive, fast, texture, texture_alpha_mean, record, boxes,
                tile_of, counts, status, listed, deferred, deferred_count,
            )  # fmt: skip

    return kernel


@called
def _project_range(
    start,
    stop,
    chunk,
    cam,
    positions,
    colors,
    radii,
    rotation,
    velocities,
    checks,
    kind,
    streak,
    min_radius,
    shutter,
    intensity,
    additive,
    fast,
    texture,
    texture_alpha_mean,
    record,
    boxes,
    tile_of,
    counts,
    status,
    listed,
    deferred,
    deferred_count,
):
    """Project, cull, classify and measure particles ``start..stop`` (one chunk).

    Parameters
    ----------
    cam : (PACKED_SIZE,) float64
        Packed camera (:meth:`Camera.packed`).
    positions, velocities : (n, 3) float32
        World positions [m] and velocities [m/s] (velocities read only with ``streak``).
    colors : (n, 4) float32
        Linear RGBA.
    radii, rotation : (n,) float32
        Radius [m] (unused for points) and sprite angle [rad] (read only for textures).
    checks : tuple of 13 read-only 1-D int32 arrays
        Bits of positions, colors, radii, rotation and velocities as contiguous arrays,
        then the values each holds per particle (``motes.render.sprites._bit_columns``),
        read to flag non-finite values.
    kind : int
        Footprint kind (POINT, SMOOTH, DISC, TEXTURE).
    streak : bool
        Whether to draw streaks from ``p - v * shutter`` to ``p``.
    min_radius : float
        Smallest footprint radius [px]; smaller particles keep their energy over it.
    shutter : float
        Exposure [s].
    intensity : float
        Factor on every colour.
    additive : bool
        Additive records hold premultiplied colour ``rgb · a · intensity`` times the
        particle's weight scale; alpha-over records hold ``rgb · intensity`` and, in
        ``ALPHA``, ``a`` times the weight scale.
    fast : bool
        Send small additive footprints to the fast path. Their records hold ``rgb · a ·
        intensity · energy`` (the drawing pass divides by the sampled weights' sum).
    texture : (th, tw, 4) float32
        Sprite texture (a dummy unless ``kind == TEXTURE``).
    texture_alpha_mean : float
        Mean texel alpha: a textured sprite's unit-peak area is ``4 R² ·`` this.
    record : (n, RECORD_BASE or RECORD_WIDE) float32, output
    boxes : (4, n) int32, output
        Inclusive ``col0, row0, col1, row1`` clipped to the image, for general-path
        particles; ``col1 < col0`` for the others.
    tile_of : (n,) int32, output
        The fast-path list of each particle: ``LISTS * tile + l`` for list ``l`` of the
        tile that owns it (see :mod:`.splat_kernels`); -1 for the other particles.
    counts : (chunks, LISTS * tiles) int64, output
        Fast-path particles per chunk and list (zeroed by the caller).
    status : (chunks, 4) int64, output
        Per chunk: input problems (BAD_* bits), particles drawn, general-path particles,
        and pixels in their clipped boxes (an estimate of the drawing work).
    listed : bool
        Whether :func:`windows_kernel` has run on these particles: then only the chunk's
        particles it deferred are visited, ``deferred[start : start + deferred_count[chunk]]``,
        and its counts in ``status`` are added to.
    deferred : (n,) int64; deferred_count : (chunks,) int64
    """
    width = int(cam[WIDTH])
    height = int(cam[HEIGHT])
    tiles_x = (width + TILE - 1) // TILE
    near = cam[NEAR]
    far = cam[FAR]
    wide = streak or kind == TEXTURE
    drawn = 0
    general = 0
    work = 0
    count = stop - start
    if listed:
        # windows_kernel checked the chunk and placed what fits the fast path's windows.
        if status[chunk, PROBLEMS]:
            return
        count = deferred_count[chunk]
        drawn = status[chunk, DRAWN]
        work = status[chunk, FRAGMENTS]
    else:
        bad = _chunk_problems(start, stop, checks, kind, streak, radii)
        if bad:
            # The caller raises: nothing of this chunk is drawn or counted.
            status[chunk, PROBLEMS] = bad
            return
    # Unsigned: Numba then skips the negative-index wraparound on every access.
    for j in range(np.uint64(count)):
        i = np.uint64(deferred[start + j]) if listed else np.uint64(start) + j
        boxes[0, i] = 0
        boxes[2, i] = -1  # not binned unless drawn by the general path below
        tile_of[i] = -1
        px, py, pz = positions[i, 0], positions[i, 1], positions[i, 2]
        sx, sy, depth, ppm = to_screen(cam, px, py, pz)
        if depth < near or depth > far:
            continue
        tx, ty, tdepth = sx, sy, depth
        if streak:
            qx = px - velocities[i, 0] * shutter
            qy = py - velocities[i, 1] * shutter
            qz = pz - velocities[i, 2] * shutter
            tdepth = to_screen(cam, qx, qy, qz)[2]
            # Clip the tail to the depth slab along the segment (perspective garbage
            # behind the eye must not be projected).
            keep = 1.0
            if tdepth < near:
                keep = (depth - near) / (depth - tdepth)
            elif tdepth > far:
                keep = (far - depth) / (tdepth - depth)
            qx = px + keep * (qx - px)
            qy = py + keep * (qy - py)
            qz = pz + keep * (qz - pz)
            tx, ty, tdepth, _ = to_screen(cam, qx, qy, qz)

        radius = 0.0
        rf = 1.0
        if kind != POINT:
            radius = min(radii[i] * ppm, MAX_RADIUS_PX)
            rf = max(radius, min_radius)
        # Round to the record's float32 once; everything below uses the rounded values,
        # exactly as the drawing passes will.
        sx32, sy32 = np.float32(sx), np.float32(sy)
        tx32, ty32 = np.float32(tx), np.float32(ty)
        rf32 = np.float32(rf)
        c0, r0, c1, r1 = footprint_bounds(kind, sx32, sy32, tx32, ty32, rf32)
        if c1 < 0 or r1 < 0 or c0 > width - 1 or r0 > height - 1 or c1 < c0 or r1 < r0:
            continue
        col0, row0 = max(int(c0), 0), max(int(r0), 0)
        col1, row1 = min(int(c1), width - 1), min(int(r1), height - 1)
        drawn += 1
        work += (col1 - col0 + 1) * (row1 - row0 + 1)
        a = colors[i, 3]
        area = profile_area(kind, radius, 0.0, texture_alpha_mean)
        record[i, SX] = sx32
        record[i, SY] = sy32
        record[i, DEPTH] = depth
        record[i, RADIUS] = rf32
        if wide:
            record[i, TAIL_X] = tx32
            record[i, TAIL_Y] = ty32
            record[i, TAIL_DEPTH] = tdepth
        if fast and kind != TEXTURE:
            # The fast path's lists (see splat_kernels): the smallest window that holds the
            # box, whose footprint is drawn over that whole window, or the list of larger
            # ones. The tile holding the centre of the clipped box (or window) owns the
            # particle if it stays within MARGIN of the tile.
            # Streaks always take the general list: few fit a window, and it saves
            # compiling unrolled streak kernels.
            # Branch-free (a 3 px sprite fits the 3 × 3 window at some sub-pixel
            # positions and not at others: a branch on it mispredicts half the time).
            span = max(c1 - c0, r1 - r0)
            which = LISTS - 1
            if not streak:
                which = 0
                for w in range(LISTS - 1):
                    which += span >= WINDOWS[w]
            if which < LISTS - 1:
                reach = WINDOWS[which] - 1
                col1 = min(int(c0) + reach, width - 1)
                row1 = min(int(r0) + reach, height - 1)
            owner_x = ((col0 + col1) >> 1) // TILE
            owner_y = ((row0 + row1) >> 1) // TILE
            left, top = owner_x * TILE - MARGIN, owner_y * TILE - MARGIN
            right, bottom = left + TILE - 1 + 2 * MARGIN, top + TILE - 1 + 2 * MARGIN
            if col0 >= left and col1 <= right and row0 >= top and row1 <= bottom:
                slot = LISTS * (owner_y * tiles_x + owner_x) + which
                tile_of[i] = slot
                gain = intensity * a * area
                record[i, RED] = colors[i, 0] * gain
                record[i, GREEN] = colors[i, 1] * gain
                record[i, BLUE] = colors[i, 2] * gain
                continue

        general += 1
        col1, row1 = min(int(c1), width - 1), min(int(r1), height - 1)
        cs, sn = ONE, ZERO
        if kind == TEXTURE:
            cs, sn = np.float32(math.cos(rotation[i])), np.float32(math.sin(rotation[i]))
            record[i, COS] = cs
            record[i, SIN] = sn
        segx, segy = sx32 - tx32, sy32 - ty32
        seg2 = segx * segx + segy * segy
        inv_seg2 = ONE / seg2 if seg2 > ZERO else ZERO
        if kind == POINT and seg2 == ZERO:
            scale = 1.0  # the bilinear tent's weights sum to 1 exactly
        else:
            e = footprint_extent(kind, rf32)
            if (abs(segx) + TWO * e) * (abs(segy) + TWO * e) <= EXACT_AREA:
                total = footprint_sum(
                    kind, streak, sx32, sy32, segx, segy, inv_seg2, rf32, cs, sn, texture,
                    c0, r0, c1, r1,
                )  # fmt: skip
            else:
                total = profile_area(kind, rf, math.sqrt(float(seg2)), texture_alpha_mean)
            scale = area / total if total > 0 else 0.0
        gain = intensity * (a * scale if additive else 1.0)
        record[i, RED] = colors[i, 0] * gain
        record[i, GREEN] = colors[i, 1] * gain
        record[i, BLUE] = colors[i, 2] * gain
        record[i, ALPHA] = a * scale
        boxes[0, i] = col0
        boxes[1, i] = row0
        boxes[2, i] = col1
        boxes[3, i] = row1
    if fast and kind != TEXTURE:
        # Counted in a loop of their own: the increment in the loop above cost the
        # projection of 1M sprites 28.5 -> 23.4 ms on one thread (same counts).
        for i in range(np.uint64(start), np.uint64(stop)):
            slot = tile_of[i]
            if slot >= 0:
                counts[np.uint64(chunk), np.uint64(slot)] += 1
    status[chunk, PROBLEMS] = 0
    status[chunk, DRAWN] = drawn
    status[chunk, GENERAL] = general
    status[chunk, FRAGMENTS] = work


#: Particles per pass of :func:`_project_windows`.
PASS = 256


@cache
def windows_kernel(kind: int):
    """Compile (or fetch) the first projection pass of still additive footprints of one
    kind (not textures): :func:`_project_windows` over fixed chunks, in parallel.

    The returned kernel is ``kernel(cam, positions, colors, radii, checks, min_radius,
    intensity, record, boxes, tile_of, deferred, deferred_count, status)``: per chunk,
    the input check of :func:`_project_range` (``status[chunk, PROBLEMS]``), then the
    particles that fit a window listed (``status[chunk, DRAWN]``, ``FRAGMENTS``) and the
    other visible ones' indices in ``deferred[start : start + deferred_count[chunk]]``,
    for the projection kernel run with ``listed``. A kernel of its own, launched only
    for such styles, so that streaks and textures do not compile it (2-3 s).
    """

    @parallel_kernel
    def kernel(
        cam, positions, colors, radii, checks, min_radius, intensity, record, boxes, tile_of,
        deferred, deferred_count, status,
    ):  # fmt: skip
        n = positions.shape[0]
        for chunk in numba.prange(status.shape[0]):
            index = np.int64(chunk)  # as in project_kernel
            start, stop = index * CHUNK, min(n, (index + 1) * CHUNK)
            bad = _chunk_problems(start, stop, checks, kind, False, radii)
            status[chunk, PROBLEMS] = bad
            if bad:
                continue
            count, drawn, work = _project_windows(
                start, stop, cam, positions, colors, radii, kind, min_radius, intensity,
                record, boxes, tile_of, deferred[start:stop],
            )  # fmt: skip
            deferred_count[chunk] = count
            status[chunk, DRAWN] = drawn
            status[chunk, FRAGMENTS] = work

    return kernel


@called
def _project_windows(
    start, stop, cam, positions, colors, radii, kind, min_radius, intensity, record, boxes,
    tile_of, deferred,
):  # fmt: skip
    """Project particles ``start..stop`` (additive, without streaks or textures) and list
    those whose footprint fits a window of the fast path, exactly as
    :func:`_project_range` would; the indices of the other visible ones go to
    ``deferred`` (its first entries). Returns ``(deferred count, particles listed, pixels
    in their boxes)``.

    In passes of :data:`PASS` particles: their inputs copied into contiguous buffers,
    then projected, measured and classified in a loop without branches or scattered
    stores, which the compiler vectorises (a loop reading the particles' rows, or a
    column of the colours, stays scalar), then the records written in a scalar loop.
    1M sprites on one thread: the projection 24 -> 18.6 ms (the same records).
    """
    width = int(cam[WIDTH])
    height = int(cam[HEIGHT])
    tiles_x = (width + TILE - 1) // TILE
    near, far, scale = cam[NEAR], cam[FAR], cam[SCALE]
    ortho = cam[ORTHO] > 0.5
    half_width, half_height = 0.5 * cam[WIDTH], 0.5 * cam[HEIGHT]
    ex, ey, ez = cam[EYE], cam[EYE + 1], cam[EYE + 2]
    rx, ry, rz = cam[RIGHT], cam[RIGHT + 1], cam[RIGHT + 2]
    ux, uy, uz = cam[UP], cam[UP + 1], cam[UP + 2]
    fx, fy, fz = cam[FORWARD], cam[FORWARD + 1], cam[FORWARD + 2]
    inputs = np.empty((5, PASS), np.float32)
    placed = np.empty((4, PASS), np.float32)  # sx, sy, depth, radius as recorded
    gains = np.empty(PASS, np.float64)
    slots = np.empty(PASS, np.int64)  # list slot; -1 culled, -2 deferred
    pixels = np.empty(PASS, np.int64)
    count = drawn = work = 0
    for first in range(start, stop, PASS):
        m = min(PASS, stop - first)
        for k in range(m):
            i = np.uint64(first + k)
            inputs[0, k] = positions[i, 0]
            inputs[1, k] = positions[i, 1]
            inputs[2, k] = positions[i, 2]
            inputs[3, k] = radii[i] if kind != POINT else ZERO
            inputs[4, k] = colors[i, 3]
        for k in range(m):
            # to_screen, the radius, footprint_bounds and the fast path's choice of
            # _project_range, operation for operation, as selects.
            dx = np.float64(inputs[0, k]) - ex
            dy = np.float64(inputs[1, k]) - ey
            dz = np.float64(inputs[2, k]) - ez
            vx = dx * rx + dy * ry + dz * rz
            vy = dx * ux + dy * uy + dz * uz
            depth = dx * fx + dy * fy + dz * fz
            factor = scale if ortho else scale / max(depth, 1e-12)
            sx = half_width + factor * vx
            sy = half_height - factor * vy
            radius = 0.0
            rf = 1.0
            if kind != POINT:
                radius = min(np.float64(inputs[3, k]) * factor, MAX_RADIUS_PX)
                rf = max(radius, min_radius)
            sx32, sy32, rf32 = np.float32(sx), np.float32(sy), np.float32(rf)
            e = ONE if kind == POINT else (rf32 + HALF if kind == DISC else rf32)
            c0 = np.floor(sx32 - e - HALF) + ONE
            c1 = np.ceil(sx32 + e - HALF) - ONE
            r0 = np.floor(sy32 - e - HALF) + ONE
            r1 = np.ceil(sy32 + e - HALF) - ONE
            visible = (
                (depth >= near) & (depth <= far) & (c1 >= 0) & (r1 >= 0) & (c0 <= width - 1)
                & (r0 <= height - 1) & (c1 >= c0) & (r1 >= r0)
            )  # fmt: skip
            col0, row0 = max(np.int64(c0), 0), max(np.int64(r0), 0)
            pixels[k] = (min(np.int64(c1), width - 1) - col0 + 1) * (
                min(np.int64(r1), height - 1) - row0 + 1
            )
            span = max(c1 - c0, r1 - r0)
            which = 0
            reach = WINDOWS[0] - 1
            for w in range(LISTS - 1):
                which += span >= WINDOWS[w]
            for w in range(1, LISTS - 1):
                reach += (WINDOWS[w] - WINDOWS[w - 1]) * (span >= WINDOWS[w - 1])
            col1 = min(np.int64(c0) + reach, width - 1)
            row1 = min(np.int64(r0) + reach, height - 1)
            owner_x = ((col0 + col1) >> 1) // TILE
            owner_y = ((row0 + row1) >> 1) // TILE
            left, top = owner_x * TILE - MARGIN, owner_y * TILE - MARGIN
            fits = (
                (which < LISTS - 1) & (col0 >= left) & (col1 <= left + TILE - 1 + 2 * MARGIN)
                & (row0 >= top) & (row1 <= top + TILE - 1 + 2 * MARGIN)
            )  # fmt: skip
            slot = LISTS * (owner_y * tiles_x + owner_x) + which
            slots[k] = slot if visible & fits else (-2 if visible else -1)
            placed[0, k] = sx32
            placed[1, k] = sy32
            placed[2, k] = depth
            placed[3, k] = rf32
            area = math.pi * radius * radius / 3.0
            if kind == DISC:
                area = math.pi * (radius * radius + 1.0 / 12.0)
            elif kind == POINT:
                area = 1.0
            gains[k] = intensity * inputs[4, k] * area
        for k in range(m):
            i = np.uint64(first + k)
            slot = slots[k]
            boxes[0, i] = 0
            boxes[2, i] = -1  # not binned unless deferred to the general path
            tile_of[i] = -1
            if slot == -2:
                deferred[count] = i
                count += 1
            if slot < 0:
                continue
            tile_of[i] = slot
            drawn += 1
            work += pixels[k]
            record[i, SX] = placed[0, k]
            record[i, SY] = placed[1, k]
            record[i, DEPTH] = placed[2, k]
            record[i, RADIUS] = placed[3, k]
            gain = gains[k]
            record[i, RED] = colors[i, 0] * gain
            record[i, GREEN] = colors[i, 1] * gain
            record[i, BLUE] = colors[i, 2] * gain
    return count, drawn, work


#: Entries of the finiteness checks per array: positions, colors, radii, rotation,
#: velocities (see :func:`motes.render.sprites._bit_columns`).
CHECK_START = (0, 3, 7, 8, 9, 12)


@called
def _chunk_problems(start, stop, checks, kind, streak, radii):
    """BAD_* bits of the input problems among particles ``start..stop`` (0: none).

    A pass of its own, without branches: most chunks have no problem, and the drawing
    loop then needs no test per particle. ``checks`` holds the arrays' bits as
    contiguous 1-D arrays, entry ``e`` with ``checks[-1][e]`` values per particle
    (:func:`motes.render.sprites._bit_columns`), so that each test is one
    vectorised loop (over rows of 3 and 4 columns they stayed scalar: a third of the
    projection's time)."""
    # Unsigned throughout: a signed index costs each access a wraparound select, which
    # keeps a loop scalar (and a literal times a uint64 is an int64 in Numba).
    first, last = np.uint64(start), np.uint64(stop)
    position = _nonfinite_entries(checks, 0, first, last)
    color = _nonfinite_entries(checks, 1, first, last)
    radius = negative = rotation = velocity = False
    if kind != POINT:
        radius = _nonfinite_entries(checks, 2, first, last)
        found = 0
        for i in range(first, last):
            found |= np.int32(radii[i] < ZERO)  # read as a float: -0.0 is a valid radius
        negative = found != 0
    if kind == TEXTURE:
        rotation = _nonfinite_entries(checks, 3, first, last)
    if streak:
        velocity = _nonfinite_entries(checks, 4, first, last)
    return (
        BAD_POSITION * position | BAD_COLOR * color | BAD_RADIUS * radius
        | NEGATIVE_RADIUS * negative | BAD_ROTATION * rotation
        | BAD_VELOCITY * velocity
    )  # fmt: skip


@device
def _nonfinite_entries(checks, field, first, last):
    """Whether particles ``first..last`` have a NaN or infinite value in array ``field``
    (its entries ``CHECK_START[field]:CHECK_START[field + 1]`` of ``checks``)."""
    widths = checks[CHECK_START[-1]]
    found = False
    for e in range(CHECK_START[field], CHECK_START[field + 1]):
        width = np.uint64(widths[e])
        found |= _nonfinite_in(checks[e], width * first, width * last)
    return found


@device
def _nonfinite_in(bits, lo, hi):
    """Whether any of the float32s ``bits[lo:hi]`` (int32 bit patterns) is NaN or
    infinite: an exponent of all ones. Integer arithmetic, because ``fastmath`` lets the
    compiler assume floats are finite and fold a float test away."""
    found = 0
    for j in range(lo, hi):
        found |= np.int32((bits[j] & FLOAT_EXPONENT) == FLOAT_EXPONENT)
    return found != 0


@parallel_kernel
def gather_rows(source, index, out):
    """``out[s] = source[index[s]]`` for every slot ``s``, rows of float32."""
    m = index.shape[0]
    columns = source.shape[1]
    for block in numba.prange(block_count(m)):
        start, stop = block_bounds(block, m)
        for s in range(start, stop):
            i = index[s]
            for c in range(columns):
                out[s, c] = source[i, c]


@called
def _blend(color, depth, row, col, w, d, inv_soft, additive, red, green, blue, alpha):
    """Depth-test (or soft-fade) one fragment of weight ``w`` at depth ``d`` and blend it.

    Branch-free in the fragment's values: a weight of 0 leaves the pixel bit-for-bit
    unchanged in both blend modes (``c + 0 = c``, ``0 · rgb + c · 1 = c``), so callers
    may pass masked fragments of pixels inside their own tile.
    """
    w *= depth_factor(depth[row, col], d, inv_soft)
    if additive:
        color[row, col, 0] = fma(red, w, color[row, col, 0])
        color[row, col, 1] = fma(green, w, color[row, col, 1])
        color[row, col, 2] = fma(blue, w, color[row, col, 2])
    else:
        a = min(max(alpha * w, ZERO), ONE)
        keep = ONE - a
        color[row, col, 0] = fma(color[row, col, 0], keep, red * a)
        color[row, col, 1] = fma(color[row, col, 1], keep, green * a)
        color[row, col, 2] = fma(color[row, col, 2], keep, blue * a)


@cache
def draw_kernel(kind: int, streak: bool):
    """Compile (or fetch) the drawing pass for one footprint kind, with or without tails.

    Closure constants, as in :func:`project_kernel` (the blend mode is an argument: its
    branch is taken the same way by every fragment, and one kernel fewer per kind saves
    seconds of compilation). The returned kernel is ``kernel(records, starts, tile_order,
    tiles_x, additive, inv_soft, texture, depth, color)``:
    it draws every tile, in parallel, in the order ``tile_order`` hands them out
    (interleaved for load balance; the result does not depend on it). See
    :func:`_draw_tile` for the other arguments.
    """

    @parallel_kernel
    def kernel(records, starts, tile_order, tiles_x, additive, inv_soft, texture, depth, color):
        for j in numba.prange(tile_order.shape[0]):
            _draw_tile(
                tile_order[j], records, starts, tiles_x, kind, streak, additive, inv_soft,
                texture, depth, color,
            )  # fmt: skip

    return kernel


@called
def _draw_tile(
    tile, records, starts, tiles_x, kind, streak, additive, inv_soft, texture, depth, color
):
    """Blend the fragments of tile ``tile``'s particles into its pixels, in list order.

    Parameters
    ----------
    tile : int
        Tile number, row-major (:class:`motes.render.tiles.TileBins`).
    records : (m, RECORD_BASE or RECORD_WIDE) float32
        Records in tile-list order: tile ``t`` draws ``records[starts[t]:starts[t + 1]]``.
    starts : (tiles + 1,) int64
    tiles_x : int
        Tiles per row.
    kind : int
        Footprint kind; ``streak`` says whether records carry tails.
    additive : bool
        ``color += rgb · w`` (premultiplied record colour) or alpha-over
        ``color = rgb · a + color · (1 - a)`` with ``a = clamp(record alpha · w, 0, 1)``.
    inv_soft : float
        Inverse soft-particle distance [1/m] (``_footprint.inverse_softness``): the weight
        is multiplied by ``clamp((D - d) / s, 0, 1)`` with ``D`` the opaque depth and
        ``d`` the fragment's; ``HARD`` makes it the hard test ``d < D``.
    texture : (th, tw, 4) float32
    depth : (h, w) float32
        Opaque depth [m] (``inf`` where there is none); read only.
    color : (h, w, 3) float32
        Linear colour; blended in place.

    Footprints of at most SMALL × SMALL pixels (in the tile) take a path with fixed trip
    counts, which the compiler unrolls: with loops of 2-3 iterations whose bounds change
    from particle to particle, loop control costs more than the fragments. Its pixels
    past the footprint's box are clamped back into it and weigh 0, so they stay in the
    tile and change nothing.
    """
    height, width = depth.shape
    inv_soft = np.float32(inv_soft)
    tcol = (tile % tiles_x) * TILE
    trow = (tile // tiles_x) * TILE
    tcol1 = min(tcol + TILE, width) - 1
    trow1 = min(trow + TILE, height) - 1
    for s in range(starts[tile], starts[tile + 1]):
        sx = records[s, SX]
        sy = records[s, SY]
        rf = records[s, RADIUS]
        head_depth = records[s, DEPTH]
        red = records[s, RED]
        green = records[s, GREEN]
        blue = records[s, BLUE]
        alpha = records[s, ALPHA]
        tx, ty, tail_depth = sx, sy, head_depth
        cs, sn = ONE, ZERO
        if streak:
            tx = records[s, TAIL_X]
            ty = records[s, TAIL_Y]
            tail_depth = records[s, TAIL_DEPTH]
        if kind == TEXTURE:
            cs = records[s, COS]
            sn = records[s, SIN]
        segx, segy = sx - tx, sy - ty
        seg2 = segx * segx + segy * segy
        inv_seg2 = ONE / seg2 if seg2 > ZERO else ZERO
        inv_rf2 = ONE / (rf * rf)
        inv_rf = ONE / rf
        rise = head_depth - tail_depth
        c0, r0, c1, r1 = footprint_bounds(kind, sx, sy, tx, ty, rf)
        col0 = max(int(c0), tcol)
        col1 = min(int(c1), tcol1)
        row0 = max(int(r0), trow)
        row1 = min(int(r1), trow1)
        if kind != TEXTURE and col1 - col0 < SMALL and row1 - row0 < SMALL:
            for dr in range(SMALL):
                row = min(row0 + dr, row1)
                row_in = row0 + dr <= row1
                py = np.float32(row) + HALF
                for dc in range(SMALL):
                    col = min(col0 + dc, col1)
                    px = np.float32(col) + HALF
                    dx, dy, t = segment_offset(streak, px, py, sx, sy, segx, segy, inv_seg2)
                    w = profile_weight(kind, dx, dy, rf, inv_rf2)
                    w *= np.float32(row_in & (col0 + dc <= col1))
                    _blend(
                        color, depth, row, col, w, tail_depth + t * rise, inv_soft, additive,
                        red, green, blue, alpha,
                    )  # fmt: skip
            continue
        for row in range(row0, row1 + 1):
            py = np.float32(row) + HALF
            for col in range(col0, col1 + 1):
                px = np.float32(col) + HALF
                if kind == TEXTURE:
                    tr, tg, tb, w = texture_sample(texture, px - sx, py - sy, inv_rf, cs, sn)
                    if w <= ZERO:
                        continue
                    _blend(
                        color, depth, row, col, w, head_depth, inv_soft, additive,
                        red * tr, green * tg, blue * tb, alpha,
                    )  # fmt: skip
                else:
                    dx, dy, t = segment_offset(streak, px, py, sx, sy, segx, segy, inv_seg2)
                    w = profile_weight(kind, dx, dy, rf, inv_rf2)
                    if w <= ZERO:
                        continue
                    _blend(
                        color, depth, row, col, w, tail_depth + t * rise, inv_soft, additive,
                        red, green, blue, alpha,
                    )  # fmt: skip
