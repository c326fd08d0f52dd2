"""Footprints of drawn particles: their pixel boxes, unit-peak weights and areas.

Device functions shared by the particle rasteriser's kernels (:mod:`.sprite_kernels`,
:mod:`.splat_kernels`) and the constants that describe a particle record.

Conventions (see :mod:`motes.render.camera`): pixel ``(row, col)`` has its centre at
``(col + 0.5, row + 0.5)``; depths are view depths [m]. Per-pixel arithmetic is float32
with float32 constants (a Python float literal would promote it to float64).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import called, device, fma

# Footprint kinds.
POINT = 0  # bilinear tent of the offset from the particle (or its streak)
SMOOTH = 1  # (1 - d²/R²)², d = distance to the centre (or the streak) [px]
DISC = 2  # flat disc with a 1 px anti-aliased edge: clamp(R + 0.5 - d, 0, 1)
TEXTURE = 3  # bilinear texture over the rotated square [-R, R]²

# Columns of a particle record (float32). The base record has RECORD_BASE columns; a
# record with streak tails or sprite rotations has RECORD_WIDE.
SX, SY, DEPTH, RADIUS, RED, GREEN, BLUE, ALPHA = range(8)
TAIL_X, TAIL_Y, TAIL_DEPTH, COS, SIN = range(8, 13)
RECORD_BASE, RECORD_WIDE = 8, 16

# Input problems found while projecting (bit flags, OR-ed over chunks).
BAD_POSITION = 1
BAD_COLOR = 2
BAD_RADIUS = 4
BAD_ROTATION = 8
BAD_VELOCITY = 16
NEGATIVE_RADIUS = 32

#: Largest footprint radius [px]; larger radii are clamped (a sprite that size covers any
#: image, and the clamp keeps pixel boxes within integer range).
MAX_RADIUS_PX = 1.0e6
#: Footprints whose bounding box (the streak's extent plus the reach on each side) is at
#: most this many px² are normalised by the exact sum of their sampled weights; larger
#: ones by the profile's analytic integral, whose sampling error is then below 3e-4
#: (measured for the disc edge, the worse of the two profiles).
EXACT_AREA = 1024.0
#: Footprints at most this many pixels wide and high take the unrolled paths of the
#: general drawing pass and of the exact normalisation.
SMALL = 3

#: Inverse softness [1/m] of a hard depth test: (D - d) times this is >= 1 for any two
#: distinct float32 depths above 1e-20 m, and <= 0 when d >= D (see depth_factor).
HARD = np.float32(1e30)

# float32 constants: a Python float literal in a kernel would promote float32 arithmetic
# to float64.
ZERO = np.float32(0.0)
HALF = np.float32(0.5)
ONE = np.float32(1.0)
TWO = np.float32(2.0)
SQRT2 = np.float32(math.sqrt(2.0))
FLOAT_EXPONENT = np.int32(0x7F800000)


def inverse_softness(softness: float) -> float:
    """``1 / softness`` [1/m], or :data:`HARD` for a hard depth test (softness 0)."""
    return 1.0 / softness if softness > 0 else float(HARD)


@device
def depth_factor(opaque, d, inv_soft):
    """Weight factor of a fragment at depth ``d`` over opaque depth ``opaque`` [m].

    ``clamp((D - d) / softness, 0, 1)``: soft particles fade out as they near a surface
    and vanish behind it; with ``inv_soft = HARD`` it is the hard test ``d < D`` (1 or
    0). One formula, so the fragment loops have no branch on the softness; ``D = inf``
    (no geometry) gives 1.
    """
    return min(max((opaque - d) * inv_soft, ZERO), ONE)


@called
def footprint_extent(kind, rf):
    """Distance [px] from the particle (or its streak) beyond which its weight is 0."""
    if kind == POINT:
        return ONE
    if kind == SMOOTH:
        return rf
    if kind == DISC:
        return rf + HALF
    return rf * SQRT2  # the rotated square's corners


@called
def footprint_bounds(kind, sx, sy, tx, ty, rf):
    """Float bounds ``(col0, row0, col1, row1)`` of the pixels a footprint may touch.

    Pixel column ``c`` can have weight only if its centre ``c + 0.5`` lies strictly within
    ``extent`` of the segment's x range: ``floor(x_lo - e - 0.5) + 1 <= c <=
    ceil(x_hi + e - 0.5) - 1`` (and likewise for rows).
    """
    e = footprint_extent(kind, rf)
    c0 = np.floor(min(sx, tx) - e - HALF) + ONE
    c1 = np.ceil(max(sx, tx) + e - HALF) - ONE
    r0 = np.floor(min(sy, ty) - e - HALF) + ONE
    r1 = np.ceil(max(sy, ty) + e - HALF) - ONE
    return c0, r0, c1, r1


@device
def segment_offset(streak, px, py, sx, sy, segx, segy, inv_seg2):
    """Offset of pixel centre ``(px, py)`` from the nearest point of a streak.

    The streak runs from the tail ``(sx - segx, sy - segy)`` to the head ``(sx, sy)``.
    Returns ``(dx, dy, t)``: the offset and the nearest point's parameter ``t`` in [0, 1]
    (0 at the tail, 1 at the head). ``inv_seg2 = 0`` means a zero-length streak (t = 1).
    Without ``streak`` (a compile-time constant in the kernels), the offset from the head.
    """
    dx = px - sx
    dy = py - sy
    if not streak:
        return dx, dy, ONE
    t = min(max(ONE + (dx * segx + dy * segy) * inv_seg2, ZERO), ONE)
    back = ONE - t
    return dx + back * segx, dy + back * segy, t


@device
def profile_weight(kind, dx, dy, rf, inv_rf2):
    """Unit-peak weight of a round footprint at offset ``(dx, dy)`` [px] from its centre."""
    if kind == POINT:
        return max(ONE - abs(dx), ZERO) * max(ONE - abs(dy), ZERO)
    r2 = fma(dx, dx, dy * dy)
    if kind == SMOOTH:
        s = max(fma(-r2, inv_rf2, ONE), ZERO)
        return s * s
    return min(max(rf + HALF - np.sqrt(r2), ZERO), ONE)


@called
def texture_sample(texture, dx, dy, inv_rf, cs, sn):
    """Bilinear RGBA of a texture laid on the square [-R, R]² rotated by the sprite angle.

    ``(dx, dy)`` is the pixel centre's offset [px] from the sprite centre (screen y down);
    the texture turns counter-clockwise on screen by the angle whose cosine and sine are
    ``cs, sn``. Texture row 0 is the top of the image; texel centres sit at
    ``(j + 0.5) / size`` of the square; lookups clamp to the edge texels (so the
    interpolant's mean over the square is the texels' mean). Outside the square: 0.
    """
    x = dx * inv_rf
    y = -dy * inv_rf  # view-plane y up
    u = cs * x + sn * y  # rotate by minus the sprite angle into texture axes
    v = cs * y - sn * x
    if u <= -ONE or u >= ONE or v <= -ONE or v >= ONE:
        return ZERO, ZERO, ZERO, ZERO
    th, tw = texture.shape[0], texture.shape[1]
    fc = min(max((u + ONE) * HALF * np.float32(tw) - HALF, ZERO), np.float32(tw - 1))
    fr = min(max((ONE - v) * HALF * np.float32(th) - HALF, ZERO), np.float32(th - 1))
    c0 = int(fc)
    r0 = int(fr)
    c1 = min(c0 + 1, tw - 1)
    r1 = min(r0 + 1, th - 1)
    gc = fc - np.float32(c0)
    gr = fr - np.float32(r0)
    w00 = (ONE - gr) * (ONE - gc)
    w01 = (ONE - gr) * gc
    w10 = gr * (ONE - gc)
    w11 = gr * gc
    out0 = w00 * texture[r0, c0, 0] + w01 * texture[r0, c1, 0]
    out0 += w10 * texture[r1, c0, 0] + w11 * texture[r1, c1, 0]
    out1 = w00 * texture[r0, c0, 1] + w01 * texture[r0, c1, 1]
    out1 += w10 * texture[r1, c0, 1] + w11 * texture[r1, c1, 1]
    out2 = w00 * texture[r0, c0, 2] + w01 * texture[r0, c1, 2]
    out2 += w10 * texture[r1, c0, 2] + w11 * texture[r1, c1, 2]
    out3 = w00 * texture[r0, c0, 3] + w01 * texture[r0, c1, 3]
    out3 += w10 * texture[r1, c0, 3] + w11 * texture[r1, c1, 3]
    return out0, out1, out2, out3


@called
def profile_area(kind, r, streak_length, texture_alpha_mean):
    """Analytic integral [px²] of a unit-peak footprint of radius ``r`` [px].

    Round profiles: ∫ 2πρ (1 - ρ²/r²)² dρ = πr²/3 (smooth); π(r² + 1/12) (disc with its
    1 px linear edge); 1 for the bilinear tent; ``4 r² · mean alpha`` for a texture on
    the square [-r, r]². A streak of length L adds L times the profile's cross-section:
    16r/15 (smooth), 2r (disc), 1 (tent, exact for axis-aligned streaks).
    """
    if kind == POINT:
        return 1.0 + streak_length
    if kind == SMOOTH:
        return math.pi * r * r / 3.0 + streak_length * 16.0 * r / 15.0
    if kind == DISC:
        return math.pi * (r * r + 1.0 / 12.0) + streak_length * 2.0 * r
    return 4.0 * r * r * texture_alpha_mean


@called
def footprint_sum(kind, streak, sx, sy, segx, segy, inv_seg2, rf, cs, sn, texture, c0, r0, c1, r1):
    """Sum of a footprint's sampled unit-peak weights over its pixel box ``c0..c1, r0..r1``.

    The box bounds are the float values of :func:`footprint_bounds`.
    """
    inv_rf2 = ONE / (rf * rf)
    if kind != TEXTURE and c1 - c0 < SMALL and r1 - r0 < SMALL:
        # Fixed trip counts unroll into straight-line code; pixels past
        # the box weigh 0. Masks are multiplications: a conditional expression compiles
        # to a branch, mispredicted at random on the footprint's edge.
        small = ZERO
        for dr in range(SMALL):
            row = r0 + np.float32(dr)
            for dc in range(SMALL):
                col = c0 + np.float32(dc)
                dx, dy, _ = segment_offset(
                    streak, col + HALF, row + HALF, sx, sy, segx, segy, inv_seg2
                )
                w = profile_weight(kind, dx, dy, rf, inv_rf2)
                small += w * np.float32((row <= r1) & (col <= c1))
        return float(small)
    inv_rf = ONE / rf
    total = 0.0
    for row in range(int(r0), int(r1) + 1):
        py = np.float32(row) + HALF
        # A sum per row: the rows' additions overlap, where one running sum over the
        # box would wait for each of them (float sums keep their order).
        row_total = ZERO
        for col in range(int(c0), int(c1) + 1):
            px = np.float32(col) + HALF
            if kind == TEXTURE:
                row_total += texture_sample(texture, px - sx, py - sy, inv_rf, cs, sn)[3]
            else:
                dx, dy, _ = segment_offset(streak, px, py, sx, sy, segx, segy, inv_seg2)
                row_total += profile_weight(kind, dx, dy, rf, inv_rf2)
        total += row_total
    return total
