"""N-body benchmarks: direct summation's pair rate, Barnes–Hut on a 1M-point Plummer sphere.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.nbody           # full sizes, a few minutes
    PYTHONPATH=src python -m benchmarks.nbody --quick   # shrunk sizes, seconds

- **direct**: one float32 evaluation of softened gravity by direct summation over a
  32,768-point Plummer sphere (``method="direct"``); the figure is pair interactions per
  second, ``n² / t``, in billions (``direct_gpairs_per_s``);
- **Barnes–Hut**: one float32 evaluation on a 1,000,000-point Plummer sphere at
  θ = 0.7, monopoles, no softening (``barnes_hut_1m_s``). Its error is measured against
  float64 direct summation at 1,000 random particles: the RMS and maximum of
  ``|a - a_direct| / |a_direct|`` (``barnes_hut_rms_error``, ``barnes_hut_max_error``);
- **pytreegrav** (the baseline, a Numba Barnes–Hut from PyPI, ``pip install
  motes[bench]``): the same sphere and particles with ``parallel=True``, starting at
  θ = 0.7 and lowering θ until its RMS error is no larger than motes'; the speed-up is
  the ratio of the two times (``barnes_hut_speedup_vs_pytreegrav``). Without pytreegrav
  installed the comparison is skipped and the figure is absent;
- **k nearest neighbours**: the 16 nearest of every point of the same 1M-point Plummer
  sphere (clustered), float64 distances: motes' octree and k-d tree (build + queries)
  against scipy's cKDTree (build + ``query(workers=-1)``); the results must be
  identical, and the faster tree gives ``knn_clustered_speedup_vs_ckdtree``.

Timings are the best of a few calls after a warm-up call (which compiles or loads the
kernels); the cores other processes kept busy are reported too.
"""

from __future__ import annotations

import numba
import numpy as np

from motes._jit import parallel_kernel
from motes.emit.nbody import plummer_sphere
from motes.forces.nbody import inverse_square
from motes.spatial import KDTree, Octree

from ._common import benchmark_main, machine, table, time_calls

THETA = 0.7
SAMPLE = 1000


@parallel_kernel
def reference_field(x, y, z, w, targets, eps2, out):
    """float64 direct field ``Σ_j w_j (x_j - x_i) / (r² + ε²)^{3/2}`` at ``targets``."""
    for k in numba.prange(targets.shape[0]):
        i = targets[k]
        ax = ay = az = 0.0
        for j in range(x.shape[0]):
            dx = x[j] - x[i]
            dy = y[j] - y[i]
            dz = z[j] - z[i]
            r2 = dx * dx + dy * dy + dz * dz + eps2
            if r2 > 0.0:
                s = w[j] / (r2 * np.sqrt(r2))
                ax += s * dx
                ay += s * dy
                az += s * dz
        out[0, k] = ax
        out[1, k] = ay
        out[2, k] = az


def errors(field: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """RMS and maximum of ``|a - a_ref| / |a_ref|`` over the columns."""
    e = np.sqrt(((field - reference) ** 2).sum(axis=0) / (reference**2).sum(axis=0))
    return float(np.sqrt((e**2).mean())), float(e.max())


def sphere(n: int, seed: int = 0):
    """A Plummer sphere (G = M = a = 1): float64 positions (3, n) and masses (n,)."""
    position, _, mass = plummer_sphere(n, seed=seed)
    return position, mass


def reference_at(position, mass, targets, softening=0.0):
    out = np.empty((3, targets.shape[0]))
    reference_field(*position, mass, targets, softening**2, out)
    return out


def barnes_hut(position32, mass, theta, *, quadrupole=False, softening=0.0):
    out = np.zeros(position32.shape, np.float32)
    inverse_square(
        position32, mass, out, softening=softening, method="barnes_hut", theta=theta,
        quadrupole=quadrupole,
    )  # fmt: skip
    return out


def pytreegrav_comparison(position, mass, targets, reference, target_rms, repeat):
    """Time pytreegrav at the largest θ in 0.7, 0.6, ... whose RMS error <= target_rms."""
    try:
        import pytreegrav
    except ImportError:
        return None
    pos = np.ascontiguousarray(position.T)
    h = np.zeros(len(mass))
    for theta in (0.7, 0.6, 0.5, 0.4, 0.3, 0.2):

        def run(theta=theta):
            return pytreegrav.Accel(pos, mass, h, theta=theta, G=1.0, parallel=True)

        accel = run()
        rms, worst = errors(accel.T[:, targets], reference)
        if rms <= target_rms:
            timing = time_calls(run, repeat=repeat, warmup=0)
            return {"theta": theta, "seconds": timing.best, "rms": rms, "max": worst}
    return None


def knn_comparison(position, repeat):
    """Time 16 nearest neighbours of every point: the octree, the k-d tree, cKDTree."""
    from scipy.spatial import cKDTree

    def tree(kind):
        return lambda: kind(leaf_size=16).build(position).knn(position, 16)

    def theirs():
        return cKDTree(position.T).query(position.T, 16, workers=-1)

    reference = theirs()
    times = {}
    for name, kind in (("octree", Octree), ("kdtree", KDTree)):
        mine = tree(kind)()
        if not (np.array_equal(mine[0], reference[0]) and np.array_equal(mine[1], reference[1])):
            raise RuntimeError(f"the {name}'s nearest neighbours differ from cKDTree's")
        times[name] = time_calls(tree(kind), repeat=repeat)
    return times, time_calls(theirs, repeat=repeat), True


def measure(quick: bool) -> dict:
    n_direct = 4096 if quick else 32_768
    n_tree = 50_000 if quick else 1_000_000
    repeat = 2 if quick else 3

    position, mass = sphere(n_direct)
    p32 = position.astype(np.float32)
    out = np.zeros_like(p32)
    direct = time_calls(
        lambda: inverse_square(p32, mass, out, softening=0.01, method="direct"),
        repeat=repeat + 2,
    )
    gpairs = n_direct * n_direct / direct.best / 1e9

    position, mass = sphere(n_tree, seed=1)
    p32 = position.astype(np.float32)
    targets = np.sort(np.random.default_rng(2).choice(n_tree, SAMPLE, replace=False))
    reference = reference_at(position, mass, targets)
    tree = time_calls(lambda: barnes_hut(p32, mass, THETA), repeat=repeat)
    rms, worst = errors(barnes_hut(p32, mass, THETA)[:, targets].astype(np.float64), reference)
    baseline = pytreegrav_comparison(position, mass, targets, reference, rms, max(1, repeat - 1))

    trees, ckdtree, same = knn_comparison(position, repeat)
    fastest = min(trees, key=lambda name: trees[name].best)
    knn = trees[fastest]

    figures = {
        "knn_1m_s": knn.best,
        "knn_1m_octree_s": trees["octree"].best,
        "knn_1m_kdtree_s": trees["kdtree"].best,
        "knn_structure": fastest,
        "ckdtree_knn_1m_s": ckdtree.best,
        "knn_clustered_speedup_vs_ckdtree": ckdtree.best / knn.best,
        "direct_gpairs_per_s": gpairs,
        "direct_seconds": direct.best,
        "barnes_hut_1m_s": tree.best,
        "barnes_hut_1m_median_s": tree.median,
        "barnes_hut_rms_error": rms,
        "barnes_hut_max_error": worst,
        "sizes": {"direct": n_direct, "barnes_hut": n_tree, "error_sample": SAMPLE},
        "theta": THETA,
        "quick": quick,
    }
    rows = [
        ("direct summation", f"{n_direct:,} points: {direct.best * 1e3:8.1f} ms, "
                             f"{gpairs:.2f} billion pairs/s"),
        ("Barnes–Hut θ = 0.7", f"{n_tree:,} points: {tree.best:8.3f} s "
                               f"(median {tree.median:.3f})"),
        ("  error vs direct", f"RMS {rms:.2e}, max {worst:.2e} ({SAMPLE} particles)"),
        ("k = 16 nearest, octree", f"{trees['octree'].best:8.3f} s (build + queries, "
                                   f"identical: {same})"),
        ("k = 16 nearest, k-d tree", f"{trees['kdtree'].best:8.3f} s (identical: {same})"),
        ("k = 16 nearest, cKDTree", f"{ckdtree.best:8.3f} s (all workers)"),
        ("  speed-up", f"{ckdtree.best / knn.best:8.2f}x ({fastest})"),
    ]  # fmt: skip
    if baseline is None:
        rows.append(("pytreegrav", "not installed (pip install motes[bench]) or no θ matched"))
    else:
        speedup = baseline["seconds"] / tree.best
        figures.update(
            barnes_hut_speedup_vs_pytreegrav=speedup,
            pytreegrav_seconds=baseline["seconds"],
            pytreegrav_theta=baseline["theta"],
            pytreegrav_rms_error=baseline["rms"],
            pytreegrav_max_error=baseline["max"],
        )
        rows += [
            ("pytreegrav", f"θ = {baseline['theta']}: {baseline['seconds']:8.3f} s, "
                           f"RMS {baseline['rms']:.2e}, max {baseline['max']:.2e}"),
            ("speed-up", f"{speedup:8.2f}x"),
        ]  # fmt: skip
    print(table(rows, title="N-body: direct summation, Barnes–Hut"))
    figures.update(machine())
    return figures


def main(argv=None) -> dict:
    return benchmark_main(
        argv, prog="python -m benchmarks.nbody", doc=__doc__,
        quick_help="4,096 points direct, 50,000 for Barnes–Hut", run=measure,
    )  # fmt: skip


if __name__ == "__main__":
    main()
