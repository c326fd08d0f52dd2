"""A minimal pinhole camera: enough projection for level-of-detail emission."""

from __future__ import annotations

import math

import numpy as np

from . import _validate as check


class PinholeCamera:
    """Perspective camera looking from ``position`` toward ``target``.

    Parameters
    ----------
    position, target : (3,) array_like
        Eye and look-at point [m]; they must differ.
    fov : float
        Vertical field of view [deg], in (0, 180).
    aspect : float
        Width / height of the image, > 0.
    """

    def __init__(self, position, target, *, fov: float = 45.0, aspect: float = 16 / 9):
        self.position = check.vector("position", position)
        target = check.vector("target", target)
        forward = target - self.position
        if np.linalg.norm(forward) < 1e-12:
            raise ValueError("target must differ from position")
        self.forward = forward / np.linalg.norm(forward)
        self.fov = check.real("fov", fov, low=0.0, high=180.0, low_open=True, high_open=True)
        self.aspect = check.positive("aspect", aspect)

    def screen_fraction(self, center, radius: float) -> float:
        """Fraction of the image covered by a sphere (its projected disc, clipped to the frame).

        Uses the depth of the centre along the view axis; a sphere behind the camera covers 0,
        one containing the eye covers 1.
        """
        offset = np.asarray(center, dtype=np.float64) - self.position
        distance = float(np.linalg.norm(offset))
        if distance <= radius:
            return 1.0
        depth = float(offset @ self.forward)
        if depth <= 0:
            return 0.0
        focal = 1.0 / math.tan(math.radians(self.fov) / 2)  # image half-height = 1
        r = focal * radius / depth
        lateral = offset - depth * self.forward
        # Project the centre: lateral offset scaled onto the image plane (isotropic).
        up = np.cross(np.cross(self.forward, [0.0, 1.0, 0.0]), self.forward)
        up = up / np.linalg.norm(up) if np.linalg.norm(up) > 1e-12 else np.array([0.0, 0.0, 1.0])
        right = np.cross(self.forward, up)
        x = focal * float(lateral @ right) / depth
        y = focal * float(lateral @ up) / depth
        # Overlap of the disc's bounding square with the frame, times the disc/square ratio.
        w = max(0.0, min(x + r, self.aspect) - max(x - r, -self.aspect))
        h = max(0.0, min(y + r, 1.0) - max(y - r, -1.0))
        return min(1.0, (math.pi / 4) * w * h / (4 * self.aspect))
