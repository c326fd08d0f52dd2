r"""Marching cubes (Lorensen & Cline 1987) with welded vertices, in compiled kernels.

W. E. Lorensen and H. E. Cline, "Marching cubes: a high resolution 3D surface
construction algorithm", SIGGRAPH 1987. The surface ``field == level`` of a scalar field
sampled on a regular grid is approximated cell by cell: the signs of a cell's eight
corners (inside is ``field > level``, the metaball convention) select one of 256 cases,
each edge whose endpoints differ carries a vertex at the linearly interpolated crossing

.. math:: x = x_0 + t\,(x_1 - x_0), \qquad t = \frac{\text{level} - f_0}{f_1 - f_0},

and the case's triangles join those vertices.

Case tables
-----------
The tables are generated here, at import, from the cube's geometry (no table is copied):
on each face of the cube the cut edges are joined into segments, the segments are
chained into closed polygons, and each polygon is split into triangles (a fan where
possible). A face with two diagonally opposite inside corners is ambiguous; it is always
resolved by *separating the inside corners* (each segment cuts one inside corner off).
The rule depends only on the face's four signs, so the two cells sharing a face draw the
same segments there and the surface is closed: every interior mesh edge borders exactly
two triangles. For the same reason no triangle's diagonal may join two vertices of one
face (the neighbour would draw that edge too). Lewiner et al.'s tables, used by
scikit-image, decide ambiguous faces by the bilinear saddle value instead and split some
polygons along other diagonals; the vertices are the same.

Segments are directed so that, seen from outside the cube, the inside corner lies to the
right; the chained polygons and their triangles are then counter-clockwise seen from the
outside (``field <= level``), so the right-hand rule gives outward normals.

Welding and determinism
-----------------------
Each crossed *grid* edge owns one vertex, shared by the up to four cells around it, so
the mesh is indexed and watertight away from the grid boundary. Grid edges belong to the
node plane ``i`` of their lower endpoint. A first parallel pass over planes counts each
plane's vertices and each slab's triangles and numbers the plane's vertices locally; a
prefix sum gives offsets; a second parallel pass writes vertices and faces. Each plane is
one parallel work item with serial loops inside, so the output (order included) does not
depend on the number of threads.
"""

from __future__ import annotations

import functools

import numba
import numpy as np

from .. import _validate
from .._jit import block_bounds, block_count, device, parallel_kernel

#: Corner ``c`` of a cell sits at offset ``(c & 1, (c >> 1) & 1, (c >> 2) & 1)`` [cells].
CORNER_OFFSETS = np.array([[c & 1, (c >> 1) & 1, (c >> 2) & 1] for c in range(8)], np.int64)

#: The 12 cell edges as corner pairs (lower corner first): 4 along x, 4 along y, 4 along z.
EDGE_CORNERS = np.array(
    [(c, c | (1 << axis)) for axis in range(3) for c in range(8) if not c & (1 << axis)],
    np.int64,
)

#: Axis of each cell edge, and the cell offset of its lower corner: together they name the
#: grid edge ``(axis, i + di, j + dj, k + dk)`` a cell edge is.
EDGE_AXIS = np.repeat(np.arange(3), 4)
EDGE_OFFSETS = CORNER_OFFSETS[EDGE_CORNERS[:, 0]]


def _faces() -> list[tuple[int, int, list[tuple[int, int, int]]]]:
    """The six cube faces: axis and side of the outward normal, and the four face edges
    in cyclic order as ``(edge, corner, corner)``."""
    edge_of = {tuple(pair): e for e, pair in enumerate(EDGE_CORNERS.tolist())}
    faces = []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for side in (0, 1):
            base = side << axis
            ring = (base, base | 1 << u, base | 1 << u | 1 << v, base | 1 << v)
            edges = []
            for q in range(4):
                c0, c1 = ring[q], ring[(q + 1) % 4]
                edges.append((edge_of[min(c0, c1), max(c0, c1)], c0, c1))
            faces.append((axis, side, edges))
    return faces


#: Corners of each cube face.
_FACE_CORNERS = [
    {c for c in range(8) if (c >> axis & 1) == side} for axis in range(3) for side in (0, 1)
]


def _turn(a, b, p, axis: int, side: int) -> float:
    """Component along the face's outward normal of ``(b - a) x (p - a)``."""
    u, v = (axis + 1) % 3, (axis + 2) % 3
    cross = (b[u] - a[u]) * (p[v] - a[v]) - (b[v] - a[v]) * (p[u] - a[u])
    return cross if side else -cross


def _case_polygons(case: int) -> list[list[int]]:
    """Closed, outward-oriented polygons (lists of cell edges) for one corner sign case.

    Bit ``c`` of ``case`` is set when corner ``c`` is inside (``field > level``).
    """
    inside = [bool(case >> c & 1) for c in range(8)]
    corner = CORNER_OFFSETS.tolist()
    midpoint = [
        [(p + q) / 2 for p, q in zip(corner[c0], corner[c1], strict=True)]
        for c0, c1 in EDGE_CORNERS.tolist()
    ]
    following: dict[int, int] = {}
    for axis, side, edges in _faces():
        # Cut edges in ring order, each with its inside corner.
        cut = [(e, c0 if inside[c0] else c1) for e, c0, c1 in edges if inside[c0] != inside[c1]]
        if len(cut) == 2:
            segments = [(cut[0], cut[1])]
        elif len(cut) == 4:
            # Ambiguous face: pair the two cut edges around the same inside corner.
            by_corner: dict[int, list] = {}
            for item in cut:
                by_corner.setdefault(item[1], []).append(item)
            segments = [tuple(pair) for pair in by_corner.values()]
        else:
            segments = []
        for (e0, c), (e1, _) in segments:
            # Inside corner on the right seen from outside the cube (see module docstring).
            if _turn(midpoint[e0], midpoint[e1], corner[c], axis, side) > 0:
                e0, e1 = e1, e0
            if e0 in following:
                raise AssertionError(f"case {case}: edge {e0} starts two segments")
            following[e0] = e1
    if sorted(following) != sorted(following.values()):
        raise AssertionError(f"case {case}: segments do not close into polygons")
    polygons = []
    while following:
        start = min(following)
        polygon = [start]
        edge = following.pop(start)
        while edge != start:
            polygon.append(edge)
            edge = following.pop(edge)
        polygons.append(polygon)
    return polygons


def _share_face(e0: int, e1: int) -> bool:
    """Whether two cell edges lie on one cube face (they share a corner or are opposite
    sides of a face)."""
    corners = set(EDGE_CORNERS[e0].tolist()) | set(EDGE_CORNERS[e1].tolist())
    return any(len(corners & set(ring)) == len(corners) for ring in _FACE_CORNERS)


def _triangulate(polygon: list[int]) -> list[tuple[int, int, int]] | None:
    """Triangles covering a polygon, none of whose diagonals lies on a cube face.

    A diagonal between two cut edges of the same face would be drawn, as the same mesh
    edge, by the neighbour cell too (it sees the same two vertices), and four triangles
    would then share one edge. Only ambiguous faces have such non-adjacent pairs. Tries
    the fan from each vertex first, then any triangulation (depth-first, by the triangle
    on the closing edge).
    """
    n = len(polygon)
    for apex in range(n):
        p = polygon[apex:] + polygon[:apex]
        if not any(_share_face(p[0], p[q]) for q in range(2, n - 1)):
            return [(p[0], p[q], p[q + 1]) for q in range(1, n - 1)]

    def split(p: list[int]) -> list[tuple[int, int, int]] | None:
        if len(p) == 3:
            return [tuple(p)]
        for q in range(1, len(p) - 1):
            if (q > 1 and _share_face(p[0], p[q])) or (q < len(p) - 2 and _share_face(p[q], p[-1])):
                continue
            left = split(p[: q + 1]) if q > 1 else []
            right = split(p[q:]) if q < len(p) - 2 else []
            if left is not None and right is not None:
                return [*left, (p[0], p[q], p[-1]), *right]
        return None

    return split(polygon)


@functools.cache
def case_tables() -> tuple[np.ndarray, np.ndarray]:
    """Triangle tables for the 256 corner sign cases, generated once.

    Returns
    -------
    counts : (256,) int64
        Number of triangles of each case.
    triangles : (256, m, 3) int64
        Cell edges (0-11, see :data:`EDGE_CORNERS`) of each triangle, counter-clockwise
        seen from outside; rows past ``counts[case]`` are -1.
    """
    per_case = []
    for case in range(256):
        triangles = []
        for polygon in _case_polygons(case):
            found = _triangulate(polygon)
            if found is None:
                raise AssertionError(f"case {case}: no triangulation of {polygon}")
            triangles += found
        per_case.append(triangles)
    counts = np.array([len(t) for t in per_case], dtype=np.int64)
    table = np.full((256, counts.max(), 3), -1, dtype=np.int64)
    for case, triangles in enumerate(per_case):
        if triangles:
            table[case, : len(triangles)] = triangles
    counts.flags.writeable = False
    table.flags.writeable = False
    return counts, table


# -- kernels ------------------------------------------------------------------------------
# The kernels index the grid as flat arrays: node (i, j, k) is (i * ny + j) * nz + k, and
# its neighbours along x, y, z are + ny * nz, + nz, + 1. On the last plane (row) the x (y)
# stride is 0: a node compared with itself is never crossed.

#: Bits of ``row_flags``: the row owns crossed edges / the row of cells has triangles.
_EDGES, _CELLS = 1, 2


@device
def _store(vertices, v, x, y, z):
    vertices[v, 0] = x
    vertices[v, 1] = y
    vertices[v, 2] = z


@parallel_kernel
def _inside_kernel(field, level, inside):
    """``inside[n] = field[n] > level`` as 0 or 1 (flat arrays)."""
    n = field.size
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for q in range(start, stop):
            inside[q] = field[q] > level


@parallel_kernel
def _count_kernel(
    inside, shape, plane_order, tri_counts, crossing, edge_id, cases, row_flags,
    plane_vertices, slab_triangles,
):  # fmt: skip
    """Pass 1: number each plane's crossed edges, record cell cases, count triangles.

    ``crossing[node]`` gets bits 0, 1, 2 set where the x, y, z grid edges from ``node``
    are crossed (in rows that have crossings), ``edge_id[axis * N + node]`` the
    plane-local index of the vertex on the grid edge
    along ``axis`` from ``node`` (only where it is crossed), numbered in node order and
    x, y, z at each node; ``cases[node]`` the corner sign case of the cell whose corner 0
    is ``node`` (bit ``c`` for corner ``c``, see ``CORNER_OFFSETS``). Most rows of a grid
    cross nothing: branch-free, vectorised scans find the rows that do (``row_flags``),
    and only those are walked node by node.
    """
    nx, ny, nz = shape[0], shape[1], shape[2]
    plane = ny * nz
    size = nx * plane
    one = np.uint64(1)
    for p in numba.prange(nx):
        i = plane_order[p]
        sx = np.uint64(plane if i < nx - 1 else 0)
        count = 0
        triangles = 0
        for j in range(ny):
            sy = np.uint64(nz if j < ny - 1 else 0)
            base = np.uint64((i * ny + j) * nz)
            # Bits 0, 1, 2 of crossing[node]: the x, y, z edges from the node are crossed.
            any_crossed = 0
            for k in range(np.uint64(nz - 1)):
                c = inside[base + k]
                bits = (
                    (c ^ inside[base + sx + k])
                    | (c ^ inside[base + sy + k]) << 1
                    | (c ^ inside[base + k + one]) << 2
                )
                crossing[base + k] = bits
                any_crossed |= bits
            last = base + np.uint64(nz - 1)  # no z-edge
            c = inside[last]
            bits = (c ^ inside[last + sx]) | (c ^ inside[last + sy]) << 1
            crossing[last] = bits
            any_crossed |= bits
            flags = 0
            if any_crossed:
                flags |= _EDGES
                for k in range(np.uint64(nz)):
                    node = base + k
                    bits = crossing[node]
                    if bits:
                        for axis in range(3):
                            if bits >> axis & 1:
                                edge_id[np.uint64(axis * size) + node] = count
                                count += 1
            if sx and sy:
                mixed = False
                for k in range(np.uint64(nz - 1)):
                    n0 = base + k
                    case = (
                        inside[n0]
                        | inside[n0 + sx] << 1
                        | inside[n0 + sy] << 2
                        | inside[n0 + sx + sy] << 3
                        | inside[n0 + one] << 4
                        | inside[n0 + sx + one] << 5
                        | inside[n0 + sy + one] << 6
                        | inside[n0 + sx + sy + one] << 7
                    )
                    cases[n0] = case
                    mixed |= (case != 0) & (case != 255)
                if mixed:
                    flags |= _CELLS
                    for k in range(np.uint64(nz - 1)):
                        triangles += tri_counts[cases[base + k]]
            row_flags[i * ny + j] = flags
        plane_vertices[i] = count
        slab_triangles[i] = triangles


@parallel_kernel
def _fill_kernel(
    field, crossing, shape, level, spacing, origin, plane_order, tri_counts, tri_edges,
    edge_delta, edge_plane, edge_id, cases, row_flags, vertex_start, triangle_start,
    vertices, faces,
):  # fmt: skip
    """Pass 2: interpolate each plane's vertices and write each slab's triangles.

    Vertices are written in pass 1's numbering order, so they need no look-up. A cell's
    cut edge ``e`` has its vertex id in ``edge_id[node + edge_delta[e]]``, numbered within
    plane ``i + edge_plane[e]``.
    """
    nx, ny, nz = shape[0], shape[1], shape[2]
    plane = ny * nz
    for p in numba.prange(nx):
        i = plane_order[p]
        sx = np.uint64(plane if i < nx - 1 else 0)
        v = vertex_start[i]
        f = triangle_start[i]
        s0 = vertex_start[i]  # vertex ids of planes i and i + 1 start here
        s1 = vertex_start[min(i + 1, nx - 1)] - s0
        x = origin[0] + spacing[0] * i
        for j in range(ny):
            sy = np.uint64(nz if j < ny - 1 else 0)
            base = np.uint64((i * ny + j) * nz)
            flags = row_flags[i * ny + j]
            y = origin[1] + spacing[1] * j
            if flags & _EDGES:
                for k in range(np.uint64(nz)):
                    node = base + k
                    bits = crossing[node]
                    if not bits:
                        continue
                    f0 = np.float64(field[node])
                    z = origin[2] + spacing[2] * np.float64(k)
                    if bits & 1:
                        t = (level - f0) / (np.float64(field[node + sx]) - f0)
                        _store(vertices, v, x + spacing[0] * t, y, z)
                        v += 1
                    if bits & 2:
                        t = (level - f0) / (np.float64(field[node + sy]) - f0)
                        _store(vertices, v, x, y + spacing[1] * t, z)
                        v += 1
                    if bits & 4:
                        t = (level - f0) / (np.float64(field[node + np.uint64(1)]) - f0)
                        _store(vertices, v, x, y, z + spacing[2] * t)
                        v += 1
            if flags & _CELLS:
                for k in range(np.uint64(nz - 1)):
                    node = base + k
                    case = cases[node]
                    corners = 3 * tri_counts[case]
                    for q in range(corners):
                        e = tri_edges[case, q]
                        faces[3 * f + q] = s0 + s1 * edge_plane[e] + edge_id[node + edge_delta[e]]
                    f += tri_counts[case]


def spread_order(n: int) -> np.ndarray:
    """A permutation of ``range(n)`` that scatters any contiguous run over the whole range.

    Numba hands each thread a contiguous range of ``prange`` iterations. Work per plane or
    column varies with where the surface is (empty regions cost little), so iterating in
    this order balances the threads; it changes no result.
    """
    stride = max(1, round(n * 0.6180339887))  # the golden ratio spreads runs evenly
    while np.gcd(stride, n) != 1:
        stride += 1
    return (np.arange(n, dtype=np.int64) * stride) % n


# -- launcher -----------------------------------------------------------------------------
def marching_cubes(field, level, *, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0)):
    """Triangulate the surface ``field == level`` (Lorensen & Cline 1987).

    Parameters
    ----------
    field : (nx, ny, nz) array_like of float
        Samples at ``origin + spacing * (i, j, k)``; converted to float32. Every axis needs
        at least 2 samples. Inside is ``field > level``.
    level : float
        The iso-value, finite.
    spacing : (3,) array_like of float, optional
        Grid step along each axis [m], > 0.
    origin : (3,) array_like of float, optional
        Position of sample ``(0, 0, 0)`` [m].

    Returns
    -------
    vertices : (v, 3) float32
        One vertex [m] per crossed grid edge, shared by the cells around it.
    faces : (f, 3) int32
        Vertex indices, counter-clockwise seen from outside (``field <= level``), so the
        right-hand rule gives outward normals. The surface is closed wherever it does not
        reach the grid boundary.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.linspace(-1.0, 1.0, 21)
    >>> ball = 1.0 - np.sum(np.square(np.meshgrid(x, x, x, indexing="ij")), axis=0)
    >>> vertices, faces = marching_cubes(ball, 0.5, spacing=(0.1, 0.1, 0.1), origin=(-1, -1, -1))
    >>> bool(np.allclose(np.linalg.norm(vertices, axis=1), np.sqrt(0.5), atol=0.01))
    True
    """
    level = _validate.real("level", level)
    spacing = _validate.vector("spacing", spacing)
    if np.any(spacing <= 0):
        raise ValueError(f"spacing must be > 0 along every axis, got {spacing.tolist()}")
    origin = _validate.vector("origin", origin)
    field = np.ascontiguousarray(field, dtype=np.float32)
    if field.ndim != 3 or min(field.shape) < 2:
        raise ValueError(f"field must have shape (nx, ny, nz) with each >= 2, got {field.shape}")
    if not np.isfinite(field).all():
        raise ValueError("field must be finite (no NaN or inf)")
    return _marching_cubes(field, level, spacing, origin)


def _marching_cubes(field, level, spacing, origin):
    """:func:`marching_cubes` on checked input: float32 C-contiguous ``field``."""
    tri_counts, tri_table = case_tables()
    nx, ny, nz = field.shape
    size = field.size
    shape = np.array(field.shape, dtype=np.int64)
    order = spread_order(nx)
    level32 = np.float32(level)
    flat = field.reshape(-1)
    inside = np.empty(size, dtype=np.uint8)
    _inside_kernel(flat, level32, inside)
    # Read only where pass 1 wrote (crossed edges, rows of cells with triangles), so they
    # need no initialisation.
    crossing = np.empty(size, dtype=np.uint8)
    edge_id = np.empty(3 * size, dtype=np.int32)
    cases = np.empty(size, dtype=np.uint8)
    row_flags = np.empty(nx * ny, dtype=np.uint8)
    plane_vertices = np.empty(nx, dtype=np.int64)
    slab_triangles = np.empty(nx, dtype=np.int64)
    _count_kernel(
        inside, shape, order, tri_counts, crossing, edge_id, cases, row_flags, plane_vertices,
        slab_triangles,
    )  # fmt: skip
    vertex_start = np.concatenate(([0], np.cumsum(plane_vertices)))
    triangle_start = np.concatenate(([0], np.cumsum(slab_triangles)))
    vertices = np.empty((vertex_start[-1], 3), dtype=np.float32)
    faces = np.empty((triangle_start[-1], 3), dtype=np.int32)
    # Where cell edge e's vertex id sits relative to the cell's node in edge_id.
    edge_delta = EDGE_AXIS * size + EDGE_OFFSETS @ np.array([ny * nz, nz, 1])
    _fill_kernel(
        flat, crossing, shape, np.float64(level32), np.asarray(spacing, np.float64),
        np.asarray(origin, np.float64), order, tri_counts, tri_table.reshape(256, -1),
        edge_delta.astype(np.uint64), EDGE_OFFSETS[:, 0].copy(), edge_id, cases, row_flags,
        vertex_start, triangle_start, vertices, faces.reshape(-1),
    )  # fmt: skip
    return vertices, faces
