"""Compiled kernels of the cloud volumes: procedural cloud density, and particles splatted.

Both write a density grid indexed ``[k, j, i]`` (nz, ny, nx), the layout of
:class:`motes.gridfluid.GridFluid`, with cell centres at
``origin + (i + 0.5, j + 0.5, k + 0.5) * cell_size``. Both run ``prange`` over whole rows
or planes of the grid, each computed serially by one thread, so the bits do not depend on
the thread count (:mod:`motes._jit`).
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import block_bounds, block_count, device, parallel_kernel, serial_kernel
from ..forces.curl_noise import _fraction, _hash, _lattice_cell, _noise

#: Perlin's improved noise has a standard deviation of about 0.27 (measured over 10⁶
#: random points); an fBm of octaves with gain ½, divided by the sum of its amplitudes,
#: about 0.16. ``CONTRAST / Σ amplitudes`` maps it to a base of standard deviation about
#: 0.2 around ½ (clamped to [0, 1]), so that coverages of 0.2-0.8 span sparse to overcast.
CONTRAST = 1.3

#: Each octave of the fBm is shifted by a multiple of this [lattice cells] so that the
#: octaves' lattice points, where gradient noise is zero, do not line up at the origin.
OCTAVE_SHIFT = 37.13


# -- noise -------------------------------------------------------------------------------
@device
def _perlin(hash_pairs, ramp_pairs, table, x, y, z):
    """Perlin's (2002) improved noise at lattice coordinates ``(x, y, z)``, in [-1, 1]."""
    real = np.float64
    low, high = _hash(
        hash_pairs,
        ramp_pairs,
        table,
        _lattice_cell(x, real),
        _lattice_cell(y, real),
        _lattice_cell(z, real),
    )
    fx, ux, dux = _fraction(x, real)
    fy, uy, duy = _fraction(y, real)
    fz, uz, duz = _fraction(z, real)
    value, _, _, _ = _noise(low, high, fx, fy, fz, ux, uy, uz, dux, duy, duz, real)
    return value


@device
def _fbm(hash_pairs, ramp_pairs, x, y, z, octaves):
    """Fractal Brownian motion of Perlin noise: ``Σ_o 2^-o N(2^o p + o s)`` over the sum
    of the amplitudes (``s`` = :data:`OCTAVE_SHIFT`), about [-1, 1]."""
    total = 0.0
    frequency = 1.0
    amplitude = 1.0
    norm = 0.0
    for o in range(octaves):
        shift = o * OCTAVE_SHIFT
        total += amplitude * _perlin(
            hash_pairs, ramp_pairs, 0, frequency * x + shift, frequency * y, frequency * z - shift
        )
        norm += amplitude
        frequency *= 2.0
        amplitude *= 0.5
    return total / norm


_MASK = np.uint64(0xFFFFFFFF)


@device
def _cell_hash(x, y, z, key):
    """A 32-bit hash of the integer cell ``(x, y, z)`` and ``key`` (uint64 below 2³²).

    The coordinates, multiplied by large odd constants, are combined and then mixed by
    alternating xor-shifts and odd multiplies (the "finaliser" construction of integer
    hashes), so neighbouring cells get unrelated bits."""
    h = (np.uint64(x) & _MASK) * np.uint64(0x8DA6B343)
    h ^= (np.uint64(y) & _MASK) * np.uint64(0xD8163841)
    h ^= (np.uint64(z) & _MASK) * np.uint64(0xCB1AB31F)
    h = (h ^ key) & _MASK
    h ^= h >> np.uint64(16)
    h = (h * np.uint64(0x7FEB352D)) & _MASK
    h ^= h >> np.uint64(15)
    h = (h * np.uint64(0x846CA68B)) & _MASK
    h ^= h >> np.uint64(16)
    return h


@device
def _worley(x, y, z, key):
    """Worley (1996) cellular noise F1: the distance from ``(x, y, z)`` [lattice cells] to
    the nearest of the feature points, one at a hashed place in each unit cell, searched
    over the 27 cells around (a point two cells away is nearer for about one point in two
    million, by about 0.01: measured against a search of 125). In [0, √3]."""
    cx = np.floor(x)
    cy = np.floor(y)
    cz = np.floor(z)
    fx = x - cx
    fy = y - cy
    fz = z - cz
    ix = np.int64(cx)
    iy = np.int64(cy)
    iz = np.int64(cz)
    best = 27.0
    scale = 1.0 / 1024.0
    for dz in range(-1, 2):
        for dy in range(-1, 2):
            for dx in range(-1, 2):
                h = _cell_hash(ix + dx, iy + dy, iz + dz, key)
                # three 10-bit fractions of the hash: the feature point in its cell
                px = dx + (np.float64(h & np.uint64(1023)) + 0.5) * scale - fx
                py = dy + (np.float64((h >> np.uint64(10)) & np.uint64(1023)) + 0.5) * scale - fy
                pz = dz + (np.float64((h >> np.uint64(20)) & np.uint64(1023)) + 0.5) * scale - fz
                d2 = px * px + py * py + pz * pz
                best = min(best, d2)
    return np.sqrt(best)


@device
def _billows(x, y, z, key, octaves):
    """Billowy detail in [0, 1]: an fBm of inverted Worley noise ``1 - F1`` (lumps
    around every feature point, the cauliflower of cumulus), octaves with gain ½."""
    total = 0.0
    frequency = 1.0
    amplitude = 1.0
    norm = 0.0
    for o in range(octaves):
        shift = o * OCTAVE_SHIFT
        f1 = _worley(frequency * x - shift, frequency * y + shift, frequency * z, key)
        total += amplitude * max(0.0, 1.0 - f1)
        norm += amplitude
        frequency *= 2.0
        amplitude *= 0.5
    return total / norm


# -- cumulus ------------------------------------------------------------------------------
#: The base shape's noise lattice is this many times taller than wide, so that a cloud's
#: footprint changes little with height: columns with flat bases under their domes, not
#: shelves where the footprint at the base sticks out from under the one above.
STRETCH = 1.5
#: Fractions of the layer over which the height gradient rises at the bottom and falls at
#: the top (:func:`cumulus_profile`).
BOTTOM = 0.08
TOP = 0.75
#: Fraction of the layer over which the density rises linearly from the base.
BASE_SOFTNESS = 0.3


@device
def _smoothstep(a, b, t):
    s = min(max((t - a) / (b - a), 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)


@device
def cumulus_profile(h, bottom, top):
    """Cumulus height gradient at relative height ``h`` in the layer [0, 1]: a quick rise
    over the lowest ``bottom`` of the layer (flat-ish bases), 1 in the middle, a smooth
    fall over the top ``top`` (rounded tops: only the strongest noise reaches up there).
    0 outside the layer."""
    if h <= 0.0 or h >= 1.0:
        return 0.0
    return _smoothstep(0.0, bottom, h) * (1.0 - _smoothstep(1.0 - top, 1.0, h))


@parallel_kernel
def cloud_density(
    nx,
    ny,
    nz,
    x0,
    y0,
    z0,
    cell,
    inv_scale,
    inv_scale_y,
    inv_detail_scale,
    shift,
    detail_shift,
    base,
    top,
    coverage,
    erosion,
    density,
    octaves,
    detail_octaves,
    hash_pairs,
    ramp_pairs,
    key,
    out,
):
    """``out[k, j, i]``: cumulus density at the cell centre ``p = (x0, y0, z0) + (i, j, k)
    cell`` [m], its noise read at ``p + shift`` (the wind's offset).

    Schneider & Vos (2015), "The real-time volumetric cloudscapes of Horizon Zero Dawn":

    - base shape ``b = clamp(½ + C fbm(q), 0, 1)``, Perlin fBm at ``q = (p + shift) /
      (scale, STRETCH scale, scale)`` (``C`` = :data:`CONTRAST`; the lattice taller than
      wide, :data:`STRETCH`);
    - height gradient ``x = b g(h)``, ``h = (y - base) / (top - base)``
      (:func:`cumulus_profile` with :data:`BOTTOM`, :data:`TOP`);
    - coverage ``d = max(0, x - (1 - coverage))`` (their ``remap(x, 1 - c, 1, 0, 1) c``);
    - erosion by billowy detail ``D`` (:func:`_billows` at ``(p + detail_shift) /
      detail_scale``): ``d' = max(0, (d - e) / (1 - e))``, ``e = erosion D``;
    - ``out = density min(h / BASE_SOFTNESS, 1) d'`` (their density height gradient:
      lighter toward the base).

    Every step is non-decreasing in ``d``, so more coverage never takes density away. Rows
    ``(k, j)`` are independent and each computed serially: the bits do not depend on the
    thread count.
    """
    sx, sy, sz = shift[0], shift[1], shift[2]
    dx, dy, dz = detail_shift[0], detail_shift[1], detail_shift[2]
    threshold = 1.0 - coverage
    inv_layer = 1.0 / (top - base)
    for row in numba.prange(nz * ny):
        k = row // ny
        j = row - k * ny
        y = y0 + j * cell
        z = z0 + k * cell
        h = (y - base) * inv_layer
        g = cumulus_profile(h, BOTTOM, TOP)
        # lighter toward the base (their "density height gradient"): a flat base, but
        # soft, not a dense slab
        thin = density * min(h / BASE_SOFTNESS, 1.0)
        if g <= threshold:  # b <= 1, so no cell of the row reaches the threshold
            for i in range(nx):
                out[k, j, i] = 0.0
            continue
        for i in range(nx):
            x = x0 + i * cell
            b = 0.5 + CONTRAST * _fbm(
                hash_pairs,
                ramp_pairs,
                (x + sx) * inv_scale,
                (y + sy) * inv_scale_y,
                (z + sz) * inv_scale,
                octaves,
            )
            b = min(max(b, 0.0), 1.0)
            d = b * g - threshold
            if d <= 0.0:
                out[k, j, i] = 0.0
                continue
            if erosion > 0.0:
                detail = _billows(
                    (x + dx) * inv_detail_scale,
                    (y + dy) * inv_detail_scale,
                    (z + dz) * inv_detail_scale,
                    key,
                    detail_octaves,
                )
                e = erosion * detail
                d = max(0.0, (d - e) / (1.0 - e))
            out[k, j, i] = thin * d


# -- splatting ----------------------------------------------------------------------------
#: The splat kernel is a Gaussian of standard deviation R / SIGMAS, truncated at R.
SIGMAS = 3.0


@device
def _weight(u):
    """One axis's factor of the splat kernel at ``u`` = offset / R: a Gaussian of standard
    deviation ``1 / SIGMAS`` lowered by its value at 1, so that it reaches 0 there
    (continuous), 0 beyond."""
    if u <= -1.0 or u >= 1.0:
        return 0.0
    floor = np.exp(-0.5 * SIGMAS * SIGMAS)
    return (np.exp(-0.5 * SIGMAS * SIGMAS * u * u) - floor) / (1.0 - floor)


@parallel_kernel
def splat_spans(x, y, z, kernel_radius, cell, first, count):
    """``first[a, p]``, ``count[a, p]``: the cells along axis ``a`` (unbounded lattice)
    whose centres ``(m + 0.5) cell`` lie strictly within the kernel radius of particle
    ``p``. Positions relative to the grid's origin [m]."""
    n = x.shape[0]
    inv_cell = 1.0 / cell
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for p in range(start, stop):
            r = kernel_radius[p]
            for a in range(3):
                c = x[p] if a == 0 else (y[p] if a == 1 else z[p])
                lo = np.int64(np.floor((c - r) * inv_cell - 0.5)) + 1
                hi = np.int64(np.ceil((c + r) * inv_cell - 0.5)) - 1
                first[a, p] = lo
                count[a, p] = max(hi - lo + 1, 0)


@parallel_kernel
def splat_weights(x, y, z, kernel_radius, mass, cell, first, offsets, weights, amplitude):
    """Each particle's axis factors at its cells, ``weights[offsets[a, p] + m]`` for cell
    ``first[a, p] + m`` along axis ``a``, and ``amplitude[p]``: the factor that makes its
    weights over the unbounded lattice, times the cell volume, sum to its ``mass`` [m³ of
    unit density]: ``mass / (cell³ Σ w_x Σ w_y Σ w_z)`` (the kernel is separable; the sums
    of the float32 weights the splat uses), 0 for a particle of no mass."""
    n = x.shape[0]
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for p in range(start, stop):
            inv_r = 1.0 / kernel_radius[p]
            product = 1.0
            for a in range(3):
                c = x[p] if a == 0 else (y[p] if a == 1 else z[p])
                total = 0.0
                for e in range(offsets[a, p], offsets[a, p + 1]):
                    m = first[a, p] + (e - offsets[a, p])
                    w = np.float32(_weight(((m + 0.5) * cell - c) * inv_r))
                    weights[e] = w
                    total += w
                product *= total
            amplitude[p] = 0.0
            if mass[p] > 0.0 and product > 0.0:
                amplitude[p] = mass[p] / (cell * cell * cell * product)


@serial_kernel
def bin_by_plane(first, count, amplitude, nz, starts, order):
    """Particles listed by the planes ``k`` of the grid they reach, in particle order:
    plane ``k``'s are ``order[starts[k]:starts[k + 1]]``. ``starts`` (nz + 1,) is filled;
    ``order`` must have room for every (plane, particle) pair. Particles of zero
    amplitude are left out."""
    n = amplitude.shape[0]
    starts[:] = 0
    for p in range(n):
        if amplitude[p] > 0.0:
            for k in range(max(first[2, p], 0), min(first[2, p] + count[2, p], nz)):
                starts[k + 1] += 1
    for k in range(nz):
        starts[k + 1] += starts[k]
    fill = starts[:-1].copy()
    for p in range(n):
        if amplitude[p] > 0.0:
            for k in range(max(first[2, p], 0), min(first[2, p] + count[2, p], nz)):
                order[fill[k]] = p
                fill[k] += 1


@parallel_kernel
def splat_planes(first, count, offsets, weights, amplitude, starts, order, out):
    """``out[k, j, i] += a_p w_x(i) w_y(j) w_z(k)`` for every particle ``p`` reaching
    plane ``k``, in particle order; one plane per ``prange`` iteration, so the sums'
    order, and the bits, do not depend on the thread count. ``out`` (nz, ny, nx)
    float32."""
    nz, ny, nx = out.shape
    for k in numba.prange(nz):
        for e in range(starts[k], starts[k + 1]):
            p = order[e]
            az = amplitude[p] * weights[offsets[2, p] + k - first[2, p]]
            i0 = max(first[0, p], 0)
            i1 = min(first[0, p] + count[0, p], nx)
            j0 = max(first[1, p], 0)
            j1 = min(first[1, p] + count[1, p], ny)
            if i1 <= i0 or j1 <= j0:
                continue
            ox = offsets[0, p] - first[0, p]
            wx = weights[ox + i0 : ox + i1]
            oy = offsets[1, p] - first[1, p]
            for j in range(j0, j1):
                c = np.float32(az * weights[oy + j])
                row = out[k, j, i0:i1]
                for t in range(wx.shape[0]):
                    row[t] += c * wx[t]
