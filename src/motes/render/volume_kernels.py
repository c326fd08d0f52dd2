r"""Camera rays through a volume: ray marching, the froxel grid, and particles' lookup.

Each pixel's ray ``x(t) = o + t d`` is cut in segments of ``step`` metres on a lattice
``t_k = (k + ξ) Δt`` (``ξ`` in [0, 1) a hash of the pixel, so the slicing of a regular
lattice turns into fine noise), clipped to the box, to ``[near, far]`` and to the opaque
depth ``frame.depth``. ``d`` has a unit component along the view axis, so ``t`` *is* the
view depth for both projections. Each segment of length ``h`` takes the medium at its
midpoint as constant: density ``ρ`` (trilinear), extinction ``σ = σ_t ρ`` and source
``j`` (radiance per metre), and is integrated exactly for a constant medium:

.. math::

    L \mathrel{+}= T\, j\, h\, \frac{1 - e^{-σ h}}{σ h}, \qquad T \mathrel{*}= e^{-σ h},

    j = σ_t ρ\, a \odot \Big(\sum_l \hat p(\cos θ_l)\, T_l(x)\, L_l
        + \tfrac12 \big(S\, T_\uparrow(x) + G\, T_\downarrow(x)\big)\Big)
        + e\, ρ\, B(\mathcal T(x)),

with ``a`` the albedo, ``T_l`` the light's transmittance volume (:mod:`.volume_light`),
``p̂`` Henyey & Greenstein's (1941) phase function times 4π (mean 1 over directions, the
renderer's lit-particle convention), ``S`` and ``G`` the ambient sky and ground colours
reaching the point from straight above and below, ``e`` the emission scale and ``B`` the
blackbody colour of the temperature ``𝒯`` (a table). A uniform slab therefore transmits
exactly ``exp(-σ d)`` and an absorbing, emitting one glows ``e B (1 - exp(-σ d)) / σ_t``.

Empty space is leapt over: a sample in a brick at Chebyshev distance ``D > 0`` from the
nearest brick holding medium (:func:`.volume_light.brick_distances`) jumps to where the
ray leaves the cube of empty bricks within ``D - 1``, on the same lattice (the segments
skipped have midpoints there, where the density is 0, so the result is the same as
marching them); rays are marched only inside the box around the non-empty bricks, and
stop once ``T < TERMINATE``. The pixel becomes ``color T + L`` and its transmittance is
multiplied by ``T``. The same kernel marches the froxel grid's rays, cutting their
segments at its depth slices and recording ``(S, T)`` there.

A sample reads the first four channels of its eight voxels as eight 16-byte loads
(:func:`gather4`, SIMD lanes that add in the scalar order: the same bits), the common
case of one light and the ambient whole. Rows are independent and each is one serial
loop, in parallel over a fixed interleaving of rows: the image does not depend on the
number of threads.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic, overload

from .._jit import block_bounds, block_count, device, parallel_kernel
from .camera import EYE, FAR, FORWARD, HEIGHT, NEAR, ORTHO, RIGHT, SCALE, UP, WIDTH, to_screen
from .shading import LIGHT_DIRECTION, LIGHT_FALLOFF, LIGHT_POINT, LIGHT_POSITION, LIGHT_RADIANCE
from .volume_light import axis_weights, trilinear

# Layout of the packed medium (float64) the kernels read: the grid's origin [m] and cell
# [m]; extinction [1/m per unit density]; albedo (3); anisotropy g; emission scale [1/m
# per unit density]; step [m]; jitter flag; kelvin per entry of the blackbody table; and
# the channels of the temperature, of the first light and of the ambient's light from
# above (the next one: from below), -1 where absent.
ORIGIN, CELL, EXTINCTION, ALBEDO, ANISOTROPY, EMISSION, STEP, JITTER = 0, 3, 4, 5, 8, 9, 10, 11
TABLE_STEP, TEMPERATURE_CH, LIGHTS_CH, AMBIENT_CH = 12, 13, 14, 15
MEDIUM_SIZE = 16

#: A ray stops when less than this fraction of the light behind it gets through.
TERMINATE = 1e-3


@device
def henyey_greenstein(g, cos_theta):
    """Henyey & Greenstein's phase function times 4π: ``(1 - g²) / (1 + g² - 2 g cos θ)^{3/2}``
    (mean 1 over the sphere; 1 everywhere for ``g = 0``). ``θ`` is the angle between the
    light's travel and the scattered light's, so ``g > 0`` scatters forward."""
    d = 1.0 + g * g - 2.0 * g * cos_theta
    return (1.0 - g * g) / (d * math.sqrt(d))


@device
def blackbody(table, kelvin_step, temperature):
    """Linear RGB of the blackbody table at ``temperature`` [K], interpolated linearly
    (entry ``e`` at ``e * kelvin_step``; clamped to the table's ends)."""
    u = temperature / kelvin_step
    n = table.shape[0]
    if u <= 0.0:
        return table[0, 0], table[0, 1], table[0, 2]
    e = min(int(u), n - 2)
    f = min(u - e, 1.0)
    return (
        table[e, 0] + f * (table[e + 1, 0] - table[e, 0]),
        table[e, 1] + f * (table[e + 1, 1] - table[e, 1]),
        table[e, 2] + f * (table[e + 1, 2] - table[e, 2]),
    )


@device
def corners(medium, nx, ny, nz, channels, x, y, z):
    """Offsets into the raveled grid of the eight voxels around the world point ``(x, y,
    z)`` [m] and their trilinear weights (clamped to the edge voxels): 16 values, the
    offsets unsigned (Numba then indexes without a wraparound test)."""
    inv_cell = 1.0 / medium[CELL]
    i0, i1, fx = axis_weights((x - medium[ORIGIN]) * inv_cell - 0.5, nx)
    j0, j1, fy = axis_weights((y - medium[ORIGIN + 1]) * inv_cell - 0.5, ny)
    k0, k1, fz = axis_weights((z - medium[ORIGIN + 2]) * inv_cell - 0.5, nz)
    uy, uz, uc = np.uint64(ny), np.uint64(nz), np.uint64(channels)
    r00 = (np.uint64(i0) * uy + np.uint64(j0)) * uz
    r01 = (np.uint64(i0) * uy + np.uint64(j1)) * uz
    r10 = (np.uint64(i1) * uy + np.uint64(j0)) * uz
    r11 = (np.uint64(i1) * uy + np.uint64(j1)) * uz
    a, b = np.uint64(k0), np.uint64(k1)
    gx, gy, gz = 1.0 - fx, 1.0 - fy, 1.0 - fz
    return (
        (r00 + a) * uc, (r00 + b) * uc, (r01 + a) * uc, (r01 + b) * uc,
        (r10 + a) * uc, (r10 + b) * uc, (r11 + a) * uc, (r11 + b) * uc,
        gx * gy * gz, gx * gy * fz, gx * fy * gz, gx * fy * fz,
        fx * gy * gz, fx * gy * fz, fx * fy * gz, fx * fy * fz,
    )  # fmt: skip


@device
def gather(flat, c, ch):
    """Channel ``ch`` (unsigned) interpolated with the corners ``c`` of :func:`corners`."""
    return (
        c[8] * flat[c[0] + ch] + c[9] * flat[c[1] + ch] + c[10] * flat[c[2] + ch]
        + c[11] * flat[c[3] + ch] + c[12] * flat[c[4] + ch] + c[13] * flat[c[5] + ch]
        + c[14] * flat[c[6] + ch] + c[15] * flat[c[7] + ch]
    )  # fmt: skip


def gather4(flat, c):
    """Channels 0 to 3 interpolated with the corners ``c`` of :func:`corners`: the
    :func:`gather` of each, in the same order (so the same bits)."""
    return (gather(flat, c, 0), gather(flat, c, 1), gather(flat, c, 2), gather(flat, c, 3))


@intrinsic
def _gather4(typingctx, flat, c):
    """:func:`gather4` as four lanes of one SIMD vector: each corner's four channels are
    one 16-byte load, widened to double and added times the corner's weight (the adds
    in the scalar order and without fast-math flags: the same bits)."""
    if not (isinstance(flat, types.Array) and flat.dtype == types.float32 and flat.ndim == 1):
        return None

    def codegen(context, builder, signature, args):
        array = context.make_array(signature.args[0])(context, builder, args[0])
        corners_ = cgutils.unpack_tuple(builder, args[1])
        single, double = ir.FloatType(), ir.DoubleType()
        lanes4, wide4 = ir.VectorType(single, 4), ir.VectorType(double, 4)
        i32 = ir.IntType(32)
        lanes_i32 = ir.VectorType(i32, 4)
        total = ir.Constant(wide4, None)
        for k in range(8):
            offset = corners_[k]
            value = builder.load(builder.gep(array.data, [offset]), align=4, typ=lanes4)
            undefined = ir.Constant(wide4, ir.Undefined)
            weight = builder.insert_element(undefined, corners_[8 + k], ir.Constant(i32, 0))
            weight = builder.shuffle_vector(weight, undefined, ir.Constant(lanes_i32, [0] * 4))
            term = builder.fmul(builder.fpext(value, wide4), weight)
            total = term if k == 0 else builder.fadd(total, term)
        lanes = [builder.extract_element(total, ir.Constant(i32, k)) for k in range(4)]
        return context.make_tuple(builder, signature.return_type, lanes)

    return types.UniTuple(types.float64, 4)(flat, c), codegen


@overload(gather4, inline="always")
def _gather4_compiled(flat, c):
    return lambda flat, c: _gather4(flat, c)


@device
def channel(first4, flat, c, ch):
    """Channel ``ch``: from ``first4`` (:func:`gather4`) below 4, else gathered."""
    if ch == 0:
        return first4[0]
    if ch == 1:
        return first4[1]
    if ch == 2:
        return first4[2]
    if ch == 3:
        return first4[3]
    return gather(flat, c, np.uint64(ch))


@device
def source(flat, shape, medium, lights, ambient, weights, table, x, y, z, rx, ry, rz):
    """Density and emitted plus in-scattered radiance per metre ``(ρ, jr, jg, jb)`` at the
    world point ``(x, y, z)`` seen along the unit direction ``r`` (see the module
    docstring). ``flat`` is the packed grid raveled, ``shape`` its (nx, ny, nz, C);
    ``weights[l]`` directional light ``l``'s phase times radiance for this ray (point
    lights' phase is evaluated here)."""
    c = corners(medium, shape[0], shape[1], shape[2], shape[3], x, y, z)
    first4 = gather4(flat, c)
    rho = first4[0]
    if rho <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    lr = 0.0
    lg = 0.0
    lb = 0.0
    first = int(medium[LIGHTS_CH])
    for k in range(lights.shape[0]):
        seen = channel(first4, flat, c, first + k)
        if lights[k, LIGHT_POINT] > 0.5:
            dx = lights[k, LIGHT_POSITION] - x
            dy = lights[k, LIGHT_POSITION + 1] - y
            dz = lights[k, LIGHT_POSITION + 2] - z
            d2 = max(dx * dx + dy * dy + dz * dz, 1e-12)
            d = math.sqrt(d2)
            seen *= henyey_greenstein(medium[ANISOTROPY], (dx * rx + dy * ry + dz * rz) / d)
            if lights[k, LIGHT_FALLOFF] > 0.5:
                seen /= d2
            lr += seen * lights[k, LIGHT_RADIANCE]
            lg += seen * lights[k, LIGHT_RADIANCE + 1]
            lb += seen * lights[k, LIGHT_RADIANCE + 2]
        else:
            lr += seen * weights[k, 0]
            lg += seen * weights[k, 1]
            lb += seen * weights[k, 2]
    above = int(medium[AMBIENT_CH])
    if above >= 0:
        up = 0.5 * channel(first4, flat, c, above)
        down = 0.5 * channel(first4, flat, c, above + 1)
        lr += ambient[0] * up + ambient[3] * down
        lg += ambient[1] * up + ambient[4] * down
        lb += ambient[2] * up + ambient[5] * down
    scatter = medium[EXTINCTION] * rho
    jr = scatter * medium[ALBEDO] * lr
    jg = scatter * medium[ALBEDO + 1] * lg
    jb = scatter * medium[ALBEDO + 2] * lb
    hot = int(medium[TEMPERATURE_CH])
    if hot >= 0:
        kelvin = channel(first4, flat, c, hot)
        br, bg, bb = blackbody(table, medium[TABLE_STEP], kelvin)
        glow = medium[EMISSION] * rho
        jr += glow * br
        jg += glow * bg
        jb += glow * bb
    return rho, jr, jg, jb


@device
def camera_ray(cam, sx, sy):
    """Origin and direction of the ray through screen point ``(sx, sy)`` [px]; the
    direction's component along the view axis is 1, so the ray parameter is the view
    depth [m]."""
    a = (sx - 0.5 * cam[WIDTH]) / cam[SCALE]
    b = (0.5 * cam[HEIGHT] - sy) / cam[SCALE]
    if cam[ORTHO] > 0.5:
        return (
            cam[EYE] + a * cam[RIGHT] + b * cam[UP],
            cam[EYE + 1] + a * cam[RIGHT + 1] + b * cam[UP + 1],
            cam[EYE + 2] + a * cam[RIGHT + 2] + b * cam[UP + 2],
            cam[FORWARD],
            cam[FORWARD + 1],
            cam[FORWARD + 2],
        )
    return (
        cam[EYE],
        cam[EYE + 1],
        cam[EYE + 2],
        cam[FORWARD] + a * cam[RIGHT] + b * cam[UP],
        cam[FORWARD + 1] + a * cam[RIGHT + 1] + b * cam[UP + 1],
        cam[FORWARD + 2] + a * cam[RIGHT + 2] + b * cam[UP + 2],
    )


@device
def _slab(o, d, lo, hi, t0, t1):
    """Narrow ``[t0, t1]`` to where ``o + t d`` lies between ``lo`` and ``hi`` (one axis)."""
    if d == 0.0:
        if o < lo or o > hi:
            return math.inf, -math.inf
        return t0, t1
    ta = (lo - o) / d
    tb = (hi - o) / d
    return max(t0, min(ta, tb)), min(t1, max(ta, tb))


@device
def box_span(ox, oy, oz, dx, dy, dz, lo, hi):
    """Ray parameters ``[t0, t1]`` inside the box ``[lo, hi]`` (``t0 > t1``: missed)."""
    t0, t1 = _slab(ox, dx, lo[0], hi[0], -math.inf, math.inf)
    t0, t1 = _slab(oy, dy, lo[1], hi[1], t0, t1)
    return _slab(oz, dz, lo[2], hi[2], t0, t1)


@device
def pixel_hash(row, col):
    """A number in [0, 1) from a pixel's row and column (SplitMix64's finaliser)."""
    x = np.uint64(row) * np.uint64(0x9E3779B97F4A7C15) + np.uint64(col)
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    x = x ^ (x >> np.uint64(31))
    return float(x >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@device
def ray_weights(lights, g, rx, ry, rz, weights):
    """``weights[l]``: directional light ``l``'s radiance times its phase along the unit
    direction ``r`` (constant along a ray)."""
    for k in range(lights.shape[0]):
        cos_theta = (
            lights[k, LIGHT_DIRECTION] * rx
            + lights[k, LIGHT_DIRECTION + 1] * ry
            + lights[k, LIGHT_DIRECTION + 2] * rz
        )
        p = henyey_greenstein(g, cos_theta)
        weights[k, 0] = p * lights[k, LIGHT_RADIANCE]
        weights[k, 1] = p * lights[k, LIGHT_RADIANCE + 1]
        weights[k, 2] = p * lights[k, LIGHT_RADIANCE + 2]


@device
def segment_weight(tau, kept):
    """``(1 - e^{-τ}) / τ`` given ``kept = e^{-τ}``: the share of a constant segment's
    source that leaves it (its series below 1e-3, where the difference cancels)."""
    if tau < 1e-3:
        return 1.0 - tau * (0.5 - tau * (1.0 / 6.0))
    return (1.0 - kept) / tau


@device
def leap_exit(ox, oy, oz, dx, dy, dz, bi, bj, bk, reach, size, lo, hi, cell):
    """Ray parameter where the ray leaves the cube of bricks within ``reach`` of brick
    ``(bi, bj, bk)`` (clipped to the box)."""
    span = size * cell
    t = math.inf
    for axis in range(3):
        o = ox if axis == 0 else (oy if axis == 1 else oz)
        d = dx if axis == 0 else (dy if axis == 1 else dz)
        b = bi if axis == 0 else (bj if axis == 1 else bk)
        if d > 0.0:
            t = min(t, (min(lo[axis] + (b + 1 + reach) * span, hi[axis]) - o) / d)
        elif d < 0.0:
            t = min(t, (max(lo[axis] + (b - reach) * span, lo[axis]) - o) / d)
    return t


@device
def _record(record, row, col, slot, lr, lg, lb, seen):
    record[row, col, slot, 0] = lr
    record[row, col, slot, 1] = lg
    record[row, col, slot, 2] = lb
    record[row, col, slot, 3] = seen


@parallel_kernel
def march(cam, grid, bricks, size, lo, hi, inner, medium, lights, ambient, table, rows, x0, y0,
          factor, depth, color, trans, z0, thick, record):  # fmt: skip
    """March the rays of a grid of screen points through the volume.

    Row ``i``, column ``j`` of the grid is the ray through screen point ``(x0 + (j + 0.5)
    factor, y0 + (i + 0.5) factor)`` [px] (``0, 0, 1`` for the frame's pixels); ``rows``
    the order in which rows are handed to threads. ``lo``, ``hi``: the grid's box [m];
    ``inner`` (2, 3): the box around its non-empty bricks, where rays are marched (the
    density is 0 outside it). Each ray stops at the view depth ``depth[i, j]`` [m],
    composites the volume over ``color[i, j]`` (3) in place and multiplies ``trans[i, j]``
    by its transmittance.

    With a ``record`` of shape (H, W, slices + 1, 4) (the froxel grid) rather than
    (1, 1, 1, 4), segments are also cut at the view depths ``z0 + s thick`` and the
    radiance gathered and transmittance at each, ``(S, T)``, are recorded in
    ``record[i, j, s]`` (the last values past the ray's end); there is no jitter then.
    """
    width = depth.shape[1]
    flat = grid.reshape(-1)
    shape = grid.shape
    cell = medium[CELL]
    inv_brick = 1.0 / (cell * size)
    dt_world = medium[STEP]
    extinction = medium[EXTINCTION]
    cuts = record.shape[2] - 1
    recording = cuts > 0
    jitter = medium[JITTER] > 0.5 and not recording
    bx, by, bz = bricks.shape
    for r in numba.prange(rows.shape[0]):
        row = rows[r]
        weights = np.empty((lights.shape[0], 3))
        for col in range(width):
            ox, oy, oz, dx, dy, dz = camera_ray(
                cam, x0 + (col + 0.5) * factor, y0 + (row + 0.5) * factor
            )
            t0, t1 = box_span(ox, oy, oz, dx, dy, dz, inner[0], inner[1])
            t0 = max(t0, cam[NEAR])
            t1 = min(t1, cam[FAR], depth[row, col])
            seen = 1.0
            lr = 0.0
            lg = 0.0
            lb = 0.0
            cut = 0  # the next depth cut to record
            while recording and cut <= cuts and z0 + cut * thick <= t0:
                _record(record, row, col, cut, lr, lg, lb, seen)
                cut += 1
            next_cut = z0 + cut * thick if recording and cut <= cuts else math.inf
            if t0 < t1:
                length = math.sqrt(dx * dx + dy * dy + dz * dz)
                rx, ry, rz = dx / length, dy / length, dz / length
                ray_weights(lights, medium[ANISOTROPY], rx, ry, rz, weights)
                dt = dt_world / length
                inv_dt = length / dt_world
                offset = pixel_hash(row, col) * dt if jitter else 0.0
                ta = t0
                while ta < t1:
                    k = math.floor((ta - offset) * inv_dt)
                    end = offset + (k + 1) * dt
                    if end <= ta:  # ta is a lattice point rounded down
                        k += 1
                        end = offset + (k + 1) * dt
                    tb = min(end, t1, next_cut)
                    tm = 0.5 * (ta + tb)
                    x, y, z = ox + tm * dx, oy + tm * dy, oz + tm * dz
                    bi = min(max(int((x - lo[0]) * inv_brick), 0), bx - 1)
                    bj = min(max(int((y - lo[1]) * inv_brick), 0), by - 1)
                    bk = min(max(int((z - lo[2]) * inv_brick), 0), bz - 1)
                    empty = bricks[bi, bj, bk]
                    if empty > 0:
                        leave = leap_exit(
                            ox, oy, oz, dx, dy, dz, bi, bj, bk, empty - 1, size, lo, hi, cell
                        )
                        # on to the last lattice point before the exit: the segments up
                        # to it have their midpoints inside the empty cube
                        tb = min(max(tb, offset + math.floor((leave - offset) * inv_dt) * dt), t1)
                    else:
                        rho, jr, jg, jb = source(
                            flat, shape, medium, lights, ambient, weights, table, x, y, z, rx,
                            ry, rz,
                        )  # fmt: skip
                        if rho > 0.0:
                            h = (tb - ta) * length
                            tau = extinction * rho * h
                            kept = math.exp(-tau)
                            share = seen * h * segment_weight(tau, kept)
                            lr += share * jr
                            lg += share * jg
                            lb += share * jb
                            seen *= kept
                    while next_cut <= tb:
                        _record(record, row, col, cut, lr, lg, lb, seen)
                        cut += 1
                        next_cut = z0 + cut * thick if cut <= cuts else math.inf
                    if seen < TERMINATE:
                        break
                    ta = tb
            while recording and cut <= cuts:
                _record(record, row, col, cut, lr, lg, lb, seen)
                cut += 1
            color[row, col, 0] = color[row, col, 0] * seen + lr
            color[row, col, 1] = color[row, col, 1] * seen + lg
            color[row, col, 2] = color[row, col, 2] * seen + lb
            trans[row, col] = trans[row, col] * seen


@parallel_kernel
def froxel_lookup(cam, grid, x0, y0, factor, z0, dz, x, y, z, out):
    """``out[p]``: ``(S, T)`` of the froxel grid ``grid`` (recorded by :func:`march`) at the
    centre of particle ``p`` (world ``x, y, z`` [m]), trilinear (clamped to the grid);
    ``(0, 0, 0, 1)`` for a particle behind a perspective camera."""
    n = x.shape[0]
    gh, gw, slices = grid.shape[0], grid.shape[1], grid.shape[2] - 1
    for block in numba.prange(block_count(n)):
        first, stop = block_bounds(block, n)
        for p in range(first, stop):
            sx, sy, depth, _ = to_screen(cam, x[p], y[p], z[p])
            if cam[ORTHO] < 0.5 and depth <= 0.0:
                out[p, 0] = 0.0
                out[p, 1] = 0.0
                out[p, 2] = 0.0
                out[p, 3] = 1.0
                continue
            i0, i1, fi = axis_weights((sy - y0) / factor - 0.5, gh)
            j0, j1, fj = axis_weights((sx - x0) / factor - 0.5, gw)
            s0, s1, fs = axis_weights((depth - z0) / dz, slices + 1)
            for c in range(4):
                out[p, c] = trilinear(grid, c, i0, i1, j0, j1, s0, s1, fi, fj, fs)
