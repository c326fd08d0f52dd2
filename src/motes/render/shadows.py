"""Shadow maps for directional lights, filtered by percentage-closer filtering.

For each directional light that casts shadows (``DirectionalLight(..., shadows=True)``),
:func:`shadow_maps` renders the depth of the shadow casters as the light sees them: an
orthographic camera looking along the light, fitted around the casters' bounding sphere
(Williams 1978). Grounds are receivers only (a ground to the horizon would spread the map
over kilometres), and a point outside the map is lit.

When a surface sample is shaded, :func:`visibility` projects it into the light's view
and compares its depth with the map's over a square of ``(2 PCF_RADIUS + 1)²`` texels,
each comparison weighted bilinearly at the square's rim (Reeves, Salesin & Cook 1987,
percentage-closer filtering): the fraction of comparisons that find the sample in front
is how much of the light reaches it, which gives shadows soft, anti-aliased edges a few
texels wide instead of jagged steps. A depth bias of ``BIAS_TEXELS`` texels (plus a
slope term: a surface at a grazing angle to the light spans several depths per texel)
keeps lit surfaces from shadowing themselves ("shadow acne").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._jit import called, device
from .camera import (
    EYE,
    FORWARD,
    HEIGHT,
    PACKED_SIZE,
    RIGHT,
    SCALE,
    UP,
    WIDTH,
    Camera,
    Projection,
)
from .shading import (
    pack_lights,
)

#: Most texels of a shadow map's side (casters near the camera, or filling its view).
RESOLUTION = 2048
#: Fewest texels of a shadow map's side.
MIN_RESOLUTION = 512
#: Texels across one camera pixel at the casters' nearest point (see map_resolution).
TEXELS_PER_PIXEL = 1.0
#: Texels on each side of the centre texel that percentage-closer filtering compares.
PCF_RADIUS = 2
#: Constant depth bias, in texels of the map.
BIAS_TEXELS = 1.5


def light_camera(direction, center, radius: float, resolution: int = RESOLUTION) -> Camera:
    """An orthographic camera looking along ``direction`` (the way the light travels) at a
    sphere of ``radius`` [m] about ``center``, its view just holding the sphere."""
    direction = np.asarray(direction, dtype=np.float64)
    radius = max(float(radius), 1e-6)
    eye = np.asarray(center, dtype=np.float64) - 2.0 * radius * direction
    up = (0.0, 0.0, 1.0) if abs(direction[1]) > 0.9 else (0.0, 1.0, 0.0)
    return Camera(
        eye, np.asarray(center, dtype=np.float64), up=up, projection="orthographic",
        height=2.0 * radius, resolution=(resolution, resolution), near=1e-3 * radius,
        far=4.0 * radius,
    )  # fmt: skip


def map_resolution(camera: Camera, center, radius: float) -> int:
    """Side [texels] of the shadow map of casters within ``radius`` [m] of ``center``:
    ``TEXELS_PER_PIXEL`` texels per pixel of ``camera`` at the casters' point nearest
    to it, between ``MIN_RESOLUTION`` and ``RESOLUTION``, a multiple of 32.

    A texel much smaller than the pixel it lands in sharpens nothing (percentage-closer
    filtering blurs over five texels anyway) and costs raster time and cache misses:
    the `fire` scene's two logs, about 400 pixels across at 1280 x 720, take the
    smallest map (512) instead of 2048. Casters around or behind the camera get the
    most.
    """
    depth = float(camera.to_view(np.asarray(center, dtype=np.float64))[0][2]) - radius
    if camera.projection is Projection.PERSPECTIVE and depth <= camera.near:
        return RESOLUTION
    pixels = float(camera.pixels_per_metre(max(depth, camera.near))) * 2.0 * radius
    side = 32 * math.ceil(TEXELS_PER_PIXEL * pixels / 32)
    return int(min(max(side, MIN_RESOLUTION), RESOLUTION))


@device
def light_texel(cam, x, y, z):
    """Texel coordinates ``(u, v)`` (texel ``(j, i)`` centred at ``(i + 0.5, j + 0.5)``,
    so ``u = i`` at its centre) and depth [m] of a world point in a light's orthographic
    view ``cam`` (packed)."""
    dx = x - cam[EYE]
    dy = y - cam[EYE + 1]
    dz = z - cam[EYE + 2]
    right = dx * cam[RIGHT] + dy * cam[RIGHT + 1] + dz * cam[RIGHT + 2]
    up = dx * cam[UP] + dy * cam[UP + 1] + dz * cam[UP + 2]
    depth = dx * cam[FORWARD] + dy * cam[FORWARD + 1] + dz * cam[FORWARD + 2]
    return (
        0.5 * cam[WIDTH] + cam[SCALE] * right - 0.5,
        0.5 * cam[HEIGHT] - cam[SCALE] * up - 0.5,
        depth,
    )


# Called rather than inlined: the shading device function is inlined into the tile
# kernel, and inlining this loop too would lengthen that kernel's compile for no speed.
@called
def visibility(cams, maps, index, nx, ny, nz, wx, wy, wz):
    """Fraction in [0, 1] of light ``index``'s shadow map that sees the point
    ``(wx, wy, wz)`` [m] with unit normal ``n`` (see the module docstring)."""
    cam = cams[index]
    size = maps.shape[1]
    u, v, z = light_texel(cam, wx, wy, wz)
    if u < -0.5 or v < -0.5 or u > size - 0.5 or v > size - 0.5:
        return 1.0
    texel = 1.0 / cam[SCALE]
    # cos of the angle between the normal and the light (the light looks along FORWARD).
    cos_l = abs(nx * cam[FORWARD] + ny * cam[FORWARD + 1] + nz * cam[FORWARD + 2])
    slope = math.sqrt(max(1.0 - cos_l * cos_l, 0.0)) / max(cos_l, 0.2)
    reference = z - texel * (BIAS_TEXELS + 1.5 * slope)
    i0 = math.floor(u)
    j0 = math.floor(v)
    fu = u - i0
    fv = v - j0
    lit = 0.0
    total = 0.0
    for dj in range(-PCF_RADIUS, PCF_RADIUS + 2):
        wv = 1.0
        if dj == -PCF_RADIUS:
            wv = 1.0 - fv
        elif dj == PCF_RADIUS + 1:
            wv = fv
        j = min(max(j0 + dj, 0), size - 1)
        for di in range(-PCF_RADIUS, PCF_RADIUS + 2):
            wu = 1.0
            if di == -PCF_RADIUS:
                wu = 1.0 - fu
            elif di == PCF_RADIUS + 1:
                wu = fu
            i = min(max(i0 + di, 0), size - 1)
            w = wu * wv
            total += w
            if reference <= maps[index, j, i]:
                lit += w
    return lit / total


@dataclass
class Shadowing:
    """The lights of one frame with their shadow and opacity maps, as the kernels take
    them: ``lights`` (packed rows whose ``LIGHT_SHADOW`` / ``LIGHT_OPACITY`` columns
    index the maps), ``ambient`` (6,), and ``arrays`` = ``(shadow_cams (m, PACKED_SIZE),
    shadow_maps (m, R, R) float32, opacity_cams (o, PACKED_SIZE), opacity_maps
    (o, GRID, GRID, SLICES + 1) float32, opacity_depth (o, 2))``."""

    lights: np.ndarray
    ambient: np.ndarray
    arrays: tuple


def unshadowed(lights) -> Shadowing:
    """The packed ``lights`` with no shadow or opacity maps."""
    packed, ambient = pack_lights(lights)
    return Shadowing(packed, ambient, empty_maps())


def empty_maps() -> tuple:
    """:attr:`Shadowing.arrays` holding no map (the kernels type them by dimensions)."""
    return (
        np.zeros((0, PACKED_SIZE)),
        np.ones((0, 1, 1), np.float32),
        np.zeros((0, PACKED_SIZE)),
        np.zeros((0, 1, 1, 1), np.float32),
        np.zeros((0, 2)),
    )


def casters_sphere(positions: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre and radius [m] of a sphere holding every point of ``positions`` (v, 3)."""
    lo, hi = positions.min(axis=0), positions.max(axis=0)
    center = 0.5 * (lo + hi)
    return center, float(np.linalg.norm(hi - lo)) * 0.5 * 1.01 + 1e-6
