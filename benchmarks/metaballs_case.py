"""Metaball surface benchmark case: a splash of liquid particles meshed on a ~grid³ grid.

:func:`run` is called by the render benchmark. It times :meth:`Metaballs.mesh` (field,
marching cubes, analytic normals) on a reproducible cloud and, in the same run, a
baseline doing the same work with standard tools: Blinn's field gathered with
``scipy.spatial.cKDTree.sparse_distance_matrix`` and NumPy, then the surface and its
normals from ``skimage.measure.marching_cubes``. The NumPy field takes seconds, so it is
timed on every ``baseline_stride``-th plane of nodes only and scaled up by the number of
(node, particle) pairs it has to visit; the returned dictionary says which fraction.
"""

from __future__ import annotations

import math
import time

import numpy as np

from motes.render.metaballs import Metaballs

from ._common import OtherLoad, time_calls

#: Particle radius over the particle spacing in the pool: neighbours overlap, so the pool
#: reads as one body of liquid and the droplets as beads.
RADIUS_OVER_SPACING = 0.9


def splash_cloud(n: int, *, seed: int = 7) -> tuple[np.ndarray, float]:
    """``n`` particles [m] of a liquid splash in the unit box, and their spacing [m].

    Three quarters sit in a pool filling the lower third of the box on a jittered cubic
    lattice (as the particles of a settled liquid simulation do); the rest are droplets:
    Gaussian clumps of 20-80 particles thrown up above it.
    """
    rng = np.random.default_rng(seed)
    depth = 0.3
    spacing = (depth / ((3 * n) // 4)) ** (1.0 / 3.0)
    counts = np.maximum(np.round(np.array([1.0, 1.0, depth]) / spacing), 1).astype(int)
    lattice = np.stack(np.meshgrid(*[np.arange(c) for c in counts], indexing="ij"), axis=-1)
    pool = (lattice.reshape(-1, 3)[:n] + 0.5) * spacing
    pool += rng.uniform(-0.25 * spacing, 0.25 * spacing, pool.shape)
    clumps = []
    left = n - len(pool)
    while left > 0:
        size = min(left, int(rng.integers(20, 81)))
        centre = rng.uniform((0.1, 0.1, depth + 0.05), (0.9, 0.9, 0.95))
        clumps.append(centre + rng.normal(0.0, 0.4 * spacing * size ** (1 / 3), (size, 3)))
        left -= size
    return np.concatenate([pool, *clumps]), spacing


def splash_case(n: int, grid: int) -> tuple[np.ndarray, Metaballs]:
    """The splash and metaballs whose automatic grid has about ``grid``³ nodes."""
    points, spacing = splash_cloud(n)
    radius = RADIUS_OVER_SPACING * spacing
    reach_over_radius = Metaballs.from_radius(1.0, cell_size=1.0).cutoff_radius
    extent = np.ptp(points, axis=0) + 2 * reach_over_radius * radius
    # mesh() spans the particles, r_c and one padding cell each side, +1 node, +1 node
    # lost to snapping: solve prod(extent / h + 4) = grid³ for the cell size h.
    h = float(extent.max()) / grid
    for _ in range(60):
        h *= (float(np.prod(extent / h + 4)) / grid**3) ** (1.0 / 3.0)
    return points, Metaballs.from_radius(radius, cell_size=h)


def mesh_grid(metaballs: Metaballs, points: np.ndarray) -> tuple[np.ndarray, tuple]:
    """Origin [m] and shape of the grid :meth:`Metaballs.mesh` builds for ``points``."""
    h = metaballs.cell_size
    margin = metaballs.cutoff_radius + metaballs.padding * h
    origin = np.floor((points.min(axis=0) - margin) / h) * h
    shape = tuple(int(s) for s in np.floor((points.max(axis=0) + margin - origin) / h) + 1)
    return origin, shape


def numpy_field(
    metaballs: Metaballs, points: np.ndarray, origin, shape, planes=None
) -> tuple[np.ndarray, int]:
    """Blinn's field on node planes ``planes`` (default all) with cKDTree and NumPy.

    Returns the field on those planes, (len(planes), ny, nz), and the number of (node,
    particle) pairs within the cut-off radius it visited.
    """
    from scipy.spatial import cKDTree

    h = metaballs.cell_size
    planes = np.arange(shape[0]) if planes is None else np.asarray(planes)
    axes = [origin[0] + h * planes] + [origin[c] + h * np.arange(shape[c]) for c in (1, 2)]
    nodes = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    pairs = cKDTree(nodes).sparse_distance_matrix(
        cKDTree(points), metaballs.cutoff_radius, output_type="coo_matrix"
    )
    values = metaballs.b * np.exp(-metaballs.a * pairs.data**2)
    field = np.bincount(pairs.row, weights=values, minlength=len(nodes))
    return field.reshape(len(planes), shape[1], shape[2]).astype(np.float32), pairs.nnz


def run(n: int = 50_000, grid: int = 128, repeats: int = 3, baseline_stride: int = 8) -> dict:
    """Time ``Metaballs.mesh`` on ``n`` particles and a ~``grid``³ grid against a baseline.

    Returns the best and median of ``repeats`` timed calls after one warm-up call [ms];
    the baseline's time [ms], its NumPy field timed on every ``baseline_stride``-th node
    plane and scaled by pair count; their ratio; the mesh's size; and the cores other
    processes kept busy meanwhile (they slow the parallel kernels on a small machine).
    """
    from skimage.measure import marching_cubes as skimage_marching_cubes

    points, metaballs = splash_case(n, grid)
    load = OtherLoad()
    mesh = metaballs.mesh(points)  # the warm-up call: loads the compiled kernels
    timing = time_calls(lambda: metaballs.mesh(points), repeat=repeats, warmup=0)
    busy = load.cores()

    origin, shape = mesh_grid(metaballs, points)
    planes = np.arange(0, shape[0], baseline_stride)
    start = time.perf_counter()
    _, sampled_pairs = numpy_field(metaballs, points, origin, shape, planes)
    sampled_s = time.perf_counter() - start
    # Every particle lies at least r_c + one cell inside the grid, so it has, on average
    # over its offset from the lattice, exactly (4/3) π (r_c / h)³ nodes within reach.
    all_pairs = n * 4.0 / 3.0 * math.pi * (metaballs.cutoff_radius / metaballs.cell_size) ** 3
    field_s = sampled_s * all_pairs / max(sampled_pairs, 1)

    field = metaballs.field(points, origin, shape)
    h = metaballs.cell_size
    start = time.perf_counter()
    skimage_marching_cubes(field, metaballs.threshold, spacing=(h, h, h))
    surface_s = time.perf_counter() - start

    best_ms = 1e3 * timing.best
    baseline_ms = 1e3 * (field_s + surface_s)
    size = f"{n // 1000}k" if n >= 1000 else str(n)
    return {
        f"metaballs_{size}_ms": best_ms,
        f"metaballs_{size}_median_ms": 1e3 * timing.median,
        "metaballs_baseline_ms": baseline_ms,
        "metaballs_baseline_field_ms": 1e3 * field_s,
        "metaballs_baseline_surface_ms": 1e3 * surface_s,
        "metaballs_baseline_field_fraction": len(planes) / shape[0],
        "metaballs_speedup": baseline_ms / best_ms,
        "metaballs_grid_nodes": math.prod(shape),
        "metaballs_background_busy_cores": busy,
        "faces": len(mesh.faces),
        "vertices": len(mesh.vertices),
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=1))
