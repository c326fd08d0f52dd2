"""Triangle-mesh colliders, with a uniform grid over the triangles for fast queries.

A mesh collides as a two-sided shell of half-thickness ``thickness``: a particle (of
radius r) closer than ``r + thickness`` to a triangle is pushed away from the closest
point on it (Ericson, *Real-Time Collision Detection*, 2005, §5.1.5). Meshes of more than
:data:`GRID_ABOVE` triangles are binned into a uniform grid (each triangle listed in
every cell its bounding box, inflated by ``thickness``, overlaps; a compressed row
list), so a query tests the triangles of a few cells instead of all of them.
"""

from __future__ import annotations

import numpy as np

from .. import _validate as check
from ..geometry.layout import Kind
from ..geometry.mesh import TriangleMesh
from .colliders import Collider, Detection

#: Meshes with at most this many triangles are tested brute force (one cell).
GRID_ABOVE = 32


class TriangleMeshCollider(Collider):
    """A triangle mesh as a thin shell that particles of every kind collide with.

    A shell can be crossed within one step, so paths are swept against it by default
    (``detection="priori"``); with ``"posteriori"`` only particles found within
    ``thickness`` after the move are pushed out.

    Parameters
    ----------
    mesh : TriangleMesh or (vertices (v, 3), faces (f, 3))
        Triangles [m].
    thickness : float
        Half-thickness of the shell >= 0 [m].
    cell_size : float, optional
        Grid cell edge [m]; by default the mean triangle bounding-box edge.
    friction : float
        Coulomb coefficient mu >= 0.
    """

    kind = Kind.MESH
    default_detection = Detection.PRIORI

    def __init__(self, mesh, *, thickness: float = 0.0, cell_size: float | None = None, **response):
        response.setdefault("friction_model", "depth")
        super().__init__(**response)
        if not isinstance(mesh, TriangleMesh):
            if not isinstance(mesh, tuple) or len(mesh) != 2:
                raise TypeError("mesh must be a TriangleMesh or a (vertices, faces) tuple")
            mesh = TriangleMesh(*mesh)
        if len(mesh) == 0:
            raise ValueError("mesh must have at least one triangle")
        if self.inside:
            raise ValueError("inside=True has no meaning for a triangle-mesh shell")
        self.mesh = mesh
        self.thickness = check.non_negative("thickness", thickness)
        self.triangles = mesh.vertices.astype(np.float64)[mesh.faces].reshape(-1, 9)
        lo, hi = self._boxes()
        if cell_size is None:
            cell_size = float(np.mean(hi - lo)) if len(mesh) > GRID_ABOVE else np.inf
        else:
            cell_size = check.positive("cell_size", cell_size)
        self.origin, self.cell_size, self.dims, self.cell_start, self.cell_triangles = _grid(
            lo, hi, cell_size
        )

    def _geometry(self):
        # The index of the first cell is the mesh's place in a table's concatenated
        # grid: :func:`motes.collide.contact.pack` fills it in.
        return [*self.origin, self.cell_size, *self.dims, 0.0, self.thickness]

    def _boxes(self):
        corners = self.triangles.reshape(-1, 3, 3)
        return corners.min(axis=1) - self.thickness, corners.max(axis=1) + self.thickness


def _grid(lo, hi, cell_size):
    """Uniform grid over boxes ``lo``, ``hi`` ((t, 3)): origin, cell, dims, CSR lists."""
    origin = lo.min(axis=0)
    extent = hi.max(axis=0) - origin
    if not np.isfinite(cell_size):
        dims = np.ones(3, dtype=np.int64)
        cell_size = float(max(extent.max(), 1e-9))
    else:
        # At most 64 cells per triangle on average: the grid never dwarfs the mesh.
        cell_size = max(cell_size, float(np.cbrt(np.prod(extent + 1e-9) / (64 * len(lo)))))
        dims = np.maximum(np.ceil(extent / cell_size).astype(np.int64), 1)
    first = np.clip(((lo - origin) / cell_size).astype(np.int64), 0, dims - 1)
    last = np.clip(((hi - origin) / cell_size).astype(np.int64), 0, dims - 1)
    cells, owners = [], []
    for t in range(len(lo)):  # once per mesh, at construction
        i, j, k = np.meshgrid(
            *(np.arange(first[t, a], last[t, a] + 1) for a in range(3)), indexing="ij"
        )
        flat = ((i * dims[1] + j) * dims[2] + k).ravel()
        cells.append(flat)
        owners.append(np.full(flat.size, t))
    cells = np.concatenate(cells)
    owners = np.concatenate(owners)
    order = np.argsort(cells, kind="stable")
    counts = np.bincount(cells, minlength=int(np.prod(dims)))
    start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    return origin, float(cell_size), dims, start, owners[order].astype(np.int64)
