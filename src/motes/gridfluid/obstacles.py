"""Obstacles of a grid fluid: the scene's colliders rasterised into solid cells.

A cell is solid when its centre lies inside a collider (plane, sphere, oriented box or
capsule: the one signed distance of :mod:`motes.geometry.distance`). A collider that
moves between two steps lends its cells its velocity: the displacement of its centre
(a plane: of its offset along the normal) over the step, so the flow is pushed aside.
Rotation is not taken into account.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit import parallel_kernel
from ..geometry.distance import row_signed_distance
from ..geometry.layout import KIND, G, Kind, stack


@parallel_kernel
def rasterise(table, velocities, origin, h, solid, solid_velocity):
    """Mark cells whose centre is inside a row of ``table`` (k, ROW) as solid (1) and give
    them that row's velocity ``velocities`` (k, 3) [m/s]; the first row containing a cell
    wins. ``solid`` (nz, ny, nx) uint8, ``solid_velocity`` (3, nz, ny, nx) float32."""
    nz, ny, nx = solid.shape
    rows = table.shape[0]
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        pz = origin[2] + (k + 0.5) * h
        py = origin[1] + (j + 0.5) * h
        for i in range(nx):
            px = origin[0] + (i + 0.5) * h
            solid[k, j, i] = 0
            solid_velocity[0, k, j, i] = 0.0
            solid_velocity[1, k, j, i] = 0.0
            solid_velocity[2, k, j, i] = 0.0
            for c in range(rows):
                d, _, _, _ = row_signed_distance(table, c, px, py, pz, 1.0)
                if d < 0.0:
                    solid[k, j, i] = 1
                    solid_velocity[0, k, j, i] = velocities[c, 0]
                    solid_velocity[1, k, j, i] = velocities[c, 1]
                    solid_velocity[2, k, j, i] = velocities[c, 2]
                    break


def anchor(table: np.ndarray) -> np.ndarray:
    """A point of each row that moves with the collider, (k, 3) [m]: the centre (a
    capsule: its midpoint; a plane: the point of its surface nearest the origin)."""
    out = np.zeros((len(table), 3))
    for c, row in enumerate(table):
        kind = Kind(int(row[KIND]))
        if kind == Kind.PLANE:
            out[c] = row[G : G + 3] * row[G + 3]
        elif kind == Kind.CAPSULE:
            out[c] = 0.5 * (row[G : G + 3] + row[G + 3 : G + 6])
        else:
            out[c] = row[G : G + 3]
    return out


class Obstacles:
    """The colliders a grid fluid flows around.

    Parameters
    ----------
    colliders : sequence of motes colliders
        ``motes.colliders.Plane``, ``Sphere``, ``Box`` or ``Capsule``-like objects with
        ``packed()`` (triangle meshes are not rasterised).
    """

    def __init__(self, colliders=()):
        self.colliders = list(colliders)
        for c in self.colliders:
            if not hasattr(c, "packed"):
                raise TypeError(f"obstacles must be colliders, got {c!r}")
            if int(c.packed()[KIND]) == int(Kind.MESH):
                raise ValueError("grid fluid obstacles cannot be triangle meshes yet")
        self._previous: np.ndarray | None = None

    def rasterise(self, origin, h: float, dt: float, solid, solid_velocity) -> bool:
        """Fill ``solid`` and ``solid_velocity``; returns whether anything changed since
        the last call (then the pressure solver needs its levels rebuilt)."""
        table = stack(c.packed() for c in self.colliders)
        if self._previous is not None and np.array_equal(table, self._previous):
            return False
        points = anchor(table)
        if self._previous is not None and len(self._previous) == len(table) and dt > 0:
            velocities = (points - anchor(self._previous)) / dt
        else:
            velocities = np.zeros_like(points)
        rasterise(
            table, velocities, np.asarray(origin, np.float64), float(h), solid, solid_velocity
        )
        self._previous = table
        return True
