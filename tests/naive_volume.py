"""Slow, obviously-correct NumPy twins of the volume renderer's kernels.

In float64, one voxel, slice or ray at a time, with the formulas written out: the
trilinear interpolation as the eight-corner sum, the light sweep as a loop over slices
of a grid turned so that the light enters by its first slice, and camera rays marched
segment by segment without any empty-space leaping (so the kernels' leaping is checked
to change nothing).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from motes.render.camera import Camera
from motes.render.shading import (
    LIGHT_DIRECTION,
    LIGHT_FALLOFF,
    LIGHT_POINT,
    LIGHT_POSITION,
    LIGHT_RADIANCE,
)
from motes.render.volume import Volume, blackbody_rgb
from motes.render.volume_kernels import AMBIENT_CH, LIGHTS_CH, TEMPERATURE_CH


def trilinear(grid: np.ndarray, point, origin, cell: float) -> np.ndarray:
    """``grid`` (nx, ny, nz, ...) at the world ``point`` [m]: the eight voxels around it
    (centres at ``origin + (i + 0.5) cell``), clamped to the edge ones, weighted by the
    products of the distances along each axis."""
    total = 0.0
    lower, frac = [], []
    for axis in range(3):
        n = grid.shape[axis]
        u = min(max((point[axis] - origin[axis]) / cell - 0.5, 0.0), n - 1.0)
        i0 = min(math.floor(u), max(n - 2, 0))
        lower.append(i0)
        frac.append(u - i0)
    for corner in itertools.product((0, 1), repeat=3):
        weight = 1.0
        index = []
        for axis, c in enumerate(corner):
            weight *= frac[axis] if c else 1.0 - frac[axis]
            index.append(min(lower[axis] + c, grid.shape[axis] - 1))
        total = total + weight * grid[tuple(index)].astype(np.float64)
    return total


def brick_maxima(density: np.ndarray, size: int) -> np.ndarray:
    """Largest density of each brick's voxels and one more each side."""
    shape = tuple(-(-n // size) for n in density.shape)
    out = np.zeros(shape, np.float32)
    for b in itertools.product(*map(range, shape)):
        window = tuple(
            slice(max(k * size - 1, 0), min((k + 1) * size + 1, n))
            for k, n in zip(b, density.shape, strict=True)
        )
        out[b] = density[window].max()
    return out


def brick_distances(maxima: np.ndarray, cap: int) -> np.ndarray:
    """Chebyshev distance [bricks] to the nearest brick with a maximum above 0, by brute
    force over every pair, capped."""
    occupied = np.argwhere(maxima > 0)
    out = np.full(maxima.shape, cap, np.int32)
    for b in itertools.product(*map(range, maxima.shape)):
        if len(occupied):
            out[b] = min(cap, int(np.abs(occupied - np.array(b)).max(axis=1).min()))
    return out


def sweep_depth(density: np.ndarray, toward, extinction: float, cell: float) -> np.ndarray:
    """Optical depth from each voxel centre toward a directional light (unit direction
    ``toward``), slice by slice along the axis it travels most along: the slice facing
    the light gets half a slice's depth, each next one the previous slice's depth read
    bilinearly one slice nearer the light (0 beyond the box, where it counts half its
    own segment) plus the trapezoidal depth of the segment between them."""
    toward = np.asarray(toward, dtype=np.float64)
    axis = int(np.argmax(np.abs(toward)))
    p, q = [a for a in range(3) if a != axis]
    rho = np.transpose(density.astype(np.float64), (axis, p, q))
    if toward[axis] > 0:
        rho = rho[::-1]  # first slice faces the light
    along = abs(toward[axis])
    du, dv = toward[p] / along, toward[q] / along
    half = 0.5 * extinction * cell / along
    na, n_p, nq = rho.shape
    tau = np.zeros_like(rho)
    tau[0] = half * rho[0]
    for s in range(1, na):
        for u in range(n_p):
            for v in range(nq):
                a, b = u + du, v + dv
                if a < -0.5 or a > n_p - 0.5 or b < -0.5 or b > nq - 0.5:
                    tau[s, u, v] = half * rho[s, u, v]
                    continue
                a = min(max(a, 0.0), n_p - 1.0)
                b = min(max(b, 0.0), nq - 1.0)
                a0, b0 = min(int(a), max(n_p - 2, 0)), min(int(b), max(nq - 2, 0))
                a1, b1 = min(a0 + 1, n_p - 1), min(b0 + 1, nq - 1)
                fa, fb = a - a0, b - b0

                def bilinear(field, s=s, a0=a0, a1=a1, b0=b0, b1=b1, fa=fa, fb=fb):
                    return (
                        (1 - fa) * (1 - fb) * field[s - 1, a0, b0]
                        + (1 - fa) * fb * field[s - 1, a0, b1]
                        + fa * (1 - fb) * field[s - 1, a1, b0]
                        + fa * fb * field[s - 1, a1, b1]
                    )

                tau[s, u, v] = bilinear(tau) + half * (rho[s, u, v] + bilinear(rho))
    if toward[axis] > 0:
        tau = tau[::-1]
    return np.transpose(tau, np.argsort((axis, p, q)))


def column_depths(density: np.ndarray, extinction: float, cell: float):
    """Optical depth straight up and straight down from each voxel centre to the box's
    top and bottom, by the trapezoidal rule."""
    rho = density.astype(np.float64)
    ny = rho.shape[1]
    above = np.zeros_like(rho)
    below = np.zeros_like(rho)
    half = 0.5 * extinction * cell
    for j in range(ny):
        above[:, j] = half * rho[:, ny - 1] + sum(
            half * (rho[:, m] + rho[:, m + 1]) for m in range(j, ny - 1)
        )
        below[:, j] = half * rho[:, 0] + sum(
            half * (rho[:, m] + rho[:, m - 1]) for m in range(1, j + 1)
        )
    return above, below


def point_transmittance(volume: Volume, position, factor: int, h: float) -> np.ndarray:
    """Transmittance from the centres of the coarse grid (cells of ``factor`` voxels) to a
    point light, marched in equal midpoint segments of at most ``h`` [m] to the light or
    out of the box (every cell, no brick test)."""
    lo, hi = volume.bounds
    cell = volume.cell_size
    grid = volume.density[..., None]
    shape = tuple(-(-n // factor) for n in volume.shape)
    out = np.ones(shape)
    for c in itertools.product(*map(range, shape)):
        x = lo + np.minimum((np.array(c) + 0.5) * factor, volume.shape) * cell
        d = np.asarray(position, dtype=np.float64) - x
        dist = float(np.linalg.norm(d))
        d = d / dist
        exits = [((hi[a] if d[a] > 0 else lo[a]) - x[a]) / d[a] for a in range(3) if d[a] != 0]
        length = min(dist, max(min(exits), 0.0))
        steps = max(math.ceil(length / h), 1)
        hh = length / steps
        tau = sum(float(trilinear(grid, x + (s + 0.5) * hh * d, lo, cell)[0]) for s in range(steps))
        out[c] = math.exp(-volume.extinction * hh * tau)
    return out


def henyey_greenstein(g: float, cos_theta: float) -> float:
    """The phase function times 4π."""
    return (1 - g * g) / (1 + g * g - 2 * g * cos_theta) ** 1.5


def pixel_hash(row: int, col: int) -> float:
    """SplitMix64's finaliser of ``row * golden + col``, as a number in [0, 1)."""
    mask = (1 << 64) - 1
    x = (row * 0x9E3779B97F4A7C15 + col) & mask
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & mask
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & mask
    x ^= x >> 31
    return (x >> 11) / 2.0**53


def camera_ray(camera: Camera, sx: float, sy: float):
    """Origin and direction (unit component along the view axis) through a screen
    point."""
    right, up, forward = camera.basis
    a = (sx - camera.width / 2) / camera.scale
    b = (camera.height_px / 2 - sy) / camera.scale
    if camera.projection == "orthographic":
        return camera.position + a * right + b * up, forward.copy()
    return camera.position.copy(), forward + a * right + b * up


def box_span(origin, direction, lo, hi) -> tuple[float, float]:
    t0, t1 = -math.inf, math.inf
    for a in range(3):
        if direction[a] == 0:
            if not lo[a] <= origin[a] <= hi[a]:
                return math.inf, -math.inf
            continue
        ta, tb = (lo[a] - origin[a]) / direction[a], (hi[a] - origin[a]) / direction[a]
        t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
    return t0, t1


def source(volume: Volume, lit, point, ray) -> tuple:
    """``(ρ, j)``: density and radiance per metre (3,) at ``point`` seen along the unit
    ``ray``, from the packed grid of ``lit`` (a :class:`motes.render.volume.LitVolume`:
    its channels as its packed medium names them)."""
    values = trilinear(lit.grid, point, volume.origin, volume.cell_size)
    rho = values[0]
    if rho <= 0:
        return 0.0, np.zeros(3)
    first = int(lit.medium[LIGHTS_CH])
    light = np.zeros(3)
    for k, row in enumerate(lit.lights):
        seen = values[first + k]
        radiance = row[LIGHT_RADIANCE : LIGHT_RADIANCE + 3]
        if row[LIGHT_POINT] > 0.5:
            d = row[LIGHT_POSITION : LIGHT_POSITION + 3] - point
            dist = float(np.linalg.norm(d))
            seen *= henyey_greenstein(volume.anisotropy, float(d @ ray) / dist)
            if row[LIGHT_FALLOFF] > 0.5:
                seen /= dist * dist
        else:
            toward = row[LIGHT_DIRECTION : LIGHT_DIRECTION + 3]
            seen *= henyey_greenstein(volume.anisotropy, float(toward @ ray))
        light += seen * radiance
    above = int(lit.medium[AMBIENT_CH])
    if above >= 0:
        light += 0.5 * (lit.ambient[:3] * values[above] + lit.ambient[3:] * values[above + 1])
    j = volume.extinction * rho * volume.albedo * light
    hot = int(lit.medium[TEMPERATURE_CH])
    if hot >= 0:
        j = j + volume.emission * rho * blackbody_rgb(float(values[hot]))
    return rho, j


def march_ray(volume, lit, camera, sx, sy, *, stop=math.inf, offset=0.0, cuts=()):
    """March the ray through screen point ``(sx, sy)`` up to view depth ``stop``: the
    lattice of segments of ``step`` metres shifted by ``offset`` (a fraction of a step),
    clipped to the box around the non-empty bricks (``lit.inner``; the density is 0
    outside it) and ``[near, min(far, stop)]`` and cut at the view depths ``cuts``, each
    integrated exactly for the medium at its midpoint; no leaping, stopping when
    ``T < 1e-3``. Returns ``(L (3,), T)`` at the end and ``(S, T)`` (len(cuts), 4) at each
    cut (the last values past the end)."""
    o, d = camera_ray(camera, sx, sy)
    t0, t1 = box_span(o, d, *lit.inner)
    t0, t1 = max(t0, camera.near), min(t1, camera.far, stop)
    length = float(np.linalg.norm(d))
    ray = d / length
    dt = volume.step * volume.cell_size / length
    shift = offset * dt
    radiance, seen = np.zeros(3), 1.0
    recorded = np.zeros((len(cuts), 4))
    cut = 0

    def record_until(t):
        nonlocal cut
        while cut < len(cuts) and cuts[cut] <= t:
            recorded[cut] = (*radiance, seen)
            cut += 1

    record_until(t0)
    bounds = []  # segment ends: lattice points and cuts inside (t0, t1), then t1
    if t0 < t1:
        k = math.floor((t0 - shift) / dt) + 1
        while shift + k * dt < t1:
            bounds.append(shift + k * dt)
            k += 1
        bounds = sorted(set(bounds) | {c for c in cuts if t0 < c < t1} | {t1})
    ta = t0
    for tb in bounds:
        rho, j = source(volume, lit, o + 0.5 * (ta + tb) * d, ray)
        if rho > 0:
            h = (tb - ta) * length
            tau = volume.extinction * rho * h
            share = h * (1 - math.exp(-tau)) / tau if tau > 0 else h
            radiance += seen * share * j
            seen *= math.exp(-tau)
        record_until(tb)
        if seen < 1e-3:
            break
        ta = tb
    record_until(math.inf)
    return radiance, seen, recorded


def march_to_depth(volume, lit, camera, sx, sy, depth, step):
    """``(S (3,), T)`` along the ray through screen point ``(sx, sy)`` from the camera to
    view depth ``depth``, in equal midpoint segments of at most ``step`` (ray parameter)
    over the part inside the box: a fine march, the reference for the froxels."""
    o, d = camera_ray(camera, sx, sy)
    lo, hi = volume.bounds
    t0, t1 = box_span(o, d, lo, hi)
    t0, t1 = max(t0, camera.near), min(t1, camera.far, depth)
    length = float(np.linalg.norm(d))
    radiance, seen = np.zeros(3), 1.0
    if not t0 < t1:
        return radiance, seen
    count = max(math.ceil((t1 - t0) / step), 1)
    dt = (t1 - t0) / count
    for m in range(count):
        rho, j = source(volume, lit, o + (t0 + (m + 0.5) * dt) * d, d / length)
        if rho <= 0:
            continue
        h = dt * length
        tau = volume.extinction * rho * h
        share = h * (1 - math.exp(-tau)) / tau if tau > 0 else h
        radiance += seen * share * j
        seen *= math.exp(-tau)
    return radiance, seen


def froxel_lookup(grid: np.ndarray, x0, y0, factor, z0, dz, sx, sy, depth) -> np.ndarray:
    """Trilinear ``(S, T)`` in a froxel grid (gh, gw, slices + 1, 4) at a screen point
    and depth, clamped to the grid."""
    coords = ((sy - y0) / factor - 0.5, (sx - x0) / factor - 0.5, (depth - z0) / dz)
    lower, frac = [], []
    for axis, u in enumerate(coords):
        n = grid.shape[axis]
        u = min(max(u, 0.0), n - 1.0)
        i0 = min(math.floor(u), n - 2)
        lower.append(i0)
        frac.append(u - i0)
    total = np.zeros(4)
    for corner in itertools.product((0, 1), repeat=3):
        weight = np.prod([f if c else 1 - f for f, c in zip(frac, corner, strict=True)])
        total += weight * grid[lower[0] + corner[0], lower[1] + corner[1], lower[2] + corner[2]]
    return total


def box_blur_xz(values: np.ndarray, radius: int) -> np.ndarray:
    """A box filter of ``2 radius + 1`` voxels along x, then z, edges clamped."""
    out = np.asarray(values, np.float64)
    for axis in (0, 2):
        n = out.shape[axis]
        taps = [np.take(out, np.clip(np.arange(n) + d, 0, n - 1), axis=axis) for d in
                range(-radius, radius + 1)]  # fmt: skip
        out = np.mean(taps, axis=0)
    return out
