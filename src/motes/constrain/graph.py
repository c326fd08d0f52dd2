"""Graph colouring of constraints, so that each colour can be projected in parallel.

Two constraints that share a particle must not be projected at the same time (both
would read and write that particle). A greedy colouring gives every constraint the
lowest colour not yet taken by a constraint sharing one of its particles, visiting
constraints in the order they were added; constraints of one colour are then
independent, and the relaxation visits colours in order (Gauss–Seidel across colours,
Jacobi-free within one, since no two of its constraints touch the same particle).

The colouring is done once, when a constraint set is built, in a serial kernel (one bit
mask of used colours per particle), so its result depends only on the input order.
"""

from __future__ import annotations

import numpy as np

from .._jit import serial_kernel

#: Colours a particle's bit mask can hold.
MAX_COLORS = 64


@serial_kernel
def _greedy_colors(ends, particle_count, out):
    used = np.zeros(particle_count, dtype=np.uint64)
    for c in range(ends.shape[0]):
        taken = np.uint64(0)
        for e in range(ends.shape[1]):
            p = ends[c, e]
            if p >= 0:
                taken |= used[p]
        color = 0
        while color < 64 and (taken >> np.uint64(color)) & np.uint64(1):
            color += 1
        if color == 64:
            out[c] = -1
            return False
        out[c] = color
        bit = np.uint64(1) << np.uint64(color)
        for e in range(ends.shape[1]):
            p = ends[c, e]
            if p >= 0:
                used[p] |= bit
    return True


def color_constraints(ends: np.ndarray, particle_count: int) -> tuple[np.ndarray, np.ndarray]:
    """Colour constraints so that none of one colour shares a particle.

    Parameters
    ----------
    ends : (m, w) int64 array
        Particles each constraint touches; ``-1`` marks an unused slot.
    particle_count : int
        Number of particles the indices refer to.

    Returns
    -------
    order : (m,) int64 array
        Constraint indices sorted by colour (stable: input order within a colour).
    color_start : (k + 1,) int64 array
        Colour ``c`` holds ``order[color_start[c]:color_start[c + 1]]``.
    """
    colors = np.empty(len(ends), dtype=np.int64)
    if not _greedy_colors(np.ascontiguousarray(ends, dtype=np.int64), particle_count, colors):
        raise ValueError(
            f"a particle is shared by so many constraints that more than {MAX_COLORS} "
            "colours are needed; split the constraint set"
        )
    order = np.argsort(colors, kind="stable")
    counts = np.bincount(colors, minlength=1) if len(colors) else np.zeros(0, dtype=np.int64)
    color_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    return order.astype(np.int64), color_start
