"""Cloth topology: triangles, spring families and lumped masses (NumPy, built once)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Topology:
    """The springs and masses of a cloth.

    Attributes
    ----------
    vertices : float64 (n, 3)
        Rest positions [m].
    faces : int64 (f, 3)
        Triangles, counter-clockwise.
    structural, shear, bending : int64 (m_i, 2)
        Spring pairs of each family.
    """

    vertices: np.ndarray
    faces: np.ndarray
    structural: np.ndarray
    shear: np.ndarray
    bending: np.ndarray


def grid(nx: int, ny: int, width: float, height: float) -> Topology:
    """A ``nx`` × ``ny`` vertex grid in the local x-y plane, ``x`` in [0, width], ``y`` in
    [-height, 0] (row 0 on top), two triangles per cell. The shear springs cross both
    diagonals, so the split of cells does not make the cloth anisotropic.

    Springs (Provot 1995): structural between horizontal and vertical neighbours, shear
    along both diagonals of each cell, bending between vertices two apart along rows and
    columns.
    """
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))  # j: row (down), i: column
    vertices = np.stack(
        [i * width / (nx - 1), -j * height / (ny - 1), np.zeros(i.shape)], axis=-1
    ).reshape(-1, 3)
    index = np.arange(nx * ny).reshape(ny, nx)
    a = index[:-1, :-1].ravel()
    b = index[:-1, 1:].ravel()
    c = index[1:, :-1].ravel()
    d = index[1:, 1:].ravel()
    # Counter-clockwise seen from +z: a (top-left), c (below), d, b. One diagonal
    # direction throughout keeps the lumped masses uniform (alternating diagonals give
    # interior vertices 4 or 8 triangles: masses of 2/3 and 4/3 of a cell).
    t1 = np.stack([a, c, d], 1)
    t2 = np.stack([a, d, b], 1)
    faces = np.concatenate([t1, t2])
    structural = np.concatenate(
        [
            np.stack([index[:, :-1].ravel(), index[:, 1:].ravel()], 1),
            np.stack([index[:-1, :].ravel(), index[1:, :].ravel()], 1),
        ]
    )
    shear = np.concatenate([np.stack([a, d], 1), np.stack([b, c], 1)])
    bending = np.concatenate(
        [
            np.stack([index[:, :-2].ravel(), index[:, 2:].ravel()], 1),
            np.stack([index[:-2, :].ravel(), index[2:, :].ravel()], 1),
        ]
    )
    return Topology(vertices, faces.astype(np.int64), structural, shear, bending)


def from_triangles(vertices, faces) -> Topology:
    """Springs of an arbitrary triangle mesh.

    Structural springs on every edge; bending springs between the two vertices opposite
    a shared edge (across each pair of adjacent triangles). A triangle mesh's edges
    already resist shear, so there is no separate shear family (empty).
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    opposite = np.concatenate([faces[:, 2], faces[:, 0], faces[:, 1]])
    key = np.sort(edges, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    key, opposite = key[order], opposite[order]
    new = np.ones(len(key), dtype=bool)
    new[1:] = np.any(key[1:] != key[:-1], axis=1)
    structural = key[new]
    # Edges shared by exactly two triangles: consecutive equal keys.
    pair = ~new[1:]
    first = np.flatnonzero(pair)
    bending = np.stack([opposite[first], opposite[first + 1]], 1)
    bending = bending[bending[:, 0] != bending[:, 1]]
    return Topology(vertices, faces, structural, np.empty((0, 2), np.int64), bending)


def vertex_masses(vertices: np.ndarray, faces: np.ndarray, density: float) -> np.ndarray:
    """Lumped masses [kg]: each triangle's area × ``density`` [kg/m²], a third per corner."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    mass = np.zeros(len(vertices))
    for k in range(3):
        mass += np.bincount(faces[:, k], weights=area * density / 3.0, minlength=len(vertices))
    return mass


def vertex_triangles(faces: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertex -> triangle incidence in CSR form: ``(first (n + 1,), tris)``."""
    corner = faces.ravel()
    order = np.argsort(corner, kind="stable")
    tris = (order // 3).astype(np.int64)
    counts = np.bincount(corner, minlength=n)
    first = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    return first, tris
