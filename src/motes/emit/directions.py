"""Directions of initial velocity: a cone about an axis, the shape's normal, or radial."""

from __future__ import annotations

import math

import numpy as np

from .. import _validate as check
from .shapes import along


def orthonormal_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors perpendicular to the unit vector ``axis`` and to each other."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(axis, u)


class Direction:
    """Base class: ``sample(rng, positions, normals) -> unit vectors (count, 3)``."""

    def sample(self, rng, positions: np.ndarray, normals: np.ndarray) -> np.ndarray:
        raise TypeError(f"{type(self).__name__} is abstract")


class Cone(Direction):
    """Uniform over the solid-angle cap of half-angle ``angle`` [deg] about ``axis``.

    ``angle=180`` gives an isotropic (spherical) spray; ``angle=0`` the axis itself.
    """

    def __init__(self, axis=(0.0, 1.0, 0.0), angle: float = 30.0):
        self.axis = check.unit_vector("axis", axis)
        self.angle = check.real("angle", angle, low=0.0, high=180.0)
        self._u, self._v = orthonormal_basis(self.axis)

    def sample(self, rng, positions, normals):
        count = positions.shape[0]
        # cos(theta) uniform on [cos(angle), 1] is uniform in solid angle (Archimedes).
        cos_min = math.cos(math.radians(self.angle))
        cos_t = 1 - rng.random(count) * (1 - cos_min)
        sin_t = np.sqrt(np.maximum(0.0, 1 - cos_t**2))
        phi = rng.random(count) * 2 * np.pi
        return along(
            (self.axis, cos_t), (self._u, sin_t * np.cos(phi)), (self._v, sin_t * np.sin(phi))
        )


class Isotropic(Cone):
    """Uniformly random directions over the whole sphere."""

    def __init__(self):
        super().__init__(angle=180.0)


class ShapeNormal(Direction):
    """Along the emitter shape's normal at each sample point, optionally jittered.

    ``spread`` [deg] draws uniformly from a cone of that half-angle about the normal.
    """

    def __init__(self, spread: float = 0.0):
        self.spread = check.real("spread", spread, low=0.0, high=180.0)

    def sample(self, rng, positions, normals):
        if self.spread == 0 or positions.shape[0] == 0:
            return normals.copy()
        local = Cone((0.0, 0.0, 1.0), self.spread).sample(rng, positions, normals)
        # Rotate each local cone sample (about +z) onto its normal, with a per-particle frame.
        n = normals
        helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        u = np.cross(n, helper)
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        v = np.cross(n, u)
        return local[:, :1] * u + local[:, 1:2] * v + local[:, 2:] * n


class Radial(Direction):
    """Away from the emitter's centre (random where a sample sits exactly at the centre)."""

    def sample(self, rng, positions, normals):
        dist = np.linalg.norm(positions, axis=1, keepdims=True)
        random = Isotropic().sample(rng, positions, normals)
        return np.where(dist > 1e-12, positions / np.where(dist > 0, dist, 1.0), random)
