"""Slow, obviously-correct NumPy twins of the particle rasteriser's kernels.

One particle at a time, in float64: its unit-peak weights are evaluated on a grid of
pixel centres wide enough to hold its whole footprint (no pixel boxes, no tiles), scaled
to its energy, cropped to the frame and blended with array arithmetic. Textures are
sampled with ``scipy.ndimage.map_coordinates`` (bilinear, clamped to the edge), not with
the kernels' own lookup.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from motes.render.camera import Camera

#: Mirrors motes.render.sprite_kernels: largest radius, exact-normalisation box limit.
MAX_RADIUS_PX = 1.0e6
EXACT_AREA = 1024.0
MIN_RADIUS = {"point": 1.0, "smooth": 1.0, "disc": 0.5, "texture": 1.5}


def unit_peak_area(kind: str, r: float, length: float = 0.0, alpha_mean: float = 0.0) -> float:
    """∫ of the unit-peak profile [px²] of radius r, swept over a streak of ``length`` px."""
    if kind == "point":
        return 1.0 + length
    if kind == "smooth":
        return math.pi * r * r / 3 + length * 16 * r / 15
    if kind == "disc":
        return math.pi * (r * r + 1 / 12) + 2 * r * length
    return 4 * r * r * alpha_mean


def weights(kind, gx, gy, head, tail, rf, texture=None, angle=0.0):
    """Unit-peak weights (and, for textures, RGB) at pixel centres ``gx, gy`` (2D grids).

    Returns ``(w, rgb, t)``: weights, the texture's RGB (ones otherwise) and the parameter
    of the nearest streak point (0 at the tail, 1 at the head).
    """
    hx, hy = head
    seg = np.subtract(head, tail)
    seg2 = float(seg @ seg)
    if seg2 > 0:
        t = np.clip(((gx - tail[0]) * seg[0] + (gy - tail[1]) * seg[1]) / seg2, 0, 1)
    else:
        t = np.ones_like(gx)
    dx = gx - (tail[0] + t * seg[0])
    dy = gy - (tail[1] + t * seg[1])
    rgb = np.ones((*gx.shape, 3))
    if kind == "point":
        w = np.clip(1 - abs(dx), 0, None) * np.clip(1 - abs(dy), 0, None)
    elif kind == "smooth":
        w = np.clip(1 - (dx * dx + dy * dy) / rf**2, 0, None) ** 2
    elif kind == "disc":
        w = np.clip(rf + 0.5 - np.hypot(dx, dy), 0, 1)
    else:
        # Texture axes: the screen offset (y up) turned back by the sprite angle.
        x, y = (gx - hx) / rf, -(gy - hy) / rf
        u = math.cos(angle) * x + math.sin(angle) * y
        v = math.cos(angle) * y - math.sin(angle) * x
        th, tw = texture.shape[:2]
        coords = [(1 - v) / 2 * th - 0.5, (u + 1) / 2 * tw - 0.5]
        sample = np.stack(
            [
                ndimage.map_coordinates(texture[..., c].astype(np.float64), coords, order=1,
                                        mode="nearest")
                for c in range(4)
            ],
            axis=-1,
        )  # fmt: skip
        inside = (abs(u) < 1) & (abs(v) < 1)
        sample[~inside] = 0
        w, rgb = sample[..., 3], sample[..., :3]
    return w, rgb, t


def draw(
    color,
    depth,
    camera: Camera,
    positions,
    colors,
    radii=None,
    *,
    kind="sprite",
    falloff="smooth",
    blend="additive",
    softness=0.0,
    shutter=0.0,
    texture=None,
    intensity=1.0,
    rotation=None,
    velocities=None,
):
    """The frame colour (float64 copy of ``color``) after drawing the particles."""
    out = np.array(color, dtype=np.float64)
    depth = np.asarray(depth, dtype=np.float64)
    height, width = depth.shape
    positions = np.asarray(positions, dtype=np.float64)
    colors = np.asarray(colors, dtype=np.float64)
    n = len(positions)
    footprint = "point" if kind == "point" else ("texture" if texture is not None else falloff)
    xy, d = camera.project(positions)
    # Alpha-over composites back to front (a stable sort keeps equal depths in order).
    order = np.argsort(-d, kind="stable") if blend == "alpha" else np.arange(n)
    for i in order:
        if not camera.near <= d[i] <= camera.far:
            continue
        head, tail, tail_depth = xy[i], xy[i], d[i]
        if shutter > 0:
            p = positions[i]
            q = p - np.asarray(velocities[i], dtype=np.float64) * shutter
            qd = camera.to_view(q)[0, 2]
            if qd < camera.near:
                q = p + (d[i] - camera.near) / (d[i] - qd) * (q - p)
            elif qd > camera.far:
                q = p + (camera.far - d[i]) / (qd - d[i]) * (q - p)
            (tail,), (tail_depth,) = camera.project(q[None])
        r = 0.0
        if kind != "point":
            r = min(float(radii[i] * camera.pixels_per_metre(d[i])), MAX_RADIUS_PX)
        rf = max(r, MIN_RADIUS[footprint])
        reach = {"point": 1.0, "smooth": rf, "disc": rf + 0.5, "texture": rf * math.sqrt(2)}
        e = reach[footprint]
        lo = np.floor(np.minimum(head, tail) - e).astype(int) - 2
        hi = np.ceil(np.maximum(head, tail) + e).astype(int) + 2
        gx, gy = np.meshgrid(np.arange(lo[0], hi[0] + 1) + 0.5, np.arange(lo[1], hi[1] + 1) + 0.5)
        angle = 0.0 if rotation is None else float(rotation[i])
        w, rgb, t = weights(footprint, gx, gy, head, tail, rf, texture, angle)
        alpha_mean = float(texture[..., 3].mean()) if texture is not None else 0.0
        energy = unit_peak_area(footprint, r, 0.0, alpha_mean)
        span = np.abs(np.subtract(head, tail)) + 2 * e
        if footprint == "point" and shutter == 0:
            scale = 1.0
        elif span[0] * span[1] <= EXACT_AREA:
            scale = energy / w.sum() if w.sum() > 0 else 0.0
        else:
            length = float(np.hypot(*np.subtract(head, tail)))
            scale = energy / unit_peak_area(footprint, rf, length, alpha_mean)
        # Crop to the frame.
        cols = np.arange(lo[0], hi[0] + 1)
        rows = np.arange(lo[1], hi[1] + 1)
        cin = (cols >= 0) & (cols < width)
        rin = (rows >= 0) & (rows < height)
        if not cin.any() or not rin.any():
            continue
        w = w[np.ix_(rin, cin)] * scale
        rgb = rgb[np.ix_(rin, cin)]
        t = t[np.ix_(rin, cin)]
        frag_depth = tail_depth + t * (d[i] - tail_depth)
        opaque = depth[np.ix_(rows[rin], cols[cin])]
        if softness > 0:
            with np.errstate(invalid="ignore"):
                w = w * np.clip((opaque - frag_depth) / softness, 0, 1)
        else:
            w = np.where(frag_depth < opaque, w, 0.0)
        target = out[np.ix_(rows[rin], cols[cin])]
        c = colors[i]
        if blend == "additive":
            target += (c[:3] * c[3] * intensity) * rgb * w[..., None]
        else:
            a = np.clip(c[3] * w, 0, 1)[..., None]
            target[:] = c[:3] * intensity * rgb * a + target * (1 - a)
        out[np.ix_(rows[rin], cols[cin])] = target
    return out
