"""Fluid benchmarks: neighbour search + density at 65,536 particles, a full 100k step.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.fluid           # full sizes, about a minute
    PYTHONPATH=src python -m benchmarks.fluid --quick   # shrunk sizes, seconds

- **neighbours + density**: 65,536 points uniform in a unit cube with a radius giving
  about 40 neighbours each; motes builds its grid (:class:`motes.spatial.UniformGrid`,
  counting sort) and sums the poly6 density by cell traversal
  (``fluids.kernels.cell_density``); the baseline is scipy's ``cKDTree``: build,
  ``query_pairs``, and the same density summed over the pairs with ``np.bincount``.
  Both densities are compared (they must agree) and the time of motes' CSR neighbour
  lists (what the solver uses) is reported beside it;
- **step**: one ``Fluid.step`` of 100,000 particles collapsing in a tank (position-based
  fluids, 4 iterations, XSPH, one internal step of 1/240 s), after warm-up steps, with
  all threads and with one (``step_100k_1thread_ms``: steadier on a shared machine).

Timings are the best of several calls after warm-up (the median beside it); the cores
other processes kept busy are reported too: on a shared machine they inflate timings.
"""

from __future__ import annotations

import numba
import numpy as np
from scipy.spatial import cKDTree

from motes.fluids import Fluid, FluidModel, Tank, kernels, lattice, sph
from motes.spatial import UniformGrid

from ._common import benchmark_main, machine, table, time_calls

NEIGHBORS = 40
DT = 1 / 240  # the solver's default longest step [s]


def cloud(n: int, seed: int = 0) -> tuple[np.ndarray, float]:
    """``n`` float32 points uniform in the unit cube (3, n), and the radius giving
    ``NEIGHBORS`` neighbours on average (``n · 4/3 π r³ = NEIGHBORS``)."""
    points = np.random.default_rng(seed).random((3, n), dtype=np.float32)
    return points, (NEIGHBORS / (4 / 3 * np.pi * n)) ** (1 / 3)


def motes_density(points, h, grid, out):
    grid.build(points)
    kernels.cell_density(*grid.sorted_positions, grid.cell_start, grid.origin,
                          1.0 / grid.cell, grid.dims, h, out)  # fmt: skip
    return out


def ckdtree_density(points, h):
    pts = points.T.astype(np.float64)
    tree = cKDTree(pts)
    pairs = tree.query_pairs(h, output_type="ndarray")
    r2 = ((pts[pairs[:, 0]] - pts[pairs[:, 1]]) ** 2).sum(axis=1)
    w = 315 / (64 * np.pi * h**9) * (h * h - r2) ** 3
    n = len(pts)
    return (np.bincount(pairs[:, 0], w, n) + np.bincount(pairs[:, 1], w, n)
            + sph.poly6(0.0, h))  # fmt: skip


def step_fluid(n: int) -> Fluid:
    """About ``n`` particles in a block filling a quarter of a tank's floor."""
    s = 0.01
    side = round((n / 2) ** (1 / 3))
    upper = (side * s, 2 * side * s, side * s)
    model = FluidModel(spacing=s, boundaries=(Tank((0, 0, 0), (4 * side * s, 1, side * s)),),
                       max_dt=DT)  # fmt: skip
    return Fluid(model, lattice((0, 0, 0), upper, s))


def measure(quick: bool) -> dict:
    n = 8192 if quick else 65_536
    n_step = 10_000 if quick else 100_000
    repeat = 3 if quick else 10
    points, h = cloud(n)
    grid = UniformGrid(h)
    out = np.empty(n, np.float32)
    ours = time_calls(lambda: motes_density(points, h, grid, out), repeat=repeat, warmup=2)
    lists = time_calls(lambda: grid.build(points).neighbors(h, slots=True), repeat=repeat)
    theirs = time_calls(lambda: ckdtree_density(points, h), repeat=max(2, repeat // 3))
    reference = ckdtree_density(points, h)[grid.order]
    # float32 sums of ~40 terms against float64: agreement to 1e-5 relative.
    error = float(np.abs(out / reference - 1).max())
    if error > 1e-4:
        raise RuntimeError(f"densities disagree with cKDTree's by {error:.2e}")
    counts = grid.neighbors(h).counts

    water = step_fluid(n_step)
    for _ in range(3):
        water.step(DT)
    step = time_calls(lambda: water.step(DT), repeat=max(3, repeat // 2), warmup=1)
    # One thread too: on a shared machine it moves by a few % where two threads move by
    # tens (a parallel launch waits for the slower core).
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        one = time_calls(lambda: water.step(DT), repeat=max(3, repeat // 2), warmup=1)
    finally:
        numba.set_num_threads(threads)

    figures = {
        "neighbors_65k_ms": ours.best * 1e3,
        "neighbors_65k_median_ms": ours.median * 1e3,
        "neighbor_lists_65k_ms": lists.best * 1e3,
        "ckdtree_65k_ms": theirs.best * 1e3,
        "neighbors_speedup_vs_ckdtree": theirs.best / ours.best,
        "mean_neighbors": float(counts.mean()),
        "step_100k_ms": step.best * 1e3,
        "step_100k_median_ms": step.median * 1e3,
        "step_100k_1thread_ms": one.best * 1e3,
        "step_particles": len(water),
        "step_density_error": water.density_error,
        "sizes": {"neighbors": n, "step": len(water)},
        "quick": quick,
    }
    rows = [
        ("points", f"{n:,} with {counts.mean():.1f} neighbours on average"),
        ("grid + cell density", f"{ours.best * 1e3:8.2f} ms (median {ours.median * 1e3:.2f})"),
        ("grid + CSR lists", f"{lists.best * 1e3:8.2f} ms"),
        ("cKDTree + pairs + density", f"{theirs.best * 1e3:8.2f} ms"),
        ("speed-up", f"{theirs.best / ours.best:8.1f}x"),
        ("fluid step", f"{step.best * 1e3:8.2f} ms for {len(water):,} particles "
                       f"(median {step.median * 1e3:.2f})"),
        ("fluid step, one thread", f"{one.best * 1e3:8.2f} ms"),
    ]  # fmt: skip
    print(table(rows, title="Fluid: neighbours + density, full step"))
    figures.update(machine())
    return figures


def main(argv=None) -> dict:
    return benchmark_main(
        argv, prog="python -m benchmarks.fluid", doc=__doc__,
        quick_help="8,192 points, a 10,000-particle step", run=measure,
    )  # fmt: skip


if __name__ == "__main__":
    main()
