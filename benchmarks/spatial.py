"""Spatial structures side by side: which one wins for which points and which question.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.spatial           # 100k and 1M points, minutes
    PYTHONPATH=src python -m benchmarks.spatial --quick   # 20k points, seconds

For evenly spread points (uniform in a cube) and strongly clustered ones (a Plummer
sphere: its centre is about 12 times denser than at its half-mass radius, its halo
thousands of times sparser), float32, motes' uniform grid, octree and k-d tree each
answer, build included:

- **radius**: every point's neighbours within ``r``, CSR lists (``r`` is the median
  distance to the 32nd nearest neighbour, so a typical point has 32; the grid's cell is
  ``r``);
- **knn**: the 16 nearest of every point;
- **pairs**: every pair within ``r``, sorted.

The grid is not timed on the 1M-point Plummer sphere: its cell count is bounded (4 per
point), so the halo stretches the cells until a few in the core hold most points, and a
call takes minutes.

The baseline is scipy's cKDTree with all workers (``query_ball_point``, ``query``,
``query_pairs``). Each answer is checked against it (neighbour counts and pairs equal,
k nearest distances equal) before it is timed. Figures: ``{dist}_{n}_{question}_{name}_s``
(best of a few calls) and ``..._speedup_vs_ckdtree``.
"""

from __future__ import annotations

import sys

import numpy as np
from scipy.spatial import cKDTree

from motes.emit.nbody import plummer_sphere
from motes.spatial import STRUCTURES, spatial_index

from ._common import benchmark_main, machine, table, time_calls

K = 16
TYPICAL = 32


def cloud(kind: str, n: int) -> np.ndarray:
    if kind == "uniform":
        return np.random.default_rng(1).random((3, n), dtype=np.float32)
    return plummer_sphere(n, seed=2)[0].astype(np.float32)


def typical_radius(reference: cKDTree, points64: np.ndarray) -> float:
    sample = points64[:: max(1, len(points64) // 2000)]
    return float(np.median(reference.query(sample, TYPICAL + 1, workers=-1)[0][:, -1]))


def ours(structure: str, points, r: float):
    def index():
        if structure == "grid":
            return spatial_index("grid", cell_size=r).build(points)
        return spatial_index(structure).build(points)

    return {
        "radius": lambda: index().neighbors(r),
        "knn": lambda: index().knn(points, K, exclude_self=True),
        "pairs": lambda: index().pairs(r),
    }


def theirs(points64: np.ndarray, r: float):
    return {
        "radius": lambda: cKDTree(points64).query_ball_point(points64, r, workers=-1),
        "knn": lambda: cKDTree(points64).query(points64, K + 1, workers=-1),
        "pairs": lambda: cKDTree(points64).query_pairs(r, output_type="ndarray"),
    }


def check(question: str, mine, reference) -> None:
    """Raise unless ``mine`` answers ``question`` as cKDTree did."""
    if question == "radius":
        same = np.array_equal(mine.counts, [len(b) - 1 for b in reference])
    elif question == "knn":
        same = np.array_equal(mine[0], reference[0][:, 1:])
    else:
        pairs = reference[np.lexsort((reference[:, 1], reference[:, 0]))]
        same = np.array_equal(mine, pairs)
    if not same:
        raise RuntimeError(f"{question}: the answer differs from cKDTree's")


def measure(quick: bool) -> dict:
    sizes = (20_000,) if quick else (100_000, 1_000_000)
    repeat = 2 if quick else 3
    figures: dict = {"quick": quick, "k": K, "typical_neighbours": TYPICAL}
    rows = []
    for kind in ("uniform", "plummer"):
        for n in sizes:
            points = cloud(kind, n)
            points64 = points.T.astype(np.float64)
            r = typical_radius(cKDTree(points64), points64)
            baseline = theirs(points64, r)
            label = f"{kind}_{n // 1000}k"
            for question, call in baseline.items():
                print(f"{label} {question} ...", file=sys.stderr, flush=True)
                reference = call()
                # cKDTree's radius lists are Python lists: tens of seconds at 1M points.
                base = time_calls(call, repeat=1 if n > 100_000 else repeat, warmup=0).best
                figures[f"{label}_{question}_ckdtree_s"] = base
                cells = [f"cKDTree {base * 1e3:8.1f} ms"]
                for structure in STRUCTURES:
                    if structure == "grid" and kind == "plummer" and n > 100_000:
                        # The halo stretches the bounded grid's cells until the core's
                        # few cells hold most points: minutes per call (see the 100k row).
                        cells.append("grid   not run")
                        continue
                    mine_call = ours(structure, points, r)[question]
                    check(question, mine_call(), reference)
                    t = time_calls(mine_call, repeat=repeat).best
                    figures[f"{label}_{question}_{structure}_s"] = t
                    figures[f"{label}_{question}_{structure}_speedup_vs_ckdtree"] = base / t
                    cells.append(f"{structure} {t * 1e3:8.1f} ms ({base / t:4.1f}x)")
                rows.append((f"{kind} {n:>9,} {question:<6}", "  ".join(cells)))
    title = f"Spatial structures (build + query; r: {TYPICAL} typical neighbours, k = {K})"
    print(table(rows, title=title))
    figures.update(machine())
    return figures


def main(argv=None) -> dict:
    return benchmark_main(
        argv, prog="python -m benchmarks.spatial", doc=__doc__,
        quick_help="20,000 points", run=measure,
    )  # fmt: skip


if __name__ == "__main__":
    main()
