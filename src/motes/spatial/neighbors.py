"""The results every spatial structure gives: neighbour lists in CSR form, pairs, and
the error a fixed-capacity query raises."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kernels import count_upper, upper_pairs


class NeighborOverflow(RuntimeError):
    """A point has more neighbours than the fixed capacity holds (see ``grow``)."""

    def __init__(self, most: int, capacity: int):
        super().__init__(
            f"a point has {most} neighbours but capacity is {capacity}: pass a larger "
            "capacity or grow=True"
        )
        self.most = most
        self.capacity = capacity


@dataclass(frozen=True)
class Neighbors:
    """Neighbour lists in compressed sparse row (CSR) form.

    The neighbours of row ``i`` are ``indices[offsets[i]:offsets[i + 1]]``.

    Attributes
    ----------
    offsets : ndarray, int64, shape (rows + 1,)
        Start of each row's neighbours in ``indices``.
    indices : ndarray, int32, shape (offsets[-1],)
        Neighbour indices (point indices, or sorted slots when asked for slots).
    """

    offsets: np.ndarray
    indices: np.ndarray

    @property
    def ranges(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(begin, end, indices)``: row ``i`` is ``indices[begin[i]:end[i]]``, the form
        the fluid kernels take (views, no copy)."""
        return self.offsets[:-1], self.offsets[1:], self.indices

    @property
    def counts(self) -> np.ndarray:
        """Neighbours per row, int64, shape (rows,)."""
        return np.diff(self.offsets)

    def row(self, i: int) -> np.ndarray:
        """Neighbours of row ``i``."""
        return self.indices[self.offsets[i] : self.offsets[i + 1]]

    def pairs(self) -> np.ndarray:
        """Each unordered pair once as ``(i, j)`` with ``i < j``, shape (pairs, 2), int64.

        Only meaningful for a self query (rows and entries index the same points). Rows
        in order, and within a row the neighbours in the order the grid visits them.
        """
        rows = np.repeat(np.arange(self.offsets.shape[0] - 1), self.counts)
        keep = self.indices > rows
        return np.stack([rows[keep], self.indices[keep].astype(np.int64)], axis=1)


def sorted_pairs(lists: Neighbors) -> np.ndarray:
    """The unordered pairs of a self query, ``(i, j)`` with ``i < j``, sorted by ``i``
    then ``j``; shape (pairs, 2), int64. Sorted, so every structure gives the same array
    (rows are already in order: each row's entries are sorted on their own, in parallel)."""
    rows = lists.offsets.shape[0] - 1
    counts = np.empty(rows, np.int64)
    count_upper(lists.offsets, lists.indices, counts)
    first = np.zeros(rows + 1, np.int64)
    np.cumsum(counts, out=first[1:])
    out = np.empty((int(first[-1]), 2), np.int64)
    upper_pairs(lists.offsets, lists.indices, first, out)
    return out


def points_rows(name: str, value) -> np.ndarray:
    """``value`` as finite (3, n) rows (its dtype kept when floating, else float64)."""
    arr = np.asarray(value)
    if arr.ndim != 2 or arr.shape[0] != 3:
        raise ValueError(f"{name} must have shape (3, n), got shape {arr.shape}")
    if arr.dtype.kind != "f":
        arr = arr.astype(np.float64)
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr
