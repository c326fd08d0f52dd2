"""Compiled rasterisation of opaque triangles and anti-aliased lines with a depth buffer.

The pipeline (launched by :func:`motes.render.geometry.draw_geometry`):

1. :func:`project_vertices` — world to view space, per vertex, in parallel.
2. :func:`setup_triangles` — per face: clip against the near plane z = near in view
   space (Sutherland-Hodgman against one plane gives 0, 3 or 4 vertices, fanned into at
   most two screen triangles, the face's two slots), cull faces wholly beyond the far
   plane, project, and compute each screen triangle's pixel box for tile binning.
   :func:`setup_lines` does the same per line segment.
3. :func:`motes.render.tiles.bin_boxes` lists triangles, then lines, per 32×32 tile.
4. :func:`draw_tiles` — one thread per tile, items in input order: rasterise the tile's
   triangles into a tile-sized supersampled buffer (visibility only: nearest depth and
   triangle per sample), shade each triangle visible in a pixel once, blend the lines
   over the samples, and resolve into the frame.

Sample space is the frame's pixel grid scaled by the supersampling factor ``ss``; sample
``(j, i)`` has its centre at ``(i + 0.5, j + 0.5)``. A sample is inside a triangle when
all three edge functions are positive, or zero on an edge the triangle owns (a tie rule
under which exactly one of two triangles sharing an edge owns it). Each edge function
is evaluated from the edge's endpoints in a canonical order and then negated as needed,
so two triangles sharing an edge compute bit-identical values: no cracks, no double
coverage. Attributes are interpolated perspective-correctly: screen barycentrics
``λ_i`` are weighted by ``q_i = 1/z_i`` (perspective) or 1 (orthographic).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import block_bounds, block_count, device, parallel_kernel, serial_kernel
from .camera import EYE, FAR, FORWARD, HEIGHT, NEAR, ORTHO, RIGHT, SCALE, UP, WIDTH
from .lighting import shade
from .shading import CHECKER_COLOR, CHECKER_DENSITY, FLAT, SPECULAR, checker_fraction
from .tiles import TILE

# One screen-triangle corner: sample position, perspective weight q, view depth [m] and
# barycentric coordinates with respect to the source face's three vertices.
CX, CY, CQ, CZ, CB = 0, 1, 2, 3, 4
CORNER = 7

# One screen line segment: both ends (sample position, q, view depth, parameter along the
# source segment), then half the drawn width [samples] and the coverage scale (< 1 for
# lines thinner than one sample, which are drawn one sample wide and fainter).
LAX, LAY, LAQ, LAZ, LAT, LBX, LBY, LBQ, LBZ, LBT, LHALF, LCOV = range(12)
LINE_SIZE = 12


@parallel_kernel
def project_vertices(cam, positions, view):
    """View-space coordinates (x right, y up, z depth) [m] of (v, 3) world positions."""
    n = positions.shape[0]
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            dx = positions[i, 0] - cam[EYE]
            dy = positions[i, 1] - cam[EYE + 1]
            dz = positions[i, 2] - cam[EYE + 2]
            view[i, 0] = dx * cam[RIGHT] + dy * cam[RIGHT + 1] + dz * cam[RIGHT + 2]
            view[i, 1] = dx * cam[UP] + dy * cam[UP + 1] + dz * cam[UP + 2]
            view[i, 2] = dx * cam[FORWARD] + dy * cam[FORWARD + 1] + dz * cam[FORWARD + 2]


@device
def _to_samples(cam, ss, x, y, z):
    """Sample-space position and perspective weight q of a view-space point."""
    q = 1.0 if cam[ORTHO] > 0.5 else 1.0 / z
    factor = cam[SCALE] * (1.0 if cam[ORTHO] > 0.5 else q)
    return ss * (0.5 * cam[WIDTH] + factor * x), ss * (0.5 * cam[HEIGHT] - factor * y), q


@device
def _pixel_range(lo, hi, ss, size):
    """Inclusive pixel range whose samples have centres in [lo, hi] [samples]."""
    limit = float(size * ss + 1)
    first = math.ceil(min(max(lo - 0.5, -1.0), limit))
    last = math.floor(min(max(hi - 0.5, -1.0), limit))
    first_px = max(first // ss, 0)
    last_px = min(last // ss, size - 1) if last >= 0 else -1
    return first_px, last_px


@parallel_kernel
def setup_triangles(cam, ss, positions, view, faces, tri, tri_face, tri_facing, face_normal, box):
    """Clip, project and box each face into its two screen-triangle slots.

    Parameters
    ----------
    cam : (PACKED_SIZE,) float64
        Packed camera.
    ss : int
        Supersampling factor.
    positions, view : (v, 3) float64
        World and view-space vertex positions [m].
    faces : (f, 3) int32
        Vertex indices.
    tri : (2 f, 3, CORNER) float64
        Out: screen-triangle corners (slot ``2 k + j`` is the ``j``-th piece of face k).
    tri_face : (2 f,) int32
        Out: source face of each slot, -1 for an unused slot.
    tri_facing : (2 f,) float64
        Out: +1 when the triangle shows its front (counter-clockwise) side, else -1.
    face_normal : (f, 3) float64
        Out: unit geometric normal of each face (zero for a degenerate face).
    box : (4, 2 f) int32
        Out: inclusive pixel box ``x0, y0, x1, y1`` of each slot, empty when unused.
    """
    n = faces.shape[0]
    near = cam[NEAR]
    far = cam[FAR]
    width = int(cam[WIDTH])
    height = int(cam[HEIGHT])
    for block in numba.prange(block_count(n)):
        poly = np.empty((4, 6))  # clipped polygon: view x, y, z, barycentrics
        start, stop = block_bounds(block, n)
        for f in range(start, stop):
            a = faces[f, 0]
            b = faces[f, 1]
            c = faces[f, 2]
            ux = positions[b, 0] - positions[a, 0]
            uy = positions[b, 1] - positions[a, 1]
            uz = positions[b, 2] - positions[a, 2]
            wx = positions[c, 0] - positions[a, 0]
            wy = positions[c, 1] - positions[a, 1]
            wz = positions[c, 2] - positions[a, 2]
            nx = uy * wz - uz * wy
            ny = uz * wx - ux * wz
            nz = ux * wy - uy * wx
            length = math.sqrt(nx * nx + ny * ny + nz * nz)
            inv = 1.0 / length if length > 0.0 else 0.0
            face_normal[f, 0] = nx * inv
            face_normal[f, 1] = ny * inv
            face_normal[f, 2] = nz * inv
            for j in range(2):
                tri_face[2 * f + j] = -1
                box[0, 2 * f + j] = 0
                box[1, 2 * f + j] = 0
                box[2, 2 * f + j] = -1
                box[3, 2 * f + j] = -1
            za = view[a, 2]
            zb = view[b, 2]
            zc = view[c, 2]
            if max(za, max(zb, zc)) < near or min(za, min(zb, zc)) > far:
                continue
            m = 0
            for k in range(3):
                p = faces[f, k]
                q = faces[f, (k + 1) % 3]
                zp = view[p, 2]
                zq = view[q, 2]
                if zp >= near:
                    for d in range(3):
                        poly[m, d] = view[p, d]
                        poly[m, 3 + d] = 0.0
                    poly[m, 3 + k] = 1.0
                    m += 1
                if (zp >= near) != (zq >= near):
                    t = (near - zp) / (zq - zp)
                    for d in range(2):
                        poly[m, d] = view[p, d] + t * (view[q, d] - view[p, d])
                    poly[m, 2] = near
                    for d in range(3):
                        poly[m, 3 + d] = 0.0
                    poly[m, 3 + k] = 1.0 - t
                    poly[m, 3 + (k + 1) % 3] = t
                    m += 1
            for j in range(m - 2):
                slot = 2 * f + j
                lo_x = math.inf
                lo_y = math.inf
                hi_x = -math.inf
                hi_y = -math.inf
                for corner in range(3):
                    v = 0 if corner == 0 else j + corner
                    sx, sy, q = _to_samples(cam, ss, poly[v, 0], poly[v, 1], poly[v, 2])
                    tri[slot, corner, CX] = sx
                    tri[slot, corner, CY] = sy
                    tri[slot, corner, CQ] = q
                    tri[slot, corner, CZ] = poly[v, 2]
                    for d in range(3):
                        tri[slot, corner, CB + d] = poly[v, 3 + d]
                    lo_x = min(lo_x, sx)
                    lo_y = min(lo_y, sy)
                    hi_x = max(hi_x, sx)
                    hi_y = max(hi_y, sy)
                area = (tri[slot, 1, CX] - tri[slot, 0, CX]) * (
                    tri[slot, 2, CY] - tri[slot, 0, CY]
                ) - (tri[slot, 1, CY] - tri[slot, 0, CY]) * (tri[slot, 2, CX] - tri[slot, 0, CX])
                if area == 0.0:  # degenerate
                    continue
                # Screen y points down, so a counter-clockwise front face has negative area.
                tri_facing[slot] = 1.0 if area < 0.0 else -1.0
                tri_face[slot] = f
                box[0, slot], box[2, slot] = _pixel_range(lo_x, hi_x, ss, width)
                box[1, slot], box[3, slot] = _pixel_range(lo_y, hi_y, ss, height)


@parallel_kernel
def setup_lines(cam, ss, ends, width_px, lines, box):
    """Clip against the near plane, project and box each line segment.

    Parameters
    ----------
    cam : (PACKED_SIZE,) float64
    ss : int
    ends : (m, 2, 3) float64
        World positions [m] of both ends of each segment.
    width_px : (m,) float64
        Line width [px of the frame].
    lines : (m, LINE_SIZE) float64
        Out: screen segments.
    box : (4, m) int32
        Out: inclusive pixel box of each segment's quad, empty when culled.
    """
    n = ends.shape[0]
    near = cam[NEAR]
    far = cam[FAR]
    width = int(cam[WIDTH])
    height = int(cam[HEIGHT])
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for s in range(start, stop):
            box[0, s] = 0
            box[1, s] = 0
            box[2, s] = -1
            box[3, s] = -1
            dxa = ends[s, 0, 0] - cam[EYE]
            dya = ends[s, 0, 1] - cam[EYE + 1]
            dza = ends[s, 0, 2] - cam[EYE + 2]
            dxb = ends[s, 1, 0] - cam[EYE]
            dyb = ends[s, 1, 1] - cam[EYE + 1]
            dzb = ends[s, 1, 2] - cam[EYE + 2]
            xa = dxa * cam[RIGHT] + dya * cam[RIGHT + 1] + dza * cam[RIGHT + 2]
            ya = dxa * cam[UP] + dya * cam[UP + 1] + dza * cam[UP + 2]
            za = dxa * cam[FORWARD] + dya * cam[FORWARD + 1] + dza * cam[FORWARD + 2]
            xb = dxb * cam[RIGHT] + dyb * cam[RIGHT + 1] + dzb * cam[RIGHT + 2]
            yb = dxb * cam[UP] + dyb * cam[UP + 1] + dzb * cam[UP + 2]
            zb = dxb * cam[FORWARD] + dyb * cam[FORWARD + 1] + dzb * cam[FORWARD + 2]
            if max(za, zb) < near or min(za, zb) > far:
                continue
            ta = 0.0
            tb = 1.0
            if za < near:
                ta = (near - za) / (zb - za)
            elif zb < near:
                tb = (near - za) / (zb - za)
            x0 = xa + ta * (xb - xa)
            y0 = ya + ta * (yb - ya)
            z0 = max(za + ta * (zb - za), near)
            x1 = xa + tb * (xb - xa)
            y1 = ya + tb * (yb - ya)
            z1 = max(za + tb * (zb - za), near)
            sx0, sy0, q0 = _to_samples(cam, ss, x0, y0, z0)
            sx1, sy1, q1 = _to_samples(cam, ss, x1, y1, z1)
            drawn = width_px[s] * ss
            half = 0.5 * max(drawn, 1.0)
            lines[s, LAX] = sx0
            lines[s, LAY] = sy0
            lines[s, LAQ] = q0
            lines[s, LAZ] = z0
            lines[s, LAT] = ta
            lines[s, LBX] = sx1
            lines[s, LBY] = sy1
            lines[s, LBQ] = q1
            lines[s, LBZ] = z1
            lines[s, LBT] = tb
            lines[s, LHALF] = half
            lines[s, LCOV] = min(drawn, 1.0)
            reach = half + 0.5  # coverage falls to zero half a sample past the edge
            box[0, s], box[2, s] = _pixel_range(
                min(sx0, sx1) - reach, max(sx0, sx1) + reach, ss, width
            )
            box[1, s], box[3, s] = _pixel_range(
                min(sy0, sy1) - reach, max(sy0, sy1) + reach, ss, height
            )


@device
def _canonical_edge(ax, ay, bx, by):
    """Edge a -> b as (origin x, origin y, dx, dy, sign) with a canonical origin.

    ``sign * (dx * (py - oy) - dy * (px - ox))`` is the edge function of a -> b; both
    triangles sharing the edge evaluate it from the same origin, so their values are
    exact negatives whatever the rounding.
    """
    if ax < bx or (ax == bx and ay < by):
        return ax, ay, bx - ax, by - ay, 1.0
    return bx, by, ax - bx, ay - by, -1.0


@device
def _owns(dx, dy):
    """Tie rule: a sample exactly on edge a -> b (direction dx, dy) belongs to this side."""
    return dy > 0.0 or (dy == 0.0 and dx > 0.0)


@device
def _span(lo, hi, ex, ey, dx, dy, sign, py):
    """Narrow the x interval [lo, hi] [samples] to where one edge function is >= 0 on row py.

    Only bounds the search: the exact inside test runs on every sample of the span.
    """
    slope = -sign * dy
    offset = sign * (dx * (py - ey) + dy * ex)
    if slope > 0.0:
        lo = max(lo, -offset / slope)
    elif slope < 0.0:
        hi = min(hi, -offset / slope)
    elif offset < 0.0:
        hi = -math.inf
    return lo, hi


@serial_kernel
def _raster_triangle(tri, slot, ox, oy, sw, sh, far, zbuf, owner):
    """Depth-test one screen triangle's samples in the tile; record the nearest.

    Compiled on its own (called once per triangle and tile, so the call costs nothing):
    inlined, it made the tile kernel compile ~9 s longer.

    ``ox, oy`` is the tile's first sample, ``sw, sh`` its size [samples]; ``zbuf`` and
    ``owner`` (the slot drawn at each sample, -1 for none) are updated.
    """
    x0 = tri[slot, 0, CX]
    y0 = tri[slot, 0, CY]
    x1 = tri[slot, 1, CX]
    y1 = tri[slot, 1, CY]
    x2 = tri[slot, 2, CX]
    y2 = tri[slot, 2, CY]
    c1 = 1
    c2 = 2
    if (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0) < 0.0:
        # Wind the corners so that the inside is where the edge functions are > 0.
        x1, y1, x2, y2 = x2, y2, x1, y1
        c1 = 2
        c2 = 1
    q0 = tri[slot, 0, CQ]
    q1 = tri[slot, c1, CQ]
    q2 = tri[slot, c2, CQ]
    # Perspective-correct depth: sum(l q z) / sum(l q) over the edge functions l.
    qz0 = q0 * tri[slot, 0, CZ]
    qz1 = q1 * tri[slot, c1, CZ]
    qz2 = q2 * tri[slot, c2, CZ]
    # Edge i is opposite corner i.
    e0x, e0y, e0dx, e0dy, e0s = _canonical_edge(x1, y1, x2, y2)
    e1x, e1y, e1dx, e1dy, e1s = _canonical_edge(x2, y2, x0, y0)
    e2x, e2y, e2dx, e2dy, e2s = _canonical_edge(x0, y0, x1, y1)
    own0 = _owns(x2 - x1, y2 - y1)
    own1 = _owns(x0 - x2, y0 - y2)
    own2 = _owns(x1 - x0, y1 - y0)
    left = float(ox) - 1.0
    right = float(ox + sw) + 1.0
    lo_x = max(min(x0, min(x1, x2)), left)
    hi_x = min(max(x0, max(x1, x2)), right)
    i_lo = max(math.ceil(lo_x - 0.5) - ox, 0)
    i_hi = min(math.floor(hi_x - 0.5) - ox, sw - 1)
    lo_y = max(min(y0, min(y1, y2)), float(oy) - 1.0)
    hi_y = min(max(y0, max(y1, y2)), float(oy + sh) + 1.0)
    j_lo = max(math.ceil(lo_y - 0.5) - oy, 0)
    j_hi = min(math.floor(hi_y - 0.5) - oy, sh - 1)
    for j in range(j_lo, j_hi + 1):
        py = oy + j + 0.5
        lo, hi = _span(left, right, e0x, e0y, e0dx, e0dy, e0s, py)
        lo, hi = _span(lo, hi, e1x, e1y, e1dx, e1dy, e1s, py)
        lo, hi = _span(lo, hi, e2x, e2y, e2dx, e2dy, e2s, py)
        if hi < lo - 2.0:
            continue
        # One sample of slack each side: the span's rounding never decides coverage.
        start = max(i_lo, math.ceil(max(lo, left) - 0.5) - ox - 1)
        stop = min(i_hi, math.floor(min(hi, right) - 0.5) - ox + 1)
        for i in range(start, stop + 1):
            px = ox + i + 0.5
            l0 = e0s * (e0dx * (py - e0y) - e0dy * (px - e0x))
            l1 = e1s * (e1dx * (py - e1y) - e1dy * (px - e1x))
            l2 = e2s * (e2dx * (py - e2y) - e2dy * (px - e2x))
            if l0 < 0.0 or l1 < 0.0 or l2 < 0.0:
                continue
            if (l0 == 0.0 and not own0) or (l1 == 0.0 and not own1) or (l2 == 0.0 and not own2):
                continue
            depth = (l0 * qz0 + l1 * qz1 + l2 * qz2) / (l0 * q0 + l1 * q1 + l2 * q2)
            if depth < zbuf[j, i] and depth <= far:
                zbuf[j, i] = depth
                owner[j, i] = slot


@device
def _face_barycentrics(tri, slot, px, py):
    """Barycentric coordinates, in the source face, of the surface seen at sample (px, py).

    Screen barycentrics (edge functions; their common sign and scale cancel) weighted by
    q, then mapped through the corners' own face barycentrics.
    """
    x0 = tri[slot, 0, CX]
    y0 = tri[slot, 0, CY]
    x1 = tri[slot, 1, CX]
    y1 = tri[slot, 1, CY]
    x2 = tri[slot, 2, CX]
    y2 = tri[slot, 2, CY]
    w0 = ((x2 - x1) * (py - y1) - (y2 - y1) * (px - x1)) * tri[slot, 0, CQ]
    w1 = ((x0 - x2) * (py - y2) - (y0 - y2) * (px - x2)) * tri[slot, 1, CQ]
    w2 = ((x1 - x0) * (py - y0) - (y1 - y0) * (px - x0)) * tri[slot, 2, CQ]
    inv = 1.0 / (w0 + w1 + w2)
    w0 *= inv
    w1 *= inv
    w2 *= inv
    b0 = w0 * tri[slot, 0, CB] + w1 * tri[slot, 1, CB] + w2 * tri[slot, 2, CB]
    b1 = w0 * tri[slot, 0, CB + 1] + w1 * tri[slot, 1, CB + 1] + w2 * tri[slot, 2, CB + 1]
    return b0, b1, 1.0 - b0 - b1


@device
def _shade_at(
    cam, pixel_size, slot, px, py, tri, tri_face, tri_facing, positions, normals, colors,
    faces, face_surface, face_normal, surfaces, lights, ambient, shadowing,
):  # fmt: skip
    """Radiance (r, g, b) of the surface of screen triangle ``slot`` seen at sample (px, py).

    ``pixel_size`` is the side of a pixel [m] at unit depth (perspective) or anywhere
    (orthographic): ``1 / cam[SCALE]``.
    """
    b0, b1, b2 = _face_barycentrics(tri, slot, px, py)
    f = tri_face[slot]
    a = faces[f, 0]
    b = faces[f, 1]
    c = faces[f, 2]
    s = face_surface[f]
    if surfaces[s, FLAT] > 0.5:
        nx = face_normal[f, 0]
        ny = face_normal[f, 1]
        nz = face_normal[f, 2]
    else:
        nx = b0 * normals[a, 0] + b1 * normals[b, 0] + b2 * normals[c, 0]
        ny = b0 * normals[a, 1] + b1 * normals[b, 1] + b2 * normals[c, 1]
        nz = b0 * normals[a, 2] + b1 * normals[b, 2] + b2 * normals[c, 2]
        length = math.sqrt(nx * nx + ny * ny + nz * nz)
        inv = 1.0 / length if length > 0.0 else 0.0
        nx *= inv
        ny *= inv
        nz *= inv
    # Two-sided: the side the camera sees is lit as the front.
    facing = tri_facing[slot]
    nx *= facing
    ny *= facing
    nz *= facing
    wx = b0 * positions[a, 0] + b1 * positions[b, 0] + b2 * positions[c, 0]
    wy = b0 * positions[a, 1] + b1 * positions[b, 1] + b2 * positions[c, 1]
    wz = b0 * positions[a, 2] + b1 * positions[b, 2] + b2 * positions[c, 2]
    r = b0 * colors[a, 0] + b1 * colors[b, 0] + b2 * colors[c, 0]
    g = b0 * colors[a, 1] + b1 * colors[b, 1] + b2 * colors[c, 1]
    bl = b0 * colors[a, 2] + b1 * colors[b, 2] + b2 * colors[c, 2]
    density = surfaces[s, CHECKER_DENSITY]
    vx = 0.0
    vy = 0.0
    vz = 0.0
    # Only highlights and the checker's footprint need the direction to the viewer (a
    # square root and a division per pixel, which Lambert-only surfaces skip).
    if surfaces[s, SPECULAR] > 0.0 or density > 0.0:
        if cam[ORTHO] > 0.5:
            vx = -cam[FORWARD]
            vy = -cam[FORWARD + 1]
            vz = -cam[FORWARD + 2]
            pixel = pixel_size
        else:
            vx = cam[EYE] - wx
            vy = cam[EYE + 1] - wy
            vz = cam[EYE + 2] - wz
            pixel = -(vx * cam[FORWARD] + vy * cam[FORWARD + 1] + vz * cam[FORWARD + 2])
            pixel *= pixel_size
            inv = 1.0 / max(math.sqrt(vx * vx + vy * vy + vz * vz), 1e-300)
            vx *= inv
            vy *= inv
            vz *= inv
        if density > 0.0:
            # A pixel's footprint on the surface stretches by 1/cos of the viewing angle.
            slant = max(abs(nx * vx + ny * vy + nz * vz), 0.05)
            k = checker_fraction(wx * density, wz * density, pixel * density / slant)
            r += k * (surfaces[s, CHECKER_COLOR] - r)
            g += k * (surfaces[s, CHECKER_COLOR + 1] - g)
            bl += k * (surfaces[s, CHECKER_COLOR + 2] - bl)
    return shade(
        nx, ny, nz, vx, vy, vz, wx, wy, wz, r, g, bl, surfaces, s, lights, ambient, shadowing
    )


@serial_kernel
def _draw_line(lines, s, seg_colors, ox, oy, sw, sh, far, zbuf, cbuf, touched, ss):
    """Blend one anti-aliased line segment over the tile's samples, depth-tested.

    Compiled on its own, like :func:`_raster_triangle`.
    """
    ax = lines[s, LAX]
    ay = lines[s, LAY]
    dx = lines[s, LBX] - ax
    dy = lines[s, LBY] - ay
    qa = lines[s, LAQ]
    qb = lines[s, LBQ]
    za = lines[s, LAZ]
    zb = lines[s, LBZ]
    ta = lines[s, LAT]
    tb = lines[s, LBT]
    cov_scale = lines[s, LCOV]
    length2 = dx * dx + dy * dy
    inv_length2 = 1.0 / length2 if length2 > 0.0 else 0.0
    reach = lines[s, LHALF] + 0.5
    left = float(ox) - 1.0
    top = float(oy) - 1.0
    i_lo = max(math.ceil(max(min(ax, ax + dx) - reach, left) - 0.5) - ox, 0)
    i_hi = min(math.floor(min(max(ax, ax + dx) + reach, left + sw + 2) - 0.5) - ox, sw - 1)
    j_lo = max(math.ceil(max(min(ay, ay + dy) - reach, top) - 0.5) - oy, 0)
    j_hi = min(math.floor(min(max(ay, ay + dy) + reach, top + sh + 2) - 0.5) - oy, sh - 1)
    for j in range(j_lo, j_hi + 1):
        py = oy + j + 0.5
        start = i_lo
        stop = i_hi
        if abs(dy) * (i_hi - i_lo) > 4.0 * abs(dx):
            # Samples within `reach` of the line lie in a band; on this row it spans
            # |(px - ax) dy - (py - ay) dx| <= reach * length (one sample of slack).
            centre = ax + (py - ay) * dx / dy
            half_width = reach * math.sqrt(length2) / abs(dy)
            start = max(i_lo, math.ceil(centre - half_width - 0.5) - ox - 1)
            stop = min(i_hi, math.floor(centre + half_width - 0.5) - ox + 1)
        for i in range(start, stop + 1):
            px = ox + i + 0.5
            t = ((px - ax) * dx + (py - ay) * dy) * inv_length2
            t = min(max(t, 0.0), 1.0)
            ex = px - ax - t * dx
            ey = py - ay - t * dy
            coverage = min(max(reach - math.sqrt(ex * ex + ey * ey), 0.0), 1.0) * cov_scale
            if coverage <= 0.0:
                continue
            # Perspective-correct position along the segment: q-weighted, like triangles.
            u = t * qb / ((1.0 - t) * qa + t * qb)
            depth = za + u * (zb - za)
            if depth < zbuf[j, i] and depth <= far:
                along = ta + u * (tb - ta)
                for ch in range(3):
                    c0 = seg_colors[s, 0, ch]
                    c = c0 + along * (seg_colors[s, 1, ch] - c0)
                    cbuf[j, i, ch] += coverage * (c - cbuf[j, i, ch])
                if coverage >= 0.5:
                    zbuf[j, i] = depth
                touched[j // ss, i // ss] = True


@device
def _tile_box(t, tiles_x, width, height):
    """First column and row [px] and size (columns, rows) of tile ``t`` of an image
    ``width`` x ``height`` cut into tiles ``tiles_x`` across (the last ones clipped)."""
    px0 = (t % tiles_x) * TILE
    py0 = (t // tiles_x) * TILE
    return px0, py0, min(TILE, width - px0), min(TILE, height - py0)


@serial_kernel
def _draw_tile(
    cam, pixel_size, ss, t, starts, items, tiles_x, tri_count, tri, tri_face, tri_facing,
    positions, normals, colors, faces, face_surface, face_normal, surfaces, lights, ambient,
    shadowing, lines, seg_colors, color, depth,
):  # fmt: skip
    """Draw tile ``t`` (see :func:`draw_tiles`), whose parallel loop stays a thin wrapper."""
    height, width = depth.shape
    far = cam[FAR]
    first = starts[t]
    last = starts[t + 1]
    if first == last:
        return
    px0, py0, pw, ph = _tile_box(t, tiles_x, width, height)
    sw = pw * ss
    sh = ph * ss
    ox = px0 * ss
    oy = py0 * ss
    zbuf = np.empty((sh, sw), dtype=np.float32)
    owner = np.full((sh, sw), -1, dtype=np.int32)
    for y in range(ph):
        for x in range(pw):
            d = depth[py0 + y, px0 + x]
            for j in range(y * ss, y * ss + ss):
                for i in range(x * ss, x * ss + ss):
                    zbuf[j, i] = d
    k = first
    while k < last and items[k] < tri_count:
        _raster_triangle(tri, items[k], ox, oy, sw, sh, far, zbuf, owner)
        k += 1
    # Without lines, each pixel is shaded and resolved in one go; lines blend per
    # sample, so then the samples' colours are kept until they are drawn.
    has_lines = k < last
    touched = np.zeros((ph, pw), dtype=np.bool_)
    # float64, like the fused path's sums, so a pixel comes out bit-identical whether
    # or not a line crosses its tile.
    cbuf = np.empty((sh if has_lines else 0, sw if has_lines else 0, 3))
    cached_slot = np.empty(ss * ss, dtype=np.int64)
    cached_rgb = np.empty((ss * ss, 3))
    inv_samples = 1.0 / (ss * ss)
    for y in range(ph):
        for x in range(pw):
            back_r = color[py0 + y, px0 + x, 0]
            back_g = color[py0 + y, px0 + x, 1]
            back_b = color[py0 + y, px0 + x, 2]
            sum_r = 0.0
            sum_g = 0.0
            sum_b = 0.0
            nearest = depth[py0 + y, px0 + x]
            cached = 0
            for j in range(y * ss, y * ss + ss):
                for i in range(x * ss, x * ss + ss):
                    slot = owner[j, i]
                    if slot < 0:
                        if has_lines:
                            cbuf[j, i, 0] = back_r
                            cbuf[j, i, 1] = back_g
                            cbuf[j, i, 2] = back_b
                        sum_r += back_r
                        sum_g += back_g
                        sum_b += back_b
                        continue
                    nearest = min(nearest, zbuf[j, i])
                    hit = -1
                    for m in range(cached):
                        if cached_slot[m] == slot:
                            hit = m
                    if hit < 0:
                        r, g, b = _shade_at(
                            cam, pixel_size, slot, ox + i + 0.5, oy + j + 0.5, tri,
                            tri_face, tri_facing, positions, normals, colors, faces,
                            face_surface, face_normal, surfaces, lights, ambient, shadowing,
                        )  # fmt: skip
                        hit = cached
                        cached_slot[hit] = slot
                        cached_rgb[hit, 0] = r
                        cached_rgb[hit, 1] = g
                        cached_rgb[hit, 2] = b
                        cached += 1
                    if has_lines:
                        cbuf[j, i, 0] = cached_rgb[hit, 0]
                        cbuf[j, i, 1] = cached_rgb[hit, 1]
                        cbuf[j, i, 2] = cached_rgb[hit, 2]
                    sum_r += cached_rgb[hit, 0]
                    sum_g += cached_rgb[hit, 1]
                    sum_b += cached_rgb[hit, 2]
            if cached == 0:
                continue
            touched[y, x] = True
            if not has_lines:
                depth[py0 + y, px0 + x] = nearest
                color[py0 + y, px0 + x, 0] = sum_r * inv_samples
                color[py0 + y, px0 + x, 1] = sum_g * inv_samples
                color[py0 + y, px0 + x, 2] = sum_b * inv_samples
    if not has_lines:
        return
    while k < last:
        _draw_line(
            lines, items[k] - tri_count, seg_colors, ox, oy, sw, sh, far, zbuf, cbuf,
            touched, ss,
        )  # fmt: skip
        k += 1
    for y in range(ph):
        for x in range(pw):
            if not touched[y, x]:
                continue
            nearest = zbuf[y * ss, x * ss]
            r = 0.0
            g = 0.0
            b = 0.0
            for j in range(y * ss, y * ss + ss):
                for i in range(x * ss, x * ss + ss):
                    nearest = min(nearest, zbuf[j, i])
                    r += cbuf[j, i, 0]
                    g += cbuf[j, i, 1]
                    b += cbuf[j, i, 2]
            depth[py0 + y, px0 + x] = nearest
            color[py0 + y, px0 + x, 0] = r * inv_samples
            color[py0 + y, px0 + x, 1] = g * inv_samples
            color[py0 + y, px0 + x, 2] = b * inv_samples


@parallel_kernel
def draw_tiles(
    cam, ss, order, starts, items, tiles_x, tri_count, tri, tri_face, tri_facing, positions,
    normals, colors, faces, face_surface, face_normal, surfaces, lights, ambient, shadowing,
    lines, seg_colors, color, depth,
):  # fmt: skip
    """Draw every tile's triangles, then its lines, and resolve into the frame; tiles are
    visited in ``order`` (:attr:`motes.render.tiles.TileBins.order`).

    Items ``< tri_count`` are screen-triangle slots, the rest line segments
    ``item - tri_count``; ``bin_boxes`` keeps input order, so within a tile all
    triangles come before all lines. Each tile is drawn into its own
    ``(TILE ss) × (TILE ss)`` sample buffer, initialised by replicating the frame's depth
    (and colour). Triangles record depth and the nearest triangle per sample; each pixel
    then shades every distinct triangle visible in it once, at the first of its samples
    that triangle covers, and gives the colour to all of them (as multisampling does:
    shading every sample would cost ``ss²`` times more for the same image on smooth
    surfaces; the checker is filtered over the pixel instead). Lines blend per sample.
    A pixel any sample of which was drawn gets the mean colour and the minimum depth of
    its samples; other pixels are left untouched, bit for bit.

    ``color`` (h, w, 3) float32 and ``depth`` (h, w) float32 are read and written.
    """
    pixel_size = 1.0 / cam[SCALE]
    for n in numba.prange(order.shape[0]):
        _draw_tile(
            cam, pixel_size, ss, order[n], starts, items, tiles_x, tri_count, tri, tri_face,
            tri_facing, positions, normals, colors, faces, face_surface, face_normal, surfaces,
            lights, ambient, shadowing, lines, seg_colors, color, depth,
        )  # fmt: skip


@serial_kernel
def _depth_tile(t, starts, items, tiles_x, tri, far, depth):
    """Rasterise tile ``t``'s triangles into ``depth`` (one sample per pixel)."""
    height, width = depth.shape
    first = starts[t]
    last = starts[t + 1]
    if first == last:
        return
    px0, py0, pw, ph = _tile_box(t, tiles_x, width, height)
    zbuf = np.empty((ph, pw), dtype=np.float32)
    owner = np.empty((ph, pw), dtype=np.int32)
    for y in range(ph):
        for x in range(pw):
            zbuf[y, x] = depth[py0 + y, px0 + x]
    for k in range(first, last):
        _raster_triangle(tri, items[k], px0, py0, pw, ph, far, zbuf, owner)
    for y in range(ph):
        for x in range(pw):
            depth[py0 + y, px0 + x] = zbuf[y, x]


@parallel_kernel
def depth_tiles(cam, order, starts, items, tiles_x, tri, depth):
    """Nearest depth of every tile's triangles, written into ``depth`` (h, w) float32:
    visibility alone, as a shadow map needs (no shading, no supersampling, no lines).
    Tiles are visited in ``order``, as in :func:`draw_tiles`."""
    far = cam[FAR]
    for n in numba.prange(order.shape[0]):
        _depth_tile(order[n], starts, items, tiles_x, tri, far, depth)
