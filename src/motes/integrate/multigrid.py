r"""Aggregation multigrid: the implicit solve's preconditioner.

Block Jacobi leaves conjugate gradients an iteration count that grows with the cloth's
resolution (the condition number of ``A = M - h² ∂f/∂x`` grows as the particle masses
shrink: a 64×64 cloth took 51 iterations per step, a 128×128 one 108). One symmetric
cycle of aggregation multigrid per iteration keeps the count about flat.

- **Levels** (built once per sparsity pattern, in NumPy): particles joined by a strong
  spring (:func:`strong_springs`) or a Jacobian block are neighbours; greedy
  aggregation (Vaněk, Mandel & Brezina 1996) groups each node with its neighbours, and
  the aggregates are the next level's nodes, until a level has at most
  :data:`COARSEST` nodes or stops shrinking (unconnected nodes: strands of hair once
  each is one node).
- **Coarse matrices** (every step, compiled): Galerkin products ``Pᵀ A P`` with ``P``
  the piecewise constant interpolation (unsmoothed aggregation: an aggregate moves as
  one). A spring between two aggregates becomes a block between them, one inside an
  aggregate cancels out (springs resist relative motion only).
- **The cycle**: block Gauss-Seidel forward on the way down, backward on the way up (so
  the preconditioner is symmetric, as conjugate gradients need), a W-cycle below level
  0, symmetric sweeps on the coarsest level. (Sweeps that leave out weak springs'
  off-diagonal blocks ran a 64×64 cloth's cycle in 0.32 ms instead of 0.42 at the same
  iteration count, but tripled the iterations of hair, whose bending springs are as
  weak: not done.)

Measured with ``benchmarks.cloth`` (60 steps from rest at h = 1/60 s, tolerance 1e-2):
2.9 conjugate gradient iterations per step for a 64×64 cloth and 3.4 for a 128×128 one,
against 50.6 and 108 with block Jacobi; 2,000 hair strands 5.8 against 58 (figures in
docs/performance.md).
"""

from __future__ import annotations

import numpy as np

from .._unique import sorted_unique
from .multigrid_kernels import aggregate_kernel

#: A level with at most this many nodes is the coarsest (solved by Gauss-Seidel sweeps).
COARSEST = 16

#: Strength of connection threshold (see :func:`strong_springs`).
STRENGTH = 0.1

#: A level that keeps more than this fraction of its nodes ends the coarsening.
STALL = 0.75


class Hierarchy:
    """The aggregates and coarse sparsity of a system's graph.

    Parameters
    ----------
    n : int
        Particles.
    pairs : int64 (m, 2)
        Springs' ends.
    rows, cols : int64 (k,)
        Block-CSR off-diagonal entries of other forces (row of each entry, its column).
    strong : bool (m,), optional
        Springs whose ends may join one aggregate on the first level (default: all);
        every block still enters the coarse matrices.

    Attributes
    ----------
    agg : int64 (n,)
        Aggregate (level-1 node) of each particle.
    entry_ptr, row_mid : int64 (n + 1,), (n,)
        Level 0's spring entries by particle: ``entry_ptr[i]:entry_ptr[i + 1]``, those to
        lower-numbered particles up to ``row_mid[i]``.
    row_other, entry_spring : int32 (2 m,)
        Each entry's other particle and spring.
    spring_slot : int64 (m, 2)
        Coarse entry of each spring's blocks ``(a, b)`` and ``(b, a)``; -1 inside an
        aggregate.
    off_slot : int64 (k,)
        Coarse entry of each block-CSR entry; -1 inside an aggregate.
    level_start : int64 (levels + 1,)
        Coarse levels' node ranges in one global numbering (level 1 first).
    crow_ptr, ccols : int64
        Coarse levels' block-CSR off-diagonal pattern (global numbers).
    cagg, cslot : int64
        Next-level node of each coarse node, next-level entry of each coarse entry (-1:
        inside an aggregate, or the coarsest level).
    """

    def __init__(self, n: int, pairs: np.ndarray, rows: np.ndarray, cols: np.ndarray, strong=None):
        src = np.concatenate([pairs[:, 0], pairs[:, 1], rows]).astype(np.int64)
        dst = np.concatenate([pairs[:, 1], pairs[:, 0], cols]).astype(np.int64)
        edges = src.shape[0]
        links = np.ones(edges, dtype=bool)
        if strong is not None:
            links[: 2 * pairs.shape[0]] = np.tile(strong, 2)
        aggs, patterns, slot_maps = [], [], []
        size = n
        while size > COARSEST:
            agg, count = _aggregate(size, src[links], dst[links])
            links = None if links is None else slice(None)
            if count > STALL * size:
                break
            a, b = agg[src], agg[dst]
            between = a != b
            keys = sorted_unique(a[between] * count + b[between])
            slots = np.full(src.shape[0], -1, dtype=np.int64)
            slots[between] = np.searchsorted(keys, a[between] * count + b[between])
            aggs.append(agg)
            slot_maps.append(slots)
            patterns.append((count, keys // count, keys % count))
            src, dst = keys // count, keys % count
            size = count
        self.levels = len(aggs)
        sizes = [p[0] for p in patterns]
        self.level_start = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        nnz = [p[1].shape[0] for p in patterns]
        entry_start = np.concatenate([[0], np.cumsum(nnz)]).astype(np.int64)
        self.nodes = int(self.level_start[-1])
        # Coarse block-CSR rows (global node numbers, entries ordered by row then column).
        ptr = [np.zeros(1, dtype=np.int64)]
        ccols = []
        for level, (count, crow, ccol) in enumerate(patterns):
            counts = np.bincount(crow, minlength=count)
            ptr.append(entry_start[level] + np.cumsum(counts))
            ccols.append(ccol + self.level_start[level])
        self.crow_ptr = np.concatenate(ptr).astype(np.int64)
        self.ccols = _concat(ccols)
        # Fine level: aggregates and slots (global entry numbers).
        m = pairs.shape[0]
        if self.levels:
            self.agg = aggs[0].astype(np.int64)
            fine_slots = np.where(slot_maps[0] >= 0, slot_maps[0] + entry_start[0], -1)
        else:
            self.agg = np.zeros(n, dtype=np.int64)
            fine_slots = np.full(edges, -1, dtype=np.int64)
        both = np.stack([fine_slots[:m], fine_slots[m : 2 * m]], 1)
        self.spring_slot = np.ascontiguousarray(both)
        self.off_slot = np.ascontiguousarray(fine_slots[2 * m :])
        # Level 0's spring entries row by row, ordered by the other end: row i's entries
        # to particles j < i come first (entry_ptr[i]:row_mid[i]).
        row = np.concatenate([pairs[:, 0], pairs[:, 1]]).astype(np.int64)
        other = np.concatenate([pairs[:, 1], pairs[:, 0]]).astype(np.int64)
        order = np.lexsort((other, row))
        row, other = row[order], other[order]
        self.entry_ptr = np.concatenate([[0], np.cumsum(np.bincount(row, minlength=n))]).astype(
            np.int64
        )
        self.row_mid = self.entry_ptr[:-1] + np.bincount(row[other < row], minlength=n)
        self.row_other = other.astype(np.int32)
        self.entry_spring = (order % max(m, 1)).astype(np.int32)
        # Coarse levels: next-level node and entry of each node and entry.
        cagg, cslot = [], []
        for level in range(self.levels):
            if level + 1 < self.levels:
                cagg.append(aggs[level + 1] + self.level_start[level + 1])
                s = slot_maps[level + 1]
                cslot.append(np.where(s >= 0, s + entry_start[level + 1], -1))
            else:
                cagg.append(np.full(sizes[level], -1, dtype=np.int64))
                cslot.append(np.full(nnz[level], -1, dtype=np.int64))
        self.cagg = _concat(cagg)
        self.cslot = _concat(cslot)

    def sizes(self) -> list[int]:
        """Nodes per coarse level, finest first."""
        return np.diff(self.level_start).tolist()


def strong_springs(n: int, pairs: np.ndarray, coef: np.ndarray) -> np.ndarray:
    """Bool (m,): springs that bind their ends strongly enough to aggregate them.

    A spring's strength is the largest eigenvalue ``α + β`` of its block ``C_k``; it is
    strong when at least :data:`STRENGTH` times the strongest spring at either end
    (Ruge & Stüben's strength of connection, made symmetric). A cloth's weak bending
    springs then do not pull particles two apart into one aggregate: smaller aggregates,
    fewer iterations (64×64: 4.1 against 5.4 per step).
    """
    weight = coef[:, 0] + coef[:, 1]
    peak = np.zeros(n)
    np.maximum.at(peak, pairs[:, 0], weight)
    np.maximum.at(peak, pairs[:, 1], weight)
    return weight >= STRENGTH * np.minimum(peak[pairs[:, 0]], peak[pairs[:, 1]])


def _aggregate(n: int, src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, int]:
    """Aggregates of the graph of edges ``src -> dst`` (both directions listed)."""
    keep = src != dst
    keys = sorted_unique(src[keep] * n + dst[keep])
    indptr = np.concatenate([[0], np.cumsum(np.bincount(keys // n, minlength=n))])
    agg = np.empty(n, dtype=np.int64)
    count = aggregate_kernel(indptr.astype(np.int64), (keys % n).astype(np.int64), agg)
    return agg, int(count)


def _concat(parts) -> np.ndarray:
    return np.concatenate(parts).astype(np.int64) if parts else np.empty(0, dtype=np.int64)


__all__ = ["COARSEST", "STRENGTH", "Hierarchy", "strong_springs"]
