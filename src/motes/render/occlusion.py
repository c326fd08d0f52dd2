"""Ambient occlusion in screen space: the soft darkening where surfaces meet.

A sphere resting on the ground darkens the ground around the contact, a box in a
corner darkens the corner: less of the sky's light reaches there. From the frame's depth
buffer alone (Mittring 2007; Bavoil & Sainz 2008): each pixel of opaque geometry is put
back in view space, its normal taken from its neighbours' depths (the side with the
smaller step, so edges do not bend it), and :data:`SAMPLES` points in the hemisphere
above it within ``radius`` metres (a fixed kernel, turned by a hash of the pixel) are
looked up in the depth buffer: a sample hidden behind a nearer surface, that surface
within ``radius`` of the pixel, counts as occluded. Where ``radius`` spans fewer than
6 pixels (far away) the occlusion fades out, gone below 2: the depth buffer cannot
resolve it there. The share occluded, blurred over
5 × 5 pixels of similar depth, darkens the geometry's colour by ``strength`` times it.
It is computed at half the frame's size and brought back by the nearest depth.

The whole colour is darkened, not the ambient light alone (the frame keeps no separate
ambient term): a look, where the shadows of the direct light already darken most
contacts. Particles and volumes are drawn after it and are not darkened. A flat
surface is not occluded (tested); results do not depend on the thread count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import prange

from .. import _validate as check
from .._jit import device, parallel_kernel
from .bloom import _check_image
from .camera import HEIGHT, ORTHO, SCALE, WIDTH

#: Hemisphere samples per pixel.
SAMPLES = 16


@dataclass(frozen=True)
class AmbientOcclusion:
    """Screen-space ambient occlusion of opaque geometry.

    Parameters
    ----------
    radius : float
        How far [m] a surface occludes, > 0 (about the size of the contacts to show).
    strength : float
        Share of the colour taken where fully occluded, 0 to 1.
    """

    radius: float = 0.3
    strength: float = 0.6

    def __post_init__(self):
        values = {
            "radius": check.positive("ambient_occlusion.radius", self.radius),
            "strength": check.real("ambient_occlusion.strength", self.strength, low=0.0, high=1.0),
        }
        for name, value in values.items():
            object.__setattr__(self, name, value)

    def occlusion(self, depth: np.ndarray, camera) -> np.ndarray:
        """(height, width) float32 share occluded, in [0, 1] (0 off geometry), of a depth
        buffer (height, width) [m] (``inf``: no geometry) seen by ``camera``."""
        depth = np.asarray(depth)
        if depth.ndim != 2 or depth.shape[::-1] != tuple(camera.resolution):
            raise ValueError(
                f"depth must be (height, width) = {camera.resolution[::-1]} of the camera, "
                f"got {depth.shape}"
            )
        # no geometry: -1 (the kernels' fast math assumes finite numbers)
        depth = np.where(np.isfinite(depth), depth, np.float32(-1.0)).astype(np.float32)
        # at half size (a quarter of the work), then back by the nearest depth
        half = np.ascontiguousarray(depth[::2, ::2])
        small = camera.with_resolution((half.shape[1], half.shape[0]))
        raw = np.zeros(half.shape, np.float32)
        occlude(half, small.packed(), np.float32(self.radius), _KERNEL, raw)
        smooth = np.zeros_like(raw)
        blur(raw, half, smooth)
        out = np.zeros(depth.shape, np.float32)
        upsample(smooth, half, depth, out)
        return out

    def apply(self, color: np.ndarray, depth: np.ndarray, camera) -> np.ndarray:
        """Darken ``color`` (height, width, 3) float32 in place; returns the occlusion."""
        _check_image("color", color)
        if color.shape[:2] != np.shape(depth):
            raise ValueError(f"color {color.shape[:2]} and depth {np.shape(depth)} must match")
        share = self.occlusion(depth, camera)
        color *= (1.0 - np.float32(self.strength) * share)[..., None]
        return share


def _kernel() -> np.ndarray:
    """(SAMPLES, 3) float32 points in the unit hemisphere (z up), more near the centre:
    a fixed Fibonacci spiral, lengths growing as (k / SAMPLES)² toward 1."""
    k = np.arange(SAMPLES) + 0.5
    z = 1.0 - k / SAMPLES  # cosines evenly over the hemisphere
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    length = 0.15 + 0.85 * (k / SAMPLES) ** 2
    points = np.stack([r * np.cos(phi), r * np.sin(phi), np.maximum(z, 0.1)], axis=1)
    return (points * length[:, None]).astype(np.float32)


_KERNEL = _kernel()


@device
def _view(cam, i, j, z):
    """View-space point of pixel (i, j) at depth ``z``."""
    w, h, scale = cam[WIDTH], cam[HEIGHT], cam[SCALE]
    if cam[ORTHO] > 0.5:  # orthographic
        return (i + 0.5 - 0.5 * w) / scale, (0.5 * h - (j + 0.5)) / scale, z
    return (i + 0.5 - 0.5 * w) * z / scale, (0.5 * h - (j + 0.5)) * z / scale, z


@parallel_kernel
def occlude(depth, cam, radius, kernel, out):
    """Share of the hemisphere samples of each geometry pixel that are occluded."""
    height, width = depth.shape
    scale, ortho = cam[SCALE], cam[ORTHO] > 0.5
    for j in prange(height):
        for i in range(width):
            z = depth[j, i]
            if z <= 0.0:  # no geometry
                continue
            # where the radius spans under a few pixels the depth buffer cannot resolve
            # it (a far ground seen edge-on): fade out between 6 and 2 pixels
            reach = radius * (scale if ortho else scale / z)
            if reach < 2.0:
                continue
            fade = min(1.0, (reach - 2.0) / 4.0)
            px, py, pz = _view(cam, i, j, z)
            # normal: the neighbours on the side with the smaller depth step
            nx_, ny_, nz_ = _normal(depth, cam, i, j, px, py, pz)
            # a tangent frame, turned about the normal by a hash of the pixel
            angle = ((i * 73856093) ^ (j * 19349663)) % 1024 * (2.0 * math.pi / 1024.0)
            ax, ay, az = (1.0, 0.0, 0.0) if abs(nx_) < 0.9 else (0.0, 1.0, 0.0)
            tx, ty, tz = ay * nz_ - az * ny_, az * nx_ - ax * nz_, ax * ny_ - ay * nx_
            t = math.sqrt(tx * tx + ty * ty + tz * tz)
            tx, ty, tz = tx / t, ty / t, tz / t
            bx, by, bz = ny_ * tz - nz_ * ty, nz_ * tx - nx_ * tz, nx_ * ty - ny_ * tx
            c, s = math.cos(angle), math.sin(angle)
            tx, ty, tz, bx, by, bz = (
                c * tx + s * bx, c * ty + s * by, c * tz + s * bz,
                c * bx - s * tx, c * by - s * ty, c * bz - s * tz,
            )  # fmt: skip
            hidden = 0.0
            bias = 0.02 * radius + 1e-4 * z  # depth precision grows with distance
            for k in range(kernel.shape[0]):
                u, v, n = kernel[k, 0] * radius, kernel[k, 1] * radius, kernel[k, 2] * radius
                sx = px + u * tx + v * bx + n * nx_
                sy = py + u * ty + v * by + n * ny_
                sz = pz + u * tz + v * bz + n * nz_
                if sz <= 1e-6:
                    continue
                f = scale if ortho else scale / sz
                si = math.floor(0.5 * cam[WIDTH] + f * sx)
                sj = math.floor(0.5 * cam[HEIGHT] - f * sy)
                if si < 0 or sj < 0 or si >= width or sj >= height:
                    continue
                d = depth[sj, si]
                if d > 0.0 and d < sz - bias:  # a nearer surface hides the sample
                    gap = pz - d
                    # only surfaces near the pixel count (a far foreground does not)
                    hidden += 1.0 if abs(gap) < radius else radius / abs(gap)
            out[j, i] = fade * hidden / kernel.shape[0]


@device
def _normal(depth, cam, i, j, px, py, pz):
    """Unit view-space normal at pixel (i, j), facing the eye."""
    height, width = depth.shape
    # x: the neighbour with the smaller step
    dxp = depth[j, i + 1] if i + 1 < width else -1.0
    dxm = depth[j, i - 1] if i > 0 else -1.0
    if dxp <= 0.0 and dxm <= 0.0:
        return 0.0, 0.0, -1.0  # alone in its row: facing the eye
    if dxm <= 0.0 or (dxp > 0.0 and abs(dxp - pz) <= abs(dxm - pz)):
        qx, qy, qz = _view(cam, i + 1, j, dxp)
        ex, ey, ez = qx - px, qy - py, qz - pz
    else:
        qx, qy, qz = _view(cam, i - 1, j, dxm)
        ex, ey, ez = px - qx, py - qy, pz - qz
    dyp = depth[j + 1, i] if j + 1 < height else -1.0
    dym = depth[j - 1, i] if j > 0 else -1.0
    if dyp <= 0.0 and dym <= 0.0:
        return 0.0, 0.0, -1.0
    if dym <= 0.0 or (dyp > 0.0 and abs(dyp - pz) <= abs(dym - pz)):
        qx, qy, qz = _view(cam, i, j + 1, dyp)
        fx, fy, fz = qx - px, qy - py, qz - pz
    else:
        qx, qy, qz = _view(cam, i, j - 1, dym)
        fx, fy, fz = px - qx, py - qy, pz - qz
    nx_, ny_, nz_ = ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx
    norm = math.sqrt(nx_ * nx_ + ny_ * ny_ + nz_ * nz_)
    if norm <= 1e-30:
        return 0.0, 0.0, -1.0  # facing the eye
    nx_, ny_, nz_ = nx_ / norm, ny_ / norm, nz_ / norm
    if nx_ * px + ny_ * py + nz_ * pz > 0.0:  # toward the eye (at the origin)
        return -nx_, -ny_, -nz_
    return nx_, ny_, nz_


@parallel_kernel
def blur(raw, depth, out):
    """5 × 5 mean of ``raw`` over the geometry pixels of depth within 5 % of the centre's."""
    height, width = raw.shape
    for j in prange(height):
        for i in range(width):
            z = depth[j, i]
            if z <= 0.0:
                continue
            total = 0.0
            count = 0
            for b in range(max(j - 2, 0), min(j + 3, height)):
                for a in range(max(i - 2, 0), min(i + 3, width)):
                    if depth[b, a] > 0.0 and abs(depth[b, a] - z) <= 0.05 * z:
                        total += raw[b, a]
                        count += 1
            out[j, i] = total / count


@parallel_kernel
def upsample(small, small_depth, depth, out):
    """``out`` (full size) from ``small`` (half size, pixel (i, j) at full pixel
    (2i, 2j)): each full pixel takes the value of the nearby half-size pixel of the
    closest depth (edges stay sharp)."""
    height, width = depth.shape
    h, w = small.shape
    for j in prange(height):
        for i in range(width):
            z = depth[j, i]
            if z <= 0.0:
                continue
            best = 1e30
            value = 0.0
            for b in range(max(j // 2 - 1, 0), min(j // 2 + 2, h)):
                for a in range(max(i // 2 - 1, 0), min(i // 2 + 2, w)):
                    d = small_depth[b, a]
                    if d <= 0.0:
                        continue
                    # the depth first, the distance in pixels to break ties
                    gap = abs(d - z) / z + 1e-3 * ((2 * a - i) ** 2 + (2 * b - j) ** 2)
                    if gap < best:
                        best = gap
                        value = small[b, a]
            out[j, i] = value
