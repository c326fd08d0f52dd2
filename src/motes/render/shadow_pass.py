"""The shadow pass of a frame: shadow maps of opaque geometry and opacity maps of
particles, for every directional light that casts shadows (:mod:`.shadows`,
:mod:`.opacity`), made before the frame is drawn."""

from __future__ import annotations

import numpy as np

from .camera import PACKED_SIZE
from .geometry import draw_depth
from .opacity import GRID, SLICES, opacity_map
from .shading import (
    LIGHT_OPACITY,
    LIGHT_SHADOW,
    AmbientLight,
    DirectionalLight,
    PointLight,
    default_lights,
    pack_lights,
)
from .shadows import Shadowing, casters_sphere, light_camera, map_resolution


def prepare(lights, casters, camera, particles=()) -> Shadowing:
    """Shadow maps of opaque ``casters`` and opacity maps of ``particles`` for every
    directional light that casts shadows.

    ``casters``: geometry objects that cast shadows; ``particles``: ``(positions (n, 3),
    radius (n,), alpha (n,))`` of particle systems that cast shadows.
    """
    packed, ambient = pack_lights(lights)
    if lights is None or isinstance(lights, (DirectionalLight, PointLight, AmbientLight)):
        lights = default_lights() if lights is None else [lights]
    rows = [x for x in lights if isinstance(x, (DirectionalLight, PointLight))]
    shadowed = [k for k, x in enumerate(rows) if isinstance(x, DirectionalLight) and x.shadows]
    cams, maps, o_cams, o_maps, o_depth = [], [], [], [], []
    if shadowed and casters:
        points = np.concatenate([o.triangles(camera).positions for o in casters])
        center, radius = casters_sphere(points)
        side = map_resolution(camera, center, radius)  # one size: the maps are stacked
        for k in shadowed:
            view = light_camera(rows[k].direction, center, radius, side)
            packed[k, LIGHT_SHADOW] = len(maps)
            cams.append(view.packed())
            maps.append(draw_depth(view, casters))
    particles = [p for p in particles if len(p[0])]
    if shadowed and particles:
        points = np.concatenate([p[0] for p in particles])
        center, radius = casters_sphere(points)
        radius += max(float(p[1].max()) for p in particles)
        positions = np.concatenate([p[0] for p in particles])
        sizes = np.concatenate([p[1] for p in particles])
        alphas = np.concatenate([p[2] for p in particles])
        for k in shadowed:
            view = light_camera(rows[k].direction, center, radius, GRID)
            grid, z0, inv_dz = opacity_map(view, positions, sizes, alphas)
            packed[k, LIGHT_OPACITY] = len(o_maps)
            o_cams.append(view.packed())
            o_maps.append(grid)
            o_depth.append((z0, inv_dz))

    def stack(items, shape, dtype=np.float64):
        return np.stack(items).astype(dtype) if items else np.zeros(shape, dtype)

    arrays = (
        stack(cams, (0, PACKED_SIZE)),
        stack(maps, (0, 1, 1), np.float32),
        stack(o_cams, (0, PACKED_SIZE)),
        stack(o_maps, (0, 1, 1, SLICES + 1), np.float32),
        stack(o_depth, (0, 2)),
    )
    return Shadowing(packed, ambient, arrays)
