"""Slow, obviously correct twins of the metaball and marching cubes kernels.

The metaball twins sum Blinn's field over every (node, particle) pair in float64, with
the cut-off written as in the docstrings: particle ``i`` counts only where
``|x - p_i|² < r_c,i²``. The marching cubes twin walks the cells in Python and welds
vertices through a dictionary keyed by grid edge; it uses the same case tables as the
kernels (those are checked on their own, by topology), so it checks the compiled
indexing, numbering, welding and interpolation.
"""

from __future__ import annotations

import numpy as np

from motes.render.marching_cubes import CORNER_OFFSETS, EDGE_CORNERS, case_tables


def reach2(strength, cutoff, threshold, a):
    """Squared reach ``ln(b_i / (cutoff T)) / a`` [m²] of particles of strength ``b_i``."""
    with np.errstate(divide="ignore"):
        return np.log(np.asarray(strength, np.float64) / (cutoff * threshold)) / a


def grid_nodes(origin, shape, spacing):
    """Node positions [m], shape ``shape + (3,)``."""
    spacing = np.broadcast_to(np.asarray(spacing, np.float64), (3,))
    axes = [origin[c] + spacing[c] * np.arange(shape[c]) for c in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)


def field(positions, origin, shape, spacing, a, strength, radius2):
    """``D = Σ_i b_i e^{-a |x - p_i|²}`` over ``|x - p_i|² < r_c,i²`` at every node."""
    nodes = grid_nodes(origin, shape, spacing)
    out = np.zeros(shape)
    for p, s, r2 in zip(np.asarray(positions, np.float64), strength, radius2, strict=True):
        d2 = np.sum((nodes - p) ** 2, axis=-1)
        out += np.where(d2 < r2, s * np.exp(-a * d2), 0.0)
    return out


def gradient(points, positions, a, strength, radius2):
    """``∇D = -2a Σ_i b_i (x - p_i) e^{-a |x - p_i|²}`` at ``points`` (m, 3)."""
    points = np.asarray(points, np.float64)
    out = np.zeros_like(points)
    for p, s, r2 in zip(np.asarray(positions, np.float64), strength, radius2, strict=True):
        d = points - p
        d2 = np.sum(d**2, axis=1)
        out += np.where(d2 < r2, -2.0 * a * s * np.exp(-a * d2), 0.0)[:, None] * d
    return out


def marching_cubes(field, level, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0)):
    """Welded marching cubes, cell by cell: ``(vertices (v, 3), faces (f, 3))``.

    Inside is ``field > level`` compared in float32 (as the kernel does); crossings are
    interpolated in float64.
    """
    field = np.asarray(field, np.float32)
    level = np.float32(level)
    spacing = np.asarray(spacing, np.float64)
    origin = np.asarray(origin, np.float64)
    counts, table = case_tables()
    vertex_of: dict[tuple, int] = {}
    vertices: list[np.ndarray] = []
    faces: list[list[int]] = []

    def vertex(n0, n1) -> int:
        key = (n0, n1)
        if key not in vertex_of:
            f0, f1 = np.float64(field[n0]), np.float64(field[n1])
            t = (np.float64(level) - f0) / (f1 - f0)
            index = np.array(n0) + t * (np.array(n1) - np.array(n0))
            vertex_of[key] = len(vertices)
            vertices.append(origin + spacing * index)
        return vertex_of[key]

    nx, ny, nz = field.shape
    for i in range(nx - 1):
        for j in range(ny - 1):
            for k in range(nz - 1):
                corners = [tuple(int(x) for x in (i, j, k) + CORNER_OFFSETS[c]) for c in range(8)]
                case = sum(1 << c for c in range(8) if field[corners[c]] > level)
                for t in range(counts[case]):
                    faces.append(
                        [
                            vertex(corners[EDGE_CORNERS[e, 0]], corners[EDGE_CORNERS[e, 1]])
                            for e in table[case, t]
                        ]
                    )
    return np.array(vertices).reshape(-1, 3), np.array(faces, dtype=np.int64).reshape(-1, 3)


# -- mesh checks shared by the tests ------------------------------------------------------
def is_closed_and_oriented(faces) -> bool:
    """Whether every directed edge ``(a, b)`` of the faces occurs once and ``(b, a)`` once.

    That is: every edge borders exactly two triangles (a closed 2-manifold along edges)
    and the two traverse it in opposite directions (consistent orientation).
    """
    faces = np.asarray(faces, np.int64)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    n = int(faces.max()) + 1 if faces.size else 0
    forward = edges[:, 0] * n + edges[:, 1]
    backward = edges[:, 1] * n + edges[:, 0]
    return bool(
        len(np.unique(forward)) == len(forward)
        and np.array_equal(np.sort(forward), np.sort(backward))
    )


def component_count(faces) -> int:
    """Number of edge-connected pieces of a triangle mesh (union-find over vertices)."""
    faces = np.asarray(faces, np.int64)
    if faces.size == 0:
        return 0
    parent = np.arange(int(faces.max()) + 1)

    def root(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for a, b, c in faces:
        ra, rb, rc = root(a), root(b), root(c)
        parent[rb] = ra
        parent[rc] = ra
    return len({root(v) for v in np.unique(faces)})


def same_triangles(vertices, faces, other_vertices, other_faces, *, atol) -> bool:
    """Whether two meshes have the same vertices (within ``atol``, matched one to one)
    and the same oriented triangles, whatever their numbering."""
    from scipy.spatial import cKDTree

    if len(vertices) != len(other_vertices) or len(faces) != len(other_faces):
        return False
    distance, match = cKDTree(other_vertices).query(vertices)
    if len(vertices) and (distance.max() > atol or len(np.unique(match)) != len(match)):
        return False

    def canonical(tris):
        tris = np.asarray(tris, np.int64)
        start = np.argmin(tris, axis=1)  # rotate, keeping the orientation
        rows = np.arange(len(tris))[:, None]
        return {tuple(t) for t in tris[rows, (start[:, None] + np.arange(3)) % 3]}

    return canonical(match[np.asarray(faces)]) == canonical(other_faces)
