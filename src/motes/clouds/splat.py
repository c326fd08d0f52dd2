"""Particle clouds splatted into a density grid, to be rendered as a volume.

Reeves (1983), "Particle systems — a technique for modeling a class of fuzzy objects",
ACM TOG 2(2): clouds, smoke and fire as many small particles. Rendering each particle as
a sprite gives no self-shadowing; splatting them into a density grid and ray-marching it
(:class:`motes.render.volume.Volume`) gives the lit medium. Each particle adds a smooth
kernel of radius ``R`` holding a mass ``density · 4/3 π R³`` (density times the
particle's volume), so the splatted grid's integral is the particles' total mass.
"""

from __future__ import annotations

import numpy as np

from .. import _memory
from .. import _validate as check
from .._jit import threads_for
from ..state import as_state
from .kernels import SIGMAS, bin_by_plane, splat_planes, splat_spans, splat_weights
from .procedural import grid_buffer, grid_resolution

__all__ = ["MIN_KERNEL_CELLS", "SIGMAS", "splat_particles"]

#: Smallest kernel radius [cells]: a particle smaller than this is spread over a kernel of
#: this radius (its mass kept), so that it cannot fall between cell centres and vanish,
#: nor flicker as it moves across cells. At 1.5 cells (σ = ½ cell) the sampled Gaussian's
#: shape hardly depends on where in a cell the particle lies.
MIN_KERNEL_CELLS = 1.5


def splat_particles(
    positions,
    radius=None,
    *,
    density=1.0,
    resolution,
    cell_size: float,
    origin=(0.0, 0.0, 0.0),
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Splat particles into a density grid indexed ``[k, j, i]`` (nz, ny, nx).

    Each particle adds the separable kernel ``a w(Δx) w(Δy) w(Δz)`` at the cell centres
    ``origin + (i + 0.5, j + 0.5, k + 0.5) * cell_size``, with ``w`` a Gaussian of
    standard deviation ``R / SIGMAS`` truncated at ``R`` (lowered to reach 0 there, so the
    puff has no edge; its level sets are spheres to within 1.3 % down to a tenth of the
    peak, 8 % at a hundredth, where the box it is truncated to shows).
    ``a`` makes the kernel's sum over the unbounded lattice times the cell volume equal
    the particle's mass ``density · 4/3 π R³`` [m³ of unit density], so a particle wholly
    inside the grid adds exactly its mass (to float32 rounding), one partly outside only
    what falls on the grid's cells, one wholly outside nothing.

    Parameters
    ----------
    positions : (3, n) array_like, ParticleState, or an object with ``particle_state()``
        Particle centres [m]; a state gives its positions and radius.
    radius : float or (n,) array_like, optional
        Particle radius ``R`` [m], >= 0 (default: the state's). A kernel is never smaller
        than :data:`MIN_KERNEL_CELLS` cells, the mass stays that of ``R``.
    density : float or (n,) array_like
        Each particle's density (>= 0, unitless, as the grid's).
    resolution : (int, int, int)
        Cells ``(nx, ny, nz)``, each >= 1.
    cell_size : float
        Cell side [m], > 0.
    origin : (3,) array_like
        The grid's lowest corner [m].
    out : (nz, ny, nx) float32 array, optional
        C-contiguous buffer to overwrite and return.

    Returns
    -------
    (nz, ny, nx) float32 array
        Density, for :meth:`motes.render.volume.Volume.from_zyx`.

    Examples
    --------
    >>> import numpy as np
    >>> grid = splat_particles(np.array([[0.5], [0.5], [0.5]]), 0.2, density=2.0,
    ...                        resolution=(16, 16, 16), cell_size=1 / 16)
    >>> mass = grid.sum(dtype=np.float64) / 16**3
    >>> bool(np.isclose(mass, 2.0 * 4 / 3 * np.pi * 0.2**3, rtol=1e-5))
    True
    """
    positions, radius = _particles(positions, radius)
    n = positions.shape[1]
    density = _per_particle("density", density, n)
    nx, ny, nz = grid_resolution(resolution)
    cell_size = check.positive("cell_size", cell_size)
    origin = check.vector("origin", origin)
    out = grid_buffer(out, (nx, ny, nz))
    out.fill(0.0)
    if n == 0:
        return out
    x, y, z = (np.ascontiguousarray(positions[a] - origin[a]) for a in range(3))
    mass = density * (4.0 / 3.0 * np.pi) * radius**3
    kernel_radius = np.maximum(radius, MIN_KERNEL_CELLS * cell_size)
    first = np.empty((3, n), np.int64)
    count = np.empty((3, n), np.int64)
    with threads_for(n):
        splat_spans(x, y, z, kernel_radius, cell_size, first, count)
    # the axis factors of every particle at every cell its kernel covers, grid or not (the
    # amplitude needs the sums over the unbounded lattice): a few per particle and axis
    offsets = np.zeros((3, n + 1), np.int64)
    np.cumsum(count, axis=1, out=offsets[:, 1:])
    offsets[1:] += offsets[:-1, -1:].cumsum(axis=0)
    total = int(offsets[2, -1])
    planes = np.clip(first[2] + count[2], 0, nz) - np.clip(first[2], 0, nz)
    entries = int(np.maximum(planes, 0).sum())
    _memory.check(
        f"{n} particles", (total * 4 + entries * 8),
        per="4 B per particle and cell its kernel spans along each axis, 8 B per plane",
    )  # fmt: skip
    weights = np.empty(total, np.float32)
    amplitude = np.empty(n)
    with threads_for(n):
        splat_weights(x, y, z, kernel_radius, mass, cell_size, first, offsets, weights, amplitude)
    starts = np.empty(nz + 1, np.int64)
    order = np.empty(entries, np.int64)
    bin_by_plane(first, count, amplitude, nz, starts, order)
    with threads_for(entries):
        splat_planes(first, count, offsets, weights, amplitude, starts, order, out)
    return out


def _particles(positions, radius) -> tuple[np.ndarray, np.ndarray]:
    """Positions (3, n) and radius (n,), float64, from arrays or a particle state."""
    if not isinstance(positions, (np.ndarray, list, tuple)):
        state = as_state(positions)
        positions = state.positions
        radius = state.radius if radius is None else radius
    try:
        positions = np.asarray(positions, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError("positions must be a (3, n) array of numbers") from None
    if positions.ndim != 2 or positions.shape[0] != 3:
        raise ValueError(f"positions must have shape (3, n), got {positions.shape}")
    if not np.isfinite(positions).all():
        raise ValueError("positions must be finite (no NaN or inf)")
    if radius is None:
        raise TypeError("radius is needed with positions given as an array")
    return positions, _per_particle("radius", radius, positions.shape[1])


def _per_particle(name: str, value, n: int) -> np.ndarray:
    """A finite, non-negative float64 (n,) array from a scalar or ``n`` values."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number or {n} numbers, got {value!r}") from None
    if array.ndim == 0:
        array = np.full(n, float(array))
    if array.shape != (n,):
        raise ValueError(f"{name} must be a number or have shape ({n},), got {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    if (array < 0).any():
        raise ValueError(f"{name} must be >= 0, got a minimum of {array.min()}")
    return np.ascontiguousarray(array)
