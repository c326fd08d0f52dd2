"""Cameras: perspective and orthographic projection onto a pixel grid.

Conventions (right-handed, y up): the camera looks from ``position`` toward ``target``.
View space has x to the right, y up and z = depth, the distance along the view axis
(positive in front of the camera). Screen space is in pixels with x to the right and y
down; pixel ``(row, col)`` covers ``[col, col + 1) × [row, row + 1)``, so its centre is
at ``(col + 0.5, row + 0.5)``. Depth buffers store view-space depth [m] (linear).
"""

from __future__ import annotations

import math
from enum import StrEnum

import numpy as np

from .. import _validate as check
from .._jit import device
from .._tracked import Tracked


class Projection(StrEnum):
    """How view space maps to the image."""

    PERSPECTIVE = "perspective"
    ORTHOGRAPHIC = "orthographic"


# Layout of the packed camera array the kernels read (float64): view basis rows, eye,
# pixels per metre at unit depth (perspective) or per metre (orthographic), image size,
# clip planes, projection flag.
RIGHT, UP, FORWARD, EYE = 0, 3, 6, 9
SCALE, WIDTH, HEIGHT, NEAR, FAR, ORTHO = 12, 13, 14, 15, 16, 17
PACKED_SIZE = 18


class Camera(Tracked):
    """A look-at camera with a perspective or orthographic projection.

    Parameters
    ----------
    position, target : (3,) array_like
        Eye and look-at point [m]; they must differ.
    up : (3,) array_like
        Approximate up direction; must not be parallel to the view direction.
    fov : float
        Vertical field of view [deg] of the perspective projection, in (0, 180).
    resolution : (int, int)
        Image width and height [px], each in [1, 16384].
    near, far : float
        Clip distances along the view axis [m], 0 < near < far.
    projection : {"perspective", "orthographic"}
    height : float
        Height of the view [m] for the orthographic projection.
    """

    def __init__(
        self,
        position=(0.0, 1.0, 5.0),
        target=(0.0, 1.0, 0.0),
        *,
        up=(0.0, 1.0, 0.0),
        fov: float = 45.0,
        resolution=(640, 360),
        near: float = 0.05,
        far: float = 1000.0,
        projection: str = "perspective",
        height: float = 2.0,
    ):
        self.position = check.vector("position", position)
        self.target = check.vector("target", target)
        forward = self.target - self.position
        if np.linalg.norm(forward) < 1e-12:
            raise ValueError("target must differ from position")
        self.up = check.vector("up", up)
        forward = forward / np.linalg.norm(forward)
        right = np.cross(forward, self.up)
        if np.linalg.norm(right) < 1e-9 * max(np.linalg.norm(self.up), 1e-300):
            raise ValueError("up must not be parallel to the view direction (target - position)")
        right /= np.linalg.norm(right)
        self.basis = np.stack([right, np.cross(right, forward), forward])
        self.fov = check.real("fov", fov, low=0.0, high=180.0, low_open=True, high_open=True)
        if len(resolution) != 2:
            raise ValueError(f"resolution must be (width, height), got {resolution!r}")
        width = check.integer("resolution width", resolution[0], low=1)
        height_px = check.integer("resolution height", resolution[1], low=1)
        if max(width, height_px) > 16384:
            raise ValueError(f"resolution must be at most 16384 px per side, got {resolution}")
        self.resolution = (width, height_px)
        self.near = check.positive("near", near)
        self.far = check.positive("far", far)
        if self.far <= self.near:
            raise ValueError(f"far must be > near ({self.near}), got {self.far}")
        self.projection = Projection(
            check.choice("projection", projection, [p.value for p in Projection])
        )
        self.height = check.positive("height", height)

    @classmethod
    def look_at(cls, position, target, **options) -> Camera:
        """Same as the constructor; reads well at call sites."""
        return cls(position, target, **options)

    def with_resolution(self, resolution) -> Camera:
        """A copy rendering at another resolution (same view)."""
        return Camera(
            self.position,
            self.target,
            up=self.up,
            fov=self.fov,
            resolution=resolution,
            near=self.near,
            far=self.far,
            projection=self.projection,
            height=self.height,
        )

    @property
    def width(self) -> int:
        return self.resolution[0]

    @property
    def height_px(self) -> int:
        return self.resolution[1]

    @property
    def aspect(self) -> float:
        return self.resolution[0] / self.resolution[1]

    @property
    def scale(self) -> float:
        """Pixels per metre at unit depth (perspective) or per metre (orthographic)."""
        if self.projection is Projection.ORTHOGRAPHIC:
            return self.resolution[1] / self.height
        return 0.5 * self.resolution[1] / math.tan(math.radians(self.fov) / 2)

    def packed(self) -> np.ndarray:
        """The camera as the (PACKED_SIZE,) float64 array that kernels take."""
        p = np.zeros(PACKED_SIZE)
        p[RIGHT : RIGHT + 3], p[UP : UP + 3], p[FORWARD : FORWARD + 3] = self.basis
        p[EYE : EYE + 3] = self.position
        p[SCALE] = self.scale
        p[WIDTH], p[HEIGHT] = self.resolution
        p[NEAR], p[FAR] = self.near, self.far
        p[ORTHO] = float(self.projection is Projection.ORTHOGRAPHIC)
        return p

    def to_view(self, points) -> np.ndarray:
        """View-space coordinates (x right, y up, z depth) of (n, 3) world points, float64."""
        return (np.asarray(points, dtype=np.float64).reshape(-1, 3) - self.position) @ self.basis.T

    def project(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Screen position [px] (n, 2) and depth [m] (n,) of (n, 3) world points.

        Points at or behind the eye (perspective) get NaN screen positions; use
        ``near <= depth <= far`` to select visible ones.
        """
        v = self.to_view(points)
        depth = v[:, 2]
        if self.projection is Projection.ORTHOGRAPHIC:
            factor = np.full_like(depth, self.scale)
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                factor = np.where(depth > 0, self.scale / depth, np.nan)
        w, h = self.resolution
        xy = np.stack([0.5 * w + factor * v[:, 0], 0.5 * h - factor * v[:, 1]], axis=1)
        return xy, depth

    def pixels_per_metre(self, depth) -> np.ndarray:
        """Image size [px] of one metre at view depth ``depth`` [m] (array_like)."""
        depth = np.asarray(depth, dtype=np.float64)
        if self.projection is Projection.ORTHOGRAPHIC:
            return np.full_like(depth, self.scale)
        return self.scale / depth

    def screen_fraction(self, center, radius: float) -> float:
        """Fraction of the image covered by a sphere (its projected disc, clipped to the frame).

        Used by level-of-detail emission (Reeves' screen-area scaling). A sphere behind the
        camera covers 0; one containing the eye covers 1.
        """
        v = self.to_view(center)[0]
        if self.projection is Projection.PERSPECTIVE:
            if float(np.linalg.norm(v)) <= radius:
                return 1.0
            if v[2] <= 0:
                return 0.0
        ((x, y),) = self.project(center)[0]
        r = float(self.pixels_per_metre(max(v[2], 1e-300))) * radius
        w, h = self.resolution
        # Overlap of the disc's bounding square with the frame, times the disc/square ratio.
        covered_w = max(0.0, min(x + r, w) - max(x - r, 0.0))
        covered_h = max(0.0, min(y + r, h) - max(y - r, 0.0))
        return min(1.0, (math.pi / 4) * covered_w * covered_h / (w * h))


@device
def to_screen(cam, x, y, z):
    """Project a world point with a packed camera.

    Returns ``(sx, sy, depth, pixels_per_metre)``; the caller culls by depth against
    ``cam[NEAR]`` and ``cam[FAR]`` (for perspective, depth <= 0 gives garbage x, y).
    """
    dx = x - cam[EYE]
    dy = y - cam[EYE + 1]
    dz = z - cam[EYE + 2]
    vx = dx * cam[RIGHT] + dy * cam[RIGHT + 1] + dz * cam[RIGHT + 2]
    vy = dx * cam[UP] + dy * cam[UP + 1] + dz * cam[UP + 2]
    depth = dx * cam[FORWARD] + dy * cam[FORWARD + 1] + dz * cam[FORWARD + 2]
    factor = cam[SCALE] if cam[ORTHO] > 0.5 else cam[SCALE] / max(depth, 1e-12)
    return 0.5 * cam[WIDTH] + factor * vx, 0.5 * cam[HEIGHT] - factor * vy, depth, factor
