"""Light arriving at a surface or a particle: the shading model of opaque geometry, and
the lighting of lit particles, both through shadow and opacity maps.

The shading model, per sample with unit normal ``n`` (turned toward the viewer), unit
direction to the viewer ``v``, albedo ``c`` and, for each light, unit direction toward
the light ``l``, radiance ``L`` (a directional light's is constant; a point light's falls
off as ``1/d²`` unless it is made not to) and the fraction ``s`` of it that reaches the
sample (:func:`light_reaching`: shadow maps, :mod:`motes.render.shadows`; particles'
opacity maps, :mod:`motes.render.opacity`):

.. math::

    C = E + c \\odot \\Big(A(n) + \\sum_l s L \\max(0, n \\cdot l)\\Big)
          + k_s \\sum_l s L \\max(0, n \\cdot h)^{s} [n \\cdot l > 0],
    \\qquad h = \\frac{l + v}{\\lVert l + v \\rVert}

Lambert diffuse without the 1/π (a white surface facing a light of intensity 1 reflects
1), a hemisphere ambient :math:`A(n) = G + (S - G)(1 + n_y)/2` between a ground colour
``G`` and a sky colour ``S`` (Lambert-weighted sky light, as in three.js'
``HemisphereLight``), and Blinn-Phong highlights (Blinn 1977) with strength ``k_s`` and
exponent ``s``, white, not tinted by the albedo. ``E`` is the emission.
"""

from __future__ import annotations

import math

import numba

from .._jit import block_bounds, block_count, device, parallel_kernel
from .opacity import transmittance
from .shading import (
    EMISSION,
    LIGHT_DIRECTION,
    LIGHT_FALLOFF,
    LIGHT_OPACITY,
    LIGHT_POINT,
    LIGHT_POSITION,
    LIGHT_RADIANCE,
    LIGHT_SHADOW,
    SHININESS,
    SPECULAR,
)
from .shadows import visibility


@device
def light_reaching(lights, k, shadowing, nx, ny, nz, wx, wy, wz):
    """Fraction in [0, 1] of light ``k`` (a packed row of ``lights``) that reaches the
    point ``(wx, wy, wz)`` with unit normal ``n``: its shadow map's visibility times the
    transmittance through its opacity map (1 without either)."""
    shadow_cams, shadow_maps, opacity_cams, opacity_maps, opacity_depth = shadowing
    seen = 1.0
    index = int(lights[k, LIGHT_SHADOW])
    if index >= 0:
        seen = visibility(shadow_cams, shadow_maps, index, nx, ny, nz, wx, wy, wz)
    index = int(lights[k, LIGHT_OPACITY])
    if index >= 0 and seen > 0.0:
        seen *= transmittance(
            opacity_cams[index], opacity_maps[index], opacity_depth[index, 0],
            opacity_depth[index, 1], wx, wy, wz,
        )  # fmt: skip
    return seen


@parallel_kernel
def light_particles(lights, ambient, shadowing, x, y, z, rgb, out):
    """Colour (n, 3) of lit particles: ``rgb`` times the mean ambient light plus every
    light that reaches each particle's centre (through geometry shadows and the particles'
    own opacity maps; a point light with its falloff). Particles are lit from every side
    at once (a puff of smoke scatters in all directions), so no cosine."""
    n = x.shape[0]
    sky = (ambient[0] + ambient[3], ambient[1] + ambient[4], ambient[2] + ambient[5])
    for block in numba.prange(block_count(n)):
        first, stop = block_bounds(block, n)
        for p in range(first, stop):
            lr = 0.5 * sky[0]
            lg = 0.5 * sky[1]
            lb = 0.5 * sky[2]
            for k in range(lights.shape[0]):
                scale = 1.0
                if lights[k, LIGHT_POINT] > 0.5:
                    if lights[k, LIGHT_FALLOFF] > 0.5:
                        dx = lights[k, LIGHT_POSITION] - x[p]
                        dy = lights[k, LIGHT_POSITION + 1] - y[p]
                        dz = lights[k, LIGHT_POSITION + 2] - z[p]
                        scale = 1.0 / max(dx * dx + dy * dy + dz * dz, 1e-12)
                else:
                    scale = light_reaching(
                        lights, k, shadowing, lights[k, LIGHT_DIRECTION],
                        lights[k, LIGHT_DIRECTION + 1], lights[k, LIGHT_DIRECTION + 2],
                        x[p], y[p], z[p],
                    )  # fmt: skip
                lr += lights[k, LIGHT_RADIANCE] * scale
                lg += lights[k, LIGHT_RADIANCE + 1] * scale
                lb += lights[k, LIGHT_RADIANCE + 2] * scale
            out[p, 0] = rgb[p, 0] * lr
            out[p, 1] = rgb[p, 1] * lg
            out[p, 2] = rgb[p, 2] * lb


@device
def toward_light(lights, k, wx, wy, wz):
    """Unit direction from world point ``(wx, wy, wz)`` [m] toward light ``k`` of the
    packed ``lights``, and the factor on its radiance there (1, or the inverse square of
    the distance for a point light that falls off)."""
    lx = lights[k, LIGHT_DIRECTION]
    ly = lights[k, LIGHT_DIRECTION + 1]
    lz = lights[k, LIGHT_DIRECTION + 2]
    scale = 1.0
    if lights[k, LIGHT_POINT] > 0.5:
        lx = lights[k, LIGHT_POSITION] - wx
        ly = lights[k, LIGHT_POSITION + 1] - wy
        lz = lights[k, LIGHT_POSITION + 2] - wz
        d2 = max(lx * lx + ly * ly + lz * lz, 1e-12)
        inv = 1.0 / math.sqrt(d2)
        lx *= inv
        ly *= inv
        lz *= inv
        if lights[k, LIGHT_FALLOFF] > 0.5:
            scale = 1.0 / d2
    return lx, ly, lz, scale


@device
def shade(nx, ny, nz, vx, vy, vz, wx, wy, wz, r, g, b, surfaces, s, lights, ambient, shadowing):
    """Outgoing radiance (r, g, b) of a surface sample (see the module docstring).

    ``(nx, ny, nz)`` and ``(vx, vy, vz)`` are the unit normal and unit direction to the
    viewer, ``(wx, wy, wz)`` the sample's world position [m] (for point lights),
    ``(r, g, b)`` the albedo, ``surfaces[s]`` the surface row (passed as table and
    index: slicing a row out would cost a reference-count update per sample), ``lights``
    the packed lights, ``ambient`` the packed (sky, ground) ambient, and ``shadowing`` the
    shadow and opacity maps of the lights (:attr:`motes.render.shadows.Shadowing.arrays`).
    """
    up = 0.5 * (1.0 + ny)
    dr = ambient[3] + (ambient[0] - ambient[3]) * up
    dg = ambient[4] + (ambient[1] - ambient[4]) * up
    db = ambient[5] + (ambient[2] - ambient[5]) * up
    sr = 0.0
    sg = 0.0
    sb = 0.0
    ks = surfaces[s, SPECULAR]
    for k in range(lights.shape[0]):
        lx, ly, lz, scale = toward_light(lights, k, wx, wy, wz)
        cos_l = (nx * lx + ny * ly + nz * lz) * scale
        if cos_l <= 0.0:
            continue
        seen = light_reaching(lights, k, shadowing, nx, ny, nz, wx, wy, wz)
        if seen <= 0.0:
            continue
        scale *= seen
        cos_l *= seen
        dr += lights[k, LIGHT_RADIANCE] * cos_l
        dg += lights[k, LIGHT_RADIANCE + 1] * cos_l
        db += lights[k, LIGHT_RADIANCE + 2] * cos_l
        if ks > 0.0:
            hx = lx + vx
            hy = ly + vy
            hz = lz + vz
            h = math.sqrt(hx * hx + hy * hy + hz * hz)
            cos_h = (nx * hx + ny * hy + nz * hz) / max(h, 1e-12)
            if cos_h > 0.0:
                spec = ks * scale * cos_h ** surfaces[s, SHININESS]
                sr += lights[k, LIGHT_RADIANCE] * spec
                sg += lights[k, LIGHT_RADIANCE + 1] * spec
                sb += lights[k, LIGHT_RADIANCE + 2] * spec
    return (
        surfaces[s, EMISSION] + r * dr + sr,
        surfaces[s, EMISSION + 1] + g * dg + sg,
        surfaces[s, EMISSION + 2] + b * db + sb,
    )
