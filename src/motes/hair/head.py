"""The head hair grows on: a moving sphere, and where and how strands leave its scalp."""

from __future__ import annotations

import numpy as np

from .. import _validate as check
from ..cloth.drivers import Keyframes


def euler_matrix(angles_deg) -> np.ndarray:
    """Rotation ``R_y(yaw) R_x(pitch) R_z(roll)`` from (yaw, pitch, roll) [degrees]:
    yaw turns the head about the vertical, pitch nods it."""
    yaw, pitch, roll = np.radians(np.asarray(angles_deg, dtype=np.float64))
    cy, sy, cp, sp, cr, sr = (
        np.cos(yaw),
        np.sin(yaw),
        np.cos(pitch),
        np.sin(pitch),
        np.cos(roll),
        np.sin(roll),
    )
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rx = np.array([[1, 0, 0], [0, cp, -sp], [0, sp, cp]])
    rz = np.array([[cr, -sr, 0], [sr, cr, 0], [0, 0, 1]])
    return ry @ rx @ rz


class Head:
    """A sphere that translates and rotates over time.

    Parameters
    ----------
    center : (3,) array_like
        Centre at rest [m].
    radius : float
        > 0 [m].
    translation : Keyframes, optional
        Offset of the centre [m] over time.
    rotation : Keyframes, optional
        (yaw, pitch, roll) [degrees] over time (see :func:`euler_matrix`).
    friction : float
        Friction of hair on the scalp, in [0, 1] (velocity scaling).
    """

    def __init__(
        self,
        center=(0.0, 0.0, 0.0),
        radius: float = 0.1,
        *,
        translation=None,
        rotation=None,
        friction: float = 0.3,
    ):
        self.center = check.vector("center", center)
        self.radius = check.positive("radius", radius)
        for name, value in (("translation", translation), ("rotation", rotation)):
            if value is not None and not isinstance(value, Keyframes):
                raise TypeError(f"{name} must be Keyframes, got {value!r}")
        self.translation = translation
        self.rotation = rotation
        self.friction = check.unit_interval("friction", friction)

    def pose(self, time: float) -> tuple[np.ndarray, np.ndarray]:
        """Rotation (3, 3) and centre (3,) [m] at ``time`` [s]."""
        r = np.eye(3) if self.rotation is None else euler_matrix(self.rotation(time))
        c = self.center + (0.0 if self.translation is None else self.translation(time))
        return r, c

    def __repr__(self) -> str:
        return f"Head(center={self.center.tolist()}, radius={self.radius})"


def scalp_directions(count: int, *, seed: int = 0, coverage: float = 0.55) -> np.ndarray:
    """``count`` unit vectors spread over the top, back and sides of a head (y up, face
    +z).

    Uniform on the sphere cap ``y >= 1 - 2·coverage`` inside a hairline: above the
    forehead (``z < 0.55`` where ``y > 0.5``), the temples (``z < 0.15`` where
    ``y > 0.15``) and the back (``z < -0.25``); the face stays bare. Drawn from ``seed``.
    """
    rng = np.random.default_rng(check.integer("seed", seed, low=0))
    out = np.empty((0, 3))
    while len(out) < count:
        y = rng.uniform(1 - 2 * coverage, 1.0, 2 * count)
        phi = rng.uniform(0, 2 * np.pi, 2 * count)
        r = np.sqrt(1 - y * y)
        d = np.stack([r * np.cos(phi), y, r * np.sin(phi)], 1)
        z = d[:, 2]
        scalp = ((y > 0.5) & (z < 0.55)) | ((y > 0.15) & (z < 0.15)) | (z < -0.25)
        out = np.concatenate([out, d[scalp]])
    return out[:count]


def growth_directions(roots: np.ndarray, comb, lift: float) -> np.ndarray:
    """Unit directions in which strands leave the scalp at ``roots`` (k, 3) (unit,
    from the head's centre): ``comb`` projected onto the scalp's tangent plane, tilted
    out of it by ``lift`` (``t + lift·n``, normalised; radial where ``comb`` is normal
    to the scalp)."""
    c = np.asarray(comb, dtype=np.float64)
    tangent = c[None, :] - (roots @ c)[:, None] * roots
    size = np.linalg.norm(tangent, axis=1, keepdims=True)
    along = np.where(size > 1e-6, tangent / np.maximum(size, 1e-300), 0.0)
    g = along + lift * roots
    return g / np.linalg.norm(g, axis=1, keepdims=True)
