"""Compiled passes of the screen-space liquid (:mod:`motes.render.water`).

1. :func:`splat_spheres`, parallel over screen tiles: every particle is a sphere; each
   pixel keeps the nearest sphere front in front of the opaque depth, and the summed
   length of the spheres' chords up to that depth (the liquid's thickness);
2. :func:`smooth_rows`, parallel over rows, on the buffers and on their transposes (the
   columns): a separable bilateral Gaussian of the surface depth (van der Laan, Green &
   Sainz 2009), whose width in pixels follows the particles' size at that depth, and a
   plain Gaussian of the thickness and of the spheres' coverage; at half size
   (:func:`halve`, :func:`double`) when the filter is wide;
3. :func:`shade`, parallel over rows: the outline where the smoothed coverage crosses
   1/2, normals from the smoothed depth, then refraction
   of what lies behind, Beer-Lambert absorption over the thickness, light scattered in
   the liquid's body, Fresnel reflection of the sky and the lights' highlights.

Pixels without liquid hold :data:`EMPTY` as depth: a finite sentinel, because the
kernels compile with fast math, which assumes no infinities.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from .._jit import device, parallel_kernel
from .camera import EYE, FORWARD, HEIGHT, ORTHO, RIGHT, SCALE, UP, WIDTH
from .lighting import toward_light
from .shading import LIGHT_RADIANCE
from .tiles import TILE

#: Depth [m] of a pixel without liquid (and of opaque depth where there is nothing).
EMPTY = np.float32(1e30)

# Layout of the look's parameters (float64) for :func:`shade`.
(
    SIGMA_R, SIGMA_G, SIGMA_B,  # absorption [1/m]
    DEEP_R, DEEP_G, DEEP_B,  # colour of light scattered in the body [1]
    REFRACTION,  # screen offset [m] per metre of thickness per unit of tilt
    REFLECTANCE,  # Fresnel reflectance at normal incidence
    SHININESS,  # Blinn-Phong exponent of highlights
    SPECULAR,  # highlight strength [1]
    EDGE,  # thickness [m] over which the liquid's edge becomes opaque
    ZENITH_R, ZENITH_G, ZENITH_B,  # sky straight up (linear RGB)
    HORIZON_R, HORIZON_G, HORIZON_B,  # sky at the horizon
    GROUND_R, GROUND_G, GROUND_B,  # what is reflected from below the horizon
) = range(20)  # fmt: skip
PARAMS = 20


@parallel_kernel
def splat_spheres(starts, items, tiles_x, sx, sy, depth, rpx, radius, opaque, surface, thickness):
    """Depth of the nearest sphere front [m] into ``surface`` (min) and the spheres'
    chord lengths [m] up to the opaque depth into ``thickness`` (sum), tile by tile.

    ``sx, sy`` (n,) are screen centres [px], ``depth`` view depths [m], ``rpx`` screen
    radii [px], ``radius`` the sphere radius [m]; ``starts, items`` the tile lists of
    :func:`motes.render.tiles.bin_boxes`. ``opaque``, ``surface`` and ``thickness`` are
    (height, width) float32. Each tile is one work item, visiting its spheres in order,
    so the sums do not depend on the thread count.
    """
    height, width = opaque.shape
    tiles = starts.shape[0] - 1
    for t in prange(tiles):
        left = (t % tiles_x) * TILE
        top = (t // tiles_x) * TILE
        right = min(left + TILE, width)
        bottom = min(top + TILE, height)
        for k in range(starts[t], starts[t + 1]):
            i = items[k]
            cx = sx[i]
            cy = sy[i]
            r = rpx[i]
            inv_r2 = np.float32(1.0) / (r * r)
            c0 = max(math.floor(cx - r), left)
            c1 = min(math.floor(cx + r) + 1, right)
            r0 = max(math.floor(cy - r), top)
            r1 = min(math.floor(cy + r) + 1, bottom)
            z = depth[i]
            size = radius[i]
            for row in range(r0, r1):
                dy = np.float32(row) + np.float32(0.5) - cy
                for col in range(c0, c1):
                    dx = np.float32(col) + np.float32(0.5) - cx
                    q = np.float32(1.0) - (dx * dx + dy * dy) * inv_r2
                    if q <= 0:
                        continue
                    half = size * np.sqrt(q)
                    front = z - half
                    wall = opaque[row, col]
                    if front >= wall:
                        continue
                    thickness[row, col] += min(z + half, wall) - front
                    if front < surface[row, col]:
                        surface[row, col] = front


@parallel_kernel
def smooth_rows(surface, plain, sigma, plain_share, inv_range2, out_surface, out_plain):
    """One pass of the smoothing along rows (the caller transposes for columns).

    A liquid pixel's depth becomes the bilateral Gaussian mean of the liquid depths on
    its row within ``2 sigma`` (the spatial sigma ``sigma[row, col]`` [px]; the range
    weight, zero past a depth difference of ``1 / sqrt(inv_range2)`` [m], keeps a near
    sheet from bleeding into a far one); a pixel without liquid takes the plain Gaussian
    mean of the liquid depths within reach (the liquid grows by ``2 sigma`` a pass; the
    coverage below decides what is shown), :data:`EMPTY` with none in reach.
    ``plain`` (height, width, 2) holds the thickness [m] and the coverage (1 where the
    spheres cover a pixel, 0 elsewhere): each becomes the plain Gaussian mean with
    ``plain_share`` of the pixel's sigma (about a particle's radius: the outline loses
    the discs' scallops, not the liquid's shape). The coverage, smoothed so, crosses 1/2
    on a smooth outline that neither grows nor shrinks the liquid.
    """
    height, width = surface.shape
    one = np.float32(1.0)
    zero = np.float32(0.0)
    quarter = np.float32(0.25)
    for row in prange(height):
        for col in range(width):
            s = sigma[row, col]
            sp = s * plain_share
            inv_plain = quarter / (sp * sp)
            # Every pixel is a tap: sampling a wide filter sparsely (every sigma/8 px)
            # was 1.7x faster but left a visible grain where the spheres' bumps are.
            taps = int(2.0 * s) + 1
            inv = quarter / (s * s)
            z = surface[row, col]
            liquid = z < EMPTY
            z_sum = zero
            z_weight = zero
            t_sum = zero
            c_sum = zero
            t_weight = zero
            # Weights (1 - x^2/4)^2 of x = distance / sigma: a Gaussian's shape within two
            # sigmas, and no exponential per tap; the same shape for the depth difference
            # over its cutoff.
            # A pixel without liquid has no depth to compare: its neighbours' weigh by
            # distance alone, so the liquid's depth reaches past the spheres' outline
            # wherever the smoothed coverage may show it.
            near = one if liquid else zero
            for k in range(max(col - taps, 0), min(col + taps + 1, width)):
                d = np.float32(k - col)
                w = max(one - d * d * inv, zero)
                w *= w
                wp = max(one - d * d * inv_plain, zero)
                wp *= wp
                t_sum += wp * plain[row, k, 0]
                c_sum += wp * plain[row, k, 1]
                t_weight += wp
                q = surface[row, k]
                # an empty tap counts 0, and its difference is 0 too: (EMPTY - z)^2
                # would overflow float32, and fast math assumes no infinity
                valid = (q < EMPTY) * one
                dz = (q - z) * near * valid
                wr = max(one - dz * dz * inv_range2, zero)
                wr = w * wr * wr * valid
                z_sum += wr * q
                z_weight += wr
            out_plain[row, col, 0] = t_sum / t_weight
            out_plain[row, col, 1] = c_sum / t_weight
            # (a liquid pixel's own tap weighs 1: no division by zero)
            out_surface[row, col] = z_sum / z_weight if z_weight > zero else EMPTY


@parallel_kernel
def halve(surface, plain, out_surface, out_plain):
    """2 x 2 blocks to one pixel: the nearest liquid depth (:data:`EMPTY` for none) and
    the mean thickness and coverage. Odd edges take the pixels there are."""
    height, width = surface.shape
    for row in prange(out_surface.shape[0]):
        for col in range(out_surface.shape[1]):
            nearest = EMPTY
            total = np.float32(0.0)
            covered = np.float32(0.0)
            count = 0
            for r in range(2 * row, min(2 * row + 2, height)):
                for c in range(2 * col, min(2 * col + 2, width)):
                    nearest = min(nearest, surface[r, c])
                    total += plain[r, c, 0]
                    covered += plain[r, c, 1]
                    count += 1
            out_surface[row, col] = nearest
            out_plain[row, col, 0] = total / np.float32(count)
            out_plain[row, col, 1] = covered / np.float32(count)


@parallel_kernel
def double(surface, half_surface, half_plain, inv_range2, out_surface, out_plain):
    """Half-size smoothed buffers back to full size, bilinear: thickness and coverage
    everywhere; the depth of each liquid pixel of ``surface`` (the full-size depth before smoothing)
    from the half-size liquid samples near its own depth (the same range weight as the
    smoothing), its own depth where there are none; a pixel without liquid from the
    liquid samples around it (the grown outline), :data:`EMPTY` with none."""
    height, width = surface.shape
    half_h, half_w = half_surface.shape
    one = np.float32(1.0)
    zero = np.float32(0.0)
    for row in prange(height):
        v = min(max((row + 0.5) * 0.5 - 0.5, 0.0), half_h - 1.0)
        r0 = min(int(v), max(half_h - 2, 0))
        r1 = min(r0 + 1, half_h - 1)
        fv = np.float32(v - r0)
        for col in range(width):
            u = min(max((col + 0.5) * 0.5 - 0.5, 0.0), half_w - 1.0)
            c0 = min(int(u), max(half_w - 2, 0))
            c1 = min(c0 + 1, half_w - 1)
            fu = np.float32(u - c0)
            for k in range(2):
                top = half_plain[r0, c0, k] * (one - fu) + half_plain[r0, c1, k] * fu
                bottom = half_plain[r1, c0, k] * (one - fu) + half_plain[r1, c1, k] * fu
                out_plain[row, col, k] = top * (one - fv) + bottom * fv
            z = surface[row, col]
            liquid = z < EMPTY
            near = one if liquid else zero
            z_sum = zero
            z_weight = zero
            for r, wr in ((r0, one - fv), (r1, fv)):
                for c, wc in ((c0, one - fu), (c1, fu)):
                    q = half_surface[r, c]
                    valid = (q < EMPTY) * one  # as in smooth_rows: no overflow
                    dz = (q - z) * near * valid
                    w = max(one - dz * dz * inv_range2, zero)
                    w = wr * wc * w * w * valid
                    z_sum += w * q
                    z_weight += w
            if z_weight > 1e-6:
                out_surface[row, col] = z_sum / z_weight
            else:
                out_surface[row, col] = z


@device
def _view_point(cam, row, col, z):
    """View-space point (x right, y up, z depth) [m] seen at pixel centre (row, col) at
    depth ``z`` [m]."""
    f = 1.0 / cam[SCALE] if cam[ORTHO] > 0.5 else z / cam[SCALE]
    return (col + 0.5 - 0.5 * cam[WIDTH]) * f, (0.5 * cam[HEIGHT] - row - 0.5) * f, z


@device
def _tangent(cam, surface, row, col, dr, dc, x, y, z):
    """Difference of view-space points toward the neighbour that continues the surface
    (of the pixels at ``(row ± dr, col ± dc)`` the one whose depth differs least: at a
    silhouette the far side belongs to another surface). Zero if neither is liquid."""
    height, width = surface.shape
    best = EMPTY
    tx = ty = tz = 0.0
    for sign in (-1, 1):
        r = row + sign * dr
        c = col + sign * dc
        if 0 <= r < height and 0 <= c < width:
            q = surface[r, c]
            if q < EMPTY and abs(q - z) < best:
                best = abs(q - z)
                qx, qy, qz = _view_point(cam, r, c, q)
                tx, ty, tz = sign * (qx - x), sign * (qy - y), sign * (qz - z)
    return tx, ty, tz


@device
def _sample(image, opaque, z, u, v, row, col):
    """``image`` (h, w, 3) at screen point (u, v) [px], bilinear, clamped to the frame;
    the pixel's own colour where something opaque at the point lies nearer than ``z``
    (refraction shows only what is behind the liquid)."""
    height, width = opaque.shape
    u = min(max(u - 0.5, 0.0), width - 1.0)
    v = min(max(v - 0.5, 0.0), height - 1.0)
    c0 = min(int(u), width - 2) if width > 1 else 0
    r0 = min(int(v), height - 2) if height > 1 else 0
    c1 = min(c0 + 1, width - 1)
    r1 = min(r0 + 1, height - 1)
    if opaque[int(v + 0.5), int(u + 0.5)] < z:
        return image[row, col, 0], image[row, col, 1], image[row, col, 2]
    fu = u - c0
    fv = v - r0
    return (
        _bilinear(image, r0, r1, c0, c1, fu, fv, 0),
        _bilinear(image, r0, r1, c0, c1, fu, fv, 1),
        _bilinear(image, r0, r1, c0, c1, fu, fv, 2),
    )


@device
def _bilinear(image, r0, r1, c0, c1, fu, fv, k):
    top = image[r0, c0, k] * (1.0 - fu) + image[r0, c1, k] * fu
    bottom = image[r1, c0, k] * (1.0 - fu) + image[r1, c1, k] * fu
    return top * (1.0 - fv) + bottom * fv


@parallel_kernel
def shade(cam, behind, opaque, surface, plain, lights, ambient, params, color, depth):
    """Draw the liquid into ``color`` (h, w, 3) float32 and its depth into ``depth``.

    ``behind`` is the frame before the liquid (what refraction shows), ``opaque`` its
    depth (:data:`EMPTY` for none), ``surface`` and ``plain`` (thickness, coverage) the
    smoothed passes,
    ``lights`` and ``ambient`` as :func:`motes.render.shading.pack_lights` packs them,
    ``params`` the look (see the layout above). A pixel whose liquid is thinner than
    ``params[EDGE]`` is blended over what lies behind by its thickness, which softens
    the silhouette; a pixel more than half covered takes the liquid's depth plus
    ``params[EDGE]`` (the particle radius), so that particles drawn later within a radius
    of the surface (foam on it) are seen.
    """
    height, width = surface.shape
    up_x, up_y, up_z = cam[UP], cam[UP + 1], cam[UP + 2]
    right_x, right_y, right_z = cam[RIGHT], cam[RIGHT + 1], cam[RIGHT + 2]
    fwd_x, fwd_y, fwd_z = cam[FORWARD], cam[FORWARD + 1], cam[FORWARD + 2]
    ortho = cam[ORTHO] > 0.5
    f0 = params[REFLECTANCE]
    for row in prange(height):
        for col in range(width):
            z = surface[row, col]
            if z >= EMPTY:
                continue
            t = max(plain[row, col, 0], 0.0)
            # The outline where the smoothed coverage crosses 1/2, anti-aliased over a
            # quarter of its ramp; and a film thinner than EDGE shows partly.
            outline = min(max(4.0 * (plain[row, col, 1] - 0.5) + 0.5, 0.0), 1.0)
            if outline <= 0.0:
                continue
            x, y, _ = _view_point(cam, row, col, z)
            ax, ay, az = _tangent(cam, surface, row, col, 0, 1, x, y, z)
            bx, by, bz = _tangent(cam, surface, row, col, 1, 0, x, y, z)
            # Rows run down the screen, so (a, b) are (right, down): a x b faces the eye.
            nx = ay * bz - az * by
            ny = az * bx - ax * bz
            nz = ax * by - ay * bx
            length = math.sqrt(nx * nx + ny * ny + nz * nz)
            if length > 0.0:
                nx, ny, nz = nx / length, ny / length, nz / length
            else:
                nx, ny, nz = 0.0, 0.0, -1.0
            if nz > 0.0:
                nx, ny, nz = -nx, -ny, -nz
            # World-space normal and direction to the eye.
            wx = nx * right_x + ny * up_x + nz * fwd_x
            wy = nx * right_y + ny * up_y + nz * fwd_y
            wz = nx * right_z + ny * up_z + nz * fwd_z
            if ortho:
                ex, ey, ez = -fwd_x, -fwd_y, -fwd_z
            else:
                ex = -(x * right_x + y * up_x + z * fwd_x)
                ey = -(x * right_y + y * up_y + z * fwd_y)
                ez = -(x * right_z + y * up_z + z * fwd_z)
                inv = 1.0 / math.sqrt(ex * ex + ey * ey + ez * ez)
                ex, ey, ez = ex * inv, ey * inv, ez * inv
            cos_v = max(wx * ex + wy * ey + wz * ez, 0.0)
            fresnel = f0 + (1.0 - f0) * (1.0 - cos_v) ** 5
            # Sky in the mirror direction.
            my = 2.0 * cos_v * wy - ey
            if my >= 0.0:
                s = math.sqrt(my)
                sky_r = params[HORIZON_R] * (1.0 - s) + params[ZENITH_R] * s
                sky_g = params[HORIZON_G] * (1.0 - s) + params[ZENITH_G] * s
                sky_b = params[HORIZON_B] * (1.0 - s) + params[ZENITH_B] * s
            else:
                sky_r, sky_g, sky_b = params[GROUND_R], params[GROUND_G], params[GROUND_B]
            # Highlights and the light the body receives from above.
            spec_r = spec_g = spec_b = 0.0
            body_r, body_g, body_b = ambient[0], ambient[1], ambient[2]
            px = x * right_x + y * up_x + z * fwd_x + cam[EYE]
            py = x * right_y + y * up_y + z * fwd_y + cam[EYE + 1]
            pz = x * right_z + y * up_z + z * fwd_z + cam[EYE + 2]
            for k in range(lights.shape[0]):
                lx, ly, lz, scale = toward_light(lights, k, px, py, pz)
                r = lights[k, LIGHT_RADIANCE] * scale
                g = lights[k, LIGHT_RADIANCE + 1] * scale
                b = lights[k, LIGHT_RADIANCE + 2] * scale
                lit = max(wx * lx + wy * ly + wz * lz, 0.0)
                hx, hy, hz = lx + ex, ly + ey, lz + ez
                hl = math.sqrt(hx * hx + hy * hy + hz * hz)
                if lit > 0.0 and hl > 0.0:
                    cos_h = max((wx * hx + wy * hy + wz * hz) / hl, 0.0)
                    cos_d = max((lx * hx + ly * hy + lz * hz) / hl, 0.0)
                    f = f0 + (1.0 - f0) * (1.0 - cos_d) ** 5
                    # Normalised Blinn-Phong: the highlight's energy keeps with its size.
                    peak = params[SPECULAR] * f * lit * (params[SHININESS] + 8.0) / (8.0 * math.pi)
                    spec = peak * cos_h ** params[SHININESS]
                    spec_r += spec * r
                    spec_g += spec * g
                    spec_b += spec * b
                above = max(ly, 0.0)
                body_r += r * above
                body_g += g * above
                body_b += b * above
            # Refraction: what lies behind, shifted with the surface's tilt and the depth
            # of liquid the light crosses.
            ppm = cam[SCALE] if ortho else cam[SCALE] / z
            reach = 0.1 * height
            du = min(max(params[REFRACTION] * t * nx * ppm, -reach), reach)
            dv = min(max(-params[REFRACTION] * t * ny * ppm, -reach), reach)
            back_r, back_g, back_b = _sample(
                behind, opaque, z, col + 0.5 + du, row + 0.5 + dv, row, col
            )
            tr = math.exp(-params[SIGMA_R] * t)
            tg = math.exp(-params[SIGMA_G] * t)
            tb = math.exp(-params[SIGMA_B] * t)
            # Light scattered back by the body grows with the light it takes out of the
            # view (the mean over the channels), in the liquid's own tint.
            taken = 1.0 - (tr + tg + tb) / 3.0
            inside_r = back_r * tr + params[DEEP_R] * body_r * taken
            inside_g = back_g * tg + params[DEEP_G] * body_g * taken
            inside_b = back_b * tb + params[DEEP_B] * body_b * taken
            out_r = (1.0 - fresnel) * inside_r + fresnel * sky_r + spec_r
            out_g = (1.0 - fresnel) * inside_g + fresnel * sky_g + spec_g
            out_b = (1.0 - fresnel) * inside_b + fresnel * sky_b + spec_b
            cover = outline * min(t / params[EDGE], 1.0)
            base_r, base_g, base_b = behind[row, col, 0], behind[row, col, 1], behind[row, col, 2]
            color[row, col, 0] = base_r + cover * (out_r - base_r)
            color[row, col, 1] = base_g + cover * (out_g - base_g)
            color[row, col, 2] = base_b + cover * (out_b - base_b)
            if cover > 0.5:
                # A radius behind the front: froth riding on the surface stays in view.
                depth[row, col] = z + params[EDGE]
