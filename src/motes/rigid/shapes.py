"""Rigid shapes made of particles: a tetrahedron, a box, the convex hull of points.

A :class:`BodyShape` lists particle positions and masses, the sticks that hold them
rigid and, for solid shapes, the outward face planes other bodies collide with.
Jakobsen (2001, §5) builds rigid bodies this way: four particles and six sticks make a
tetrahedron, which cannot deform without stretching a stick; any set of particles
joined by every pair is rigid as long as it is not flat.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from .. import _validate as check


@dataclass(frozen=True)
class BodyShape:
    """Particles, sticks and faces of a rigid body at rest (world coordinates).

    Attributes
    ----------
    positions : (k, 3) float64
        Particle positions [m].
    masses : (k,) float64
        Particle masses [kg], > 0.
    sticks : (s, 2) int64
        Pairs of local particle indices held at their rest distance.
    planes : (f, 4) float64
        Faces ``n · x <= d`` (unit outward n, d [m]) of the solid; empty for shapes that
        do not push other bodies away (sticks, chains).
    """

    positions: np.ndarray
    masses: np.ndarray
    sticks: np.ndarray
    planes: np.ndarray

    @property
    def mass(self) -> float:
        return float(self.masses.sum())

    @property
    def center(self) -> np.ndarray:
        """Centre of mass [m]."""
        return self.masses @ self.positions / self.mass

    def box_geometry(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The box this solid is, or None when it is not a box.

        Returns ``(centre (3,), half_extents (3,), axes (3, 3))`` in the shape's
        coordinates [m]: the axes are unit rows, the face normals of three pairs of
        opposite, mutually orthogonal faces (any box, rotated or not, of
        :meth:`box` or :meth:`from_points`).
        """
        planes = self.planes
        if len(planes) != 6:
            return None
        normals, offsets = planes[:, :3], planes[:, 3]
        axes, centre, half = [], [], []
        used = np.zeros(6, dtype=bool)
        for f in range(6):
            if used[f]:
                continue
            opposite = np.flatnonzero(~used & (normals @ normals[f] < -1 + 1e-6))
            if len(opposite) != 1:
                return None
            g = int(opposite[0])
            used[[f, g]] = True
            axes.append(normals[f])
            half.append(0.5 * (offsets[f] + offsets[g]))
            centre.append(0.5 * (offsets[f] - offsets[g]))
        axes = np.array(axes)
        if not np.allclose(axes @ axes.T, np.eye(3), atol=1e-6):
            return None
        u, _, vt = np.linalg.svd(axes)  # the nearest orthonormal rows (faces are rounded)
        axes = u @ vt
        return centre @ axes, np.array(half), axes

    @classmethod
    def from_points(cls, points, mass: float = 1.0, *, solid: bool = True) -> BodyShape:
        """Every pair of ``points`` joined by a stick, mass shared equally.

        ``solid`` adds the convex hull's faces (the points must not be coplanar).
        """
        pts = check.points("points", points, min_rows=2)
        total = check.positive("mass", mass)
        k = len(pts)
        sticks = np.array(list(combinations(range(k), 2)), dtype=np.int64).reshape(-1, 2)
        planes = hull_planes(pts) if solid else np.zeros((0, 4))
        return cls(pts, np.full(k, total / k), sticks, planes)

    @classmethod
    def tetrahedron(
        cls, center=(0.0, 0.0, 0.0), edge: float = 1.0, mass: float = 1.0, *, rotation=None
    ) -> BodyShape:
        """A regular tetrahedron: four particles, six sticks (Jakobsen's example)."""
        edge = check.positive("edge", edge)
        corners = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
        corners *= edge / (2 * np.sqrt(2))
        return cls.from_points(_place(corners, center, rotation), mass)

    @classmethod
    def box(
        cls, center=(0.0, 0.0, 0.0), size=(1.0, 1.0, 1.0), mass: float = 1.0, *, rotation=None
    ) -> BodyShape:
        """A box: eight corner particles and 28 sticks (12 edges, 12 face diagonals,
        4 body diagonals). Corner ``i`` sits at local ``((i & 1), (i >> 1 & 1),
        (i >> 2 & 1)) - 1/2`` times ``size``, the corner order of ``render.geometry.Box``.
        """
        size = check.vector("size", size)
        if np.any(size <= 0):
            raise ValueError(f"size must be > 0 along every axis, got {size.tolist()}")
        corners = np.array([[i & 1, i >> 1 & 1, i >> 2 & 1] for i in range(8)], float) - 0.5
        return cls.from_points(_place(corners * size, center, rotation), mass)

    @classmethod
    def convex_hull(cls, points, mass: float = 1.0) -> BodyShape:
        """The convex hull of ``points`` (at least four, not coplanar) as a rigid body.

        Points inside the hull are kept as particles (they add mass and sticks).
        """
        return cls.from_points(points, mass)


def _place(local, center, rotation):
    c = check.vector("center", center)
    r = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
    if r.shape != (3, 3) or not np.allclose(r @ r.T, np.eye(3), atol=1e-6):
        raise ValueError("rotation must be a (3, 3) rotation matrix")
    if np.linalg.det(r) < 0:
        raise ValueError("rotation must be a rotation (det +1), not a reflection")
    return c + local @ r.T


def hull_planes(points: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Outward faces ``(f, 4)`` (unit n, d) of the convex hull of a few points.

    Brute force over every triple, O(k⁴), for the tens of particles of one body: a
    triple's plane is a face when every point lies on one side of it.
    """
    pts = np.asarray(points, dtype=np.float64)
    scale = max(float(np.ptp(pts, axis=0).max()), 1e-300)
    triples = np.array(list(combinations(range(len(pts)), 3)))
    if len(triples) == 0:
        raise ValueError("points must have at least 4 points for a solid body")
    a, b, c = pts[triples[:, 0]], pts[triples[:, 1]], pts[triples[:, 2]]
    n = np.cross(b - a, c - a)
    length = np.linalg.norm(n, axis=1)
    ok = length > 1e-9 * scale * scale
    n, a = n[ok] / length[ok, None], a[ok]
    d = np.einsum("fi,fi->f", n, a)
    side = pts @ n.T - d  # (k, f)
    above = (side > tol * scale).any(axis=0)
    below = (side < -tol * scale).any(axis=0)
    face = above ^ below
    flip = np.where(above[face], -1.0, 1.0)  # all points must be on the inner side
    planes = np.concatenate([n[face] * flip[:, None], (d[face] * flip)[:, None]], axis=1)
    if len(planes) < 4:
        raise ValueError("points are coplanar or collinear: a solid body needs volume")
    return np.unique(np.round(planes, 9), axis=0)
