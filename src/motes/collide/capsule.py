"""Capsules: a segment swept by a sphere, for limbs, railings and rounded obstacles."""

from __future__ import annotations

import numpy as np

from .. import _validate as check
from ..geometry.layout import Kind
from .colliders import Collider


class Capsule(Collider):
    """Solid capsule: every point within ``radius`` of the segment from ``a`` to ``b``.

    Collides with particles of every kind; swept (``detection="priori"``) only as a
    solid (not with ``inside=True``).

    Parameters
    ----------
    a, b : (3,) array_like
        Ends of the axis [m] (may coincide: a sphere).
    radius : float
        > 0 [m]
    friction : float
        Coulomb coefficient mu >= 0 (the rigid world's depth-based friction).
    """

    kind = Kind.CAPSULE

    def __init__(self, a=(0.0, 0.0, 0.0), b=(0.0, 1.0, 0.0), radius: float = 0.1, **response):
        response.setdefault("friction_model", "depth")
        super().__init__(**response)
        self.a = check.vector("a", a)
        self.b = check.vector("b", b)
        self.radius = check.positive("radius", radius)
        if self.inside and self.swept:
            raise ValueError(
                "detection 'priori' needs a solid capsule: with inside=True use 'posteriori'"
            )

    def _geometry(self):
        return [*self.a, *self.b, self.radius]

    def closest(self, points) -> np.ndarray:
        """Closest points on the axis to ``points`` ((n, 3) [m])."""
        p = np.asarray(points, dtype=np.float64)
        ab = self.b - self.a
        denom = max(float(ab @ ab), 1e-300)
        t = np.clip((p - self.a) @ ab / denom, 0.0, 1.0)
        return self.a + t[:, None] * ab
