"""Slow, obviously correct NumPy twins of the geometry rasteriser (motes.render._raster).

Triangles are ray cast: one ray per sample centre, intersected with every triangle in
view space (Möller & Trumbore 1997), so near-plane clipping, perspective-correct
interpolation and depth come from geometry, not from the kernel's screen-space
formulas. Lines follow the kernel's definition (capsule coverage in sample space) in
plain per-segment NumPy, drawn over ray-cast sample buffers and resolved like the kernel.
"""

from __future__ import annotations

import numpy as np

from motes.render.camera import Camera, Projection


def sample_rays(camera: Camera, ss: int = 1):
    """View-space origins and directions (h ss, w ss, 3) of the rays through sample centres.

    Directions have a view-z component of 1, so the ray parameter is the view depth.
    """
    w, h = camera.resolution
    u = (np.arange(w * ss) + 0.5) / ss
    v = (np.arange(h * ss) + 0.5) / ss
    uu, vv = np.meshgrid(u, v)
    x = (uu - 0.5 * w) / camera.scale
    y = -(vv - 0.5 * h) / camera.scale
    if camera.projection is Projection.ORTHOGRAPHIC:
        origin = np.stack([x, y, np.zeros_like(x)], axis=-1)
        direction = np.broadcast_to([0.0, 0.0, 1.0], origin.shape)
    else:
        origin = np.zeros((*uu.shape, 3))
        direction = np.stack([x, y, np.ones_like(x)], axis=-1)
    return origin, direction


def ray_cast(camera: Camera, corners, ss: int = 1):
    """Nearest triangle per sample.

    Parameters
    ----------
    corners : (t, 3, 3) world positions of each triangle's corners [m].

    Returns
    -------
    depth : (h ss, w ss) view depth of the nearest hit in [near, far], inf where none.
    index : (h ss, w ss) int, the triangle hit (-1 none); the first listed wins ties.
    bary : (h ss, w ss, 3) barycentric coordinates of the hit in that triangle.
    """
    origin, direction = sample_rays(camera, ss)
    depth = np.full(origin.shape[:2], np.inf)
    index = np.full(origin.shape[:2], -1)
    bary = np.zeros((*origin.shape[:2], 3))
    for k, tri in enumerate(np.asarray(corners, dtype=np.float64)):
        a, b, c = camera.to_view(tri)
        e1, e2 = b - a, c - a
        p = np.cross(direction, e2)
        det = p @ e1
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            s = origin - a
            beta = np.einsum("ijk,ijk->ij", s, p) * inv
            q = np.cross(s, e1)
            gamma = (direction * q).sum(axis=-1) * inv
            t = (q @ e2) * inv
        hit = (
            (det != 0)
            & (beta >= 0)
            & (gamma >= 0)
            & (beta + gamma <= 1)
            & (t >= camera.near)
            & (t <= camera.far)
            & (t < depth)
        )
        depth[hit] = t[hit]
        index[hit] = k
        bary[hit] = np.stack([1 - beta - gamma, beta, gamma], axis=-1)[hit]
    return depth, index, bary


def draw_lines(camera: Camera, ends, colors, widths, color, depth, ss: int = 1):
    """Blend anti-aliased segments over sample buffers, in order; return the samples drawn.

    ``color`` (h ss, w ss, 3) and ``depth`` (h ss, w ss) are updated in place.
    """
    touched = np.zeros(depth.shape, dtype=bool)
    py, px = np.mgrid[0 : depth.shape[0], 0 : depth.shape[1]] + 0.5
    for (pa, pb), (ca, cb), width in zip(ends, colors, widths, strict=True):
        va, vb = camera.to_view(np.array([pa, pb]))
        if max(va[2], vb[2]) < camera.near or min(va[2], vb[2]) > camera.far:
            continue
        ta, tb = 0.0, 1.0
        if va[2] < camera.near:
            ta = (camera.near - va[2]) / (vb[2] - va[2])
        elif vb[2] < camera.near:
            tb = (camera.near - va[2]) / (vb[2] - va[2])
        ends_view = np.array([va + ta * (vb - va), va + tb * (vb - va)])
        ends_view[:, 2] = np.maximum(ends_view[:, 2], camera.near)
        world = ends_view @ camera.basis + camera.position
        xy, z = camera.project(world)
        xy = xy * ss
        drawn = width * ss
        reach = 0.5 * max(drawn, 1.0) + 0.5
        d = xy[1] - xy[0]
        t = ((px - xy[0, 0]) * d[0] + (py - xy[0, 1]) * d[1]) / max(d @ d, 1e-300)
        t = np.clip(t, 0, 1)
        dist = np.hypot(px - xy[0, 0] - t * d[0], py - xy[0, 1] - t * d[1])
        coverage = np.clip(reach - dist, 0, 1) * min(drawn, 1.0)
        q = (1 / z) if camera.projection is Projection.PERSPECTIVE else np.ones(2)
        u = t * q[1] / ((1 - t) * q[0] + t * q[1])
        sample_depth = z[0] + u * (z[1] - z[0])
        drawn_here = (coverage > 0) & (sample_depth < depth) & (sample_depth <= camera.far)
        along = ta + u * (tb - ta)
        line_color = np.asarray(ca) + along[..., None] * (np.asarray(cb) - np.asarray(ca))
        blend = np.where(drawn_here, coverage, 0.0)[..., None]
        color += blend * (line_color - color)
        depth[:] = np.where(drawn_here & (coverage >= 0.5), sample_depth, depth)
        touched |= drawn_here
    return touched


def resolve(sample_color, sample_depth, touched, color, depth, ss: int):
    """Pixels with a touched sample get their samples' mean colour and minimum depth."""
    h, w = depth.shape
    pixel_touched = touched.reshape(h, ss, w, ss).any(axis=(1, 3))
    mean = sample_color.reshape(h, ss, w, ss, 3).mean(axis=(1, 3))
    nearest = sample_depth.reshape(h, ss, w, ss).min(axis=(1, 3))
    color[pixel_touched] = mean[pixel_touched]
    depth[pixel_touched] = nearest[pixel_touched]
