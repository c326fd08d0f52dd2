"""Opacity shadow maps: particles that shadow the ground, geometry and each other.

A cloud of translucent particles does not cast a hard shadow: light is attenuated by the
optical depth it crosses (Beer–Lambert, ``T = exp(-τ)``). For each directional light,
:func:`opacity_map` builds an opacity shadow map (Kim & Neumann 2001): a grid over the
light's view (``GRID × GRID`` texels) divided into ``SLICES`` slices along the light,
into which every shadowing particle deposits its optical depth. A particle of opacity
``α`` and radius ``r`` blocks ``1 - α`` of the light crossing its disc, i.e. an optical
depth ``-ln(1 - α)`` over an area ``π r²``; it is spread over the texels its disc covers
(weights ``1 - d²/r²``, normalised) in the slice of its depth. The slices are then summed
front to back, so texel ``(j, i)`` holds at slice boundary ``k`` the optical depth in
front of it; :func:`transmittance` interpolates that
trilinearly at any point. A uniform slab of particles of number density ``n`` and
thickness ``L`` therefore transmits ``exp(-n L π r² (-ln(1 - α)))`` of the light, the
Beer–Lambert law for that cloud (tested).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import called, serial_kernel
from .camera import SCALE
from .shadows import light_texel

#: Texels of each side of an opacity map.
GRID = 192
#: Slices along the light.
SLICES = 48
#: Largest particle disc radius [texels] splatted (bigger ones are clamped to it: a
#: puff wider than a quarter of the map spreads its depth over that much).
MAX_SPLAT = 24.0


@serial_kernel
def splat(cam, x, y, z, radius, alpha, z0, inv_dz, out):
    """Deposit each particle's optical depth into ``out`` (GRID, GRID, SLICES + 1) float32
    (slice ``k`` at ``out[..., k + 1]``), then sum the slices front to back so that
    ``out[j, i, k]`` is the optical depth in front of slice boundary ``k``."""
    size = out.shape[0]
    slices = out.shape[2] - 1
    texel_area = 1.0 / (cam[SCALE] * cam[SCALE])
    for p in range(x.shape[0]):
        a = min(max(alpha[p], 0.0), 0.999)
        if a <= 0.0 or radius[p] <= 0.0:
            continue
        tau = -math.log(1.0 - a) * math.pi * radius[p] * radius[p] / texel_area
        u, v, depth = light_texel(cam, x[p], y[p], z[p])
        k = min(max(math.floor((depth - z0) * inv_dz), 0), slices - 1)
        reach = min(max(radius[p] * cam[SCALE], 0.5), MAX_SPLAT)
        i0 = max(math.floor(u - reach), 0)
        i1 = min(math.ceil(u + reach), size - 1)
        j0 = max(math.floor(v - reach), 0)
        j1 = min(math.ceil(v + reach), size - 1)
        total = 0.0
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                d2 = ((i - u) ** 2 + (j - v) ** 2) / (reach * reach)
                total += max(1.0 - d2, 0.0)
        if total <= 0.0:
            continue
        scale = tau / total
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                d2 = ((i - u) ** 2 + (j - v) ** 2) / (reach * reach)
                out[j, i, k + 1] += max(1.0 - d2, 0.0) * scale
    for j in range(size):
        for i in range(size):
            for k in range(1, slices + 1):
                out[j, i, k] += out[j, i, k - 1]


@called
def transmittance(cam, grid, z0, inv_dz, x, y, z):
    """Fraction of the light reaching the point ``(x, y, z)`` [m] through the particles of
    an opacity map (1 outside it)."""
    size = grid.shape[0]
    slices = grid.shape[2] - 1
    u, v, depth = light_texel(cam, x, y, z)
    if u < -0.5 or v < -0.5 or u > size - 0.5 or v > size - 0.5:
        return 1.0
    s = min(max((depth - z0) * inv_dz, 0.0), float(slices))
    k = min(math.floor(s), slices - 1)
    fk = s - k
    i = min(max(math.floor(u), 0), size - 2)
    j = min(max(math.floor(v), 0), size - 2)
    fu = min(max(u - i, 0.0), 1.0)
    fv = min(max(v - j, 0.0), 1.0)
    tau = 0.0
    for b in range(2):
        wv = fv if b else 1.0 - fv
        for a in range(2):
            wu = fu if a else 1.0 - fu
            front = grid[j + b, i + a, k]
            back = grid[j + b, i + a, k + 1]
            tau += wu * wv * (front + fk * (back - front))
    return math.exp(-tau)


@serial_kernel
def transmittances(cam, grid, z0, inv_dz, x, y, z, out):
    """:func:`transmittance` at many points (n,) [m] into ``out`` (n,)."""
    for p in range(x.shape[0]):
        out[p] = transmittance(cam, grid, z0, inv_dz, x[p], y[p], z[p])


def opacity_map(view, positions, radius, alpha):
    """The opacity shadow map of particles seen from ``view`` (a light's orthographic
    :class:`~motes.render.camera.Camera` of ``GRID`` × ``GRID`` pixels).

    ``positions`` (n, 3) [m], ``radius`` (n,) [m], ``alpha`` (n,) in [0, 1]. Returns
    ``(grid (GRID, GRID, SLICES + 1) float32, z0 [m], inv_dz [1/m])``.
    """
    cam = view.packed()
    p = np.ascontiguousarray(positions, dtype=np.float64)
    depth = (p - view.position) @ view.basis[2]
    reach = float(np.max(radius)) if len(radius) else 0.0
    z0 = float(depth.min()) - reach
    dz = max((float(depth.max()) + reach - z0) / SLICES, 1e-6)
    grid = np.zeros((GRID, GRID, SLICES + 1), np.float32)
    splat(
        cam, p[:, 0].copy(), p[:, 1].copy(), p[:, 2].copy(),
        np.ascontiguousarray(radius, np.float64), np.ascontiguousarray(alpha, np.float64),
        z0, 1.0 / dz, grid,
    )  # fmt: skip
    return grid, z0, 1.0 / dz
