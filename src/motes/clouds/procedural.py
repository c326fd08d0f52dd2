"""Procedural cumulus: a density grid of fractal noise shaped like a layer of clouds.

Schneider & Vos (2015), "The real-time volumetric cloudscapes of Horizon Zero Dawn"
(SIGGRAPH course "Advances in real-time rendering"): a low-frequency noise gives the
clouds' shapes, a height gradient turns them into cumulus (flat bases, rounded tops), a
coverage threshold decides how much of the sky they fill, and a high-frequency billowy
noise erodes their edges. The noises are Perlin's (2002) improved gradient noise, shared
with :mod:`motes.forces.curl_noise`, and Worley's (1996) cellular noise. See
:func:`motes.clouds.kernels.cloud_density` for the equations.
"""

from __future__ import annotations

import numpy as np

from .. import _memory
from .. import _validate as check
from ..forces.curl_noise import MAX_OCTAVES, corner_tables, permutation_tables
from .kernels import STRETCH, cloud_density

__all__ = ["procedural_cloud"]

#: Most detail octaves: each doubles the frequency of a 27-cell Worley search.
MAX_DETAIL_OCTAVES = 6


def procedural_cloud(
    resolution,
    cell_size: float,
    *,
    base_height: float,
    top_height: float,
    scale: float,
    origin=(0.0, 0.0, 0.0),
    coverage: float = 0.5,
    octaves: int = 5,
    seed: int = 0,
    detail_scale: float | None = None,
    detail_octaves: int = 4,
    erosion: float = 0.2,
    density: float = 1.0,
    offset=(0.0, 0.0, 0.0),
    detail_offset=(0.0, 0.0, 0.0),
    out: np.ndarray | None = None,
) -> np.ndarray:
    """A layer of cumulus clouds as a density grid indexed ``[k, j, i]`` (nz, ny, nx).

    Parameters
    ----------
    resolution : (int, int, int)
        Cells ``(nx, ny, nz)`` along x, y (up) and z, each >= 1.
    cell_size : float
        Cell side [m], > 0. Cell ``(i, j, k)`` has its centre at
        ``origin + (i + 0.5, j + 0.5, k + 0.5) * cell_size``, where the noise is read.
    base_height, top_height : float
        Heights [m] (world y) of the cloud layer's bottom and top, base < top: no density
        below the base or above the top.
    scale : float
        Size [m] of the base noise's lattice cell, > 0: the clouds' shapes are about half
        of it across.
    origin : (3,) array_like
        The grid's lowest corner [m].
    coverage : float
        Fraction of the sky to cover, in [0, 1]: 0 is a clear sky, 1 overcast. The
        density at a cell never falls as the coverage rises.
    octaves : int
        Octaves of the base shape's fBm, 1 to 16 (each adds detail at twice the
        frequency and half the amplitude).
    seed : int
        Seed >= 0 of the noises: the same seed gives the same bits.
    detail_scale : float, optional
        Size [m] of the detail noise's lattice cell, > 0 (default ``scale / 9``).
    detail_octaves : int
        Octaves of the billowy detail noise, 1 to 6.
    erosion : float
        How much the detail noise eats into the clouds' edges, in [0, 0.95]: 0 leaves
        the smooth base shape.
    density : float
        Multiplies the density, >= 0 (the densest cells of a coverage-``c`` sky reach
        about ``c * density``).
    offset : (3,) array_like
        Shift [m] of the noises' domain: the clouds seen at ``p`` are those at
        ``p + offset``, so ``offset = -wind * t`` carries them with the wind ``wind``
        [m/s]. The layer's heights do not move.
    detail_offset : (3,) array_like
        Further shift [m] of the detail noise alone: changing it slowly makes the edges
        boil and the clouds change shape as they drift.
    out : (nz, ny, nx) float32 array, optional
        C-contiguous buffer to fill and return.

    Returns
    -------
    (nz, ny, nx) float32 array
        Density >= 0, for :meth:`motes.render.volume.Volume.from_zyx` or a grid fluid.

    Examples
    --------
    >>> sky = procedural_cloud((32, 8, 32), 50.0, base_height=100.0, top_height=350.0,
    ...                        scale=800.0, coverage=0.6, seed=3)
    >>> sky.shape, sky.dtype.name, bool(sky[:, 0].any()), float(sky.min())
    ((32, 8, 32), 'float32', False, 0.0)
    """
    nx, ny, nz = grid_resolution(resolution)
    cell_size = check.positive("cell_size", cell_size)
    base_height = check.real("base_height", base_height)
    top_height = check.real("top_height", top_height)
    if top_height <= base_height:
        raise ValueError(f"top_height must be > base_height ({base_height}), got {top_height}")
    scale = check.positive("scale", scale)
    origin = check.vector("origin", origin)
    coverage = check.unit_interval("coverage", coverage)
    octaves = check.integer("octaves", octaves, low=1)
    if octaves > MAX_OCTAVES:
        raise ValueError(f"octaves must be <= {MAX_OCTAVES}, got {octaves}")
    seed = check.integer("seed", seed, low=0)
    detail_scale = scale / 9.0 if detail_scale is None else detail_scale
    detail_scale = check.positive("detail_scale", detail_scale)
    detail_octaves = check.integer("detail_octaves", detail_octaves, low=1)
    if detail_octaves > MAX_DETAIL_OCTAVES:
        raise ValueError(f"detail_octaves must be <= {MAX_DETAIL_OCTAVES}, got {detail_octaves}")
    erosion = check.real("erosion", erosion, low=0.0, high=0.95)
    density = check.non_negative("density", density)
    offset = check.vector("offset", offset)
    detail_offset = check.vector("detail_offset", detail_offset)
    out = grid_buffer(out, (nx, ny, nz))
    hash_pairs, ramp_pairs = corner_tables(permutation_tables(seed))
    key = np.uint64(np.random.default_rng([seed, 1]).integers(1 << 32))
    centre = origin + 0.5 * cell_size
    cloud_density(
        nx, ny, nz, *centre, cell_size, 1.0 / scale, 1.0 / (STRETCH * scale),
        1.0 / detail_scale, offset, offset + detail_offset, base_height, top_height,
        coverage, erosion, density, octaves, detail_octaves, hash_pairs, ramp_pairs, key, out,
    )  # fmt: skip
    return out


# The grid checks both builders share (motes.clouds.splat imports them).
def grid_resolution(resolution) -> tuple[int, int, int]:
    """``(nx, ny, nz)`` as three ints >= 1, or an error naming ``resolution``."""
    try:
        values = tuple(resolution)
    except TypeError:
        raise TypeError(f"resolution must be (nx, ny, nz), got {resolution!r}") from None
    if len(values) != 3:
        raise ValueError(f"resolution must be (nx, ny, nz), got {resolution!r}")
    return tuple(
        check.integer(f"resolution {axis}", v, low=1) for axis, v in zip("xyz", values, strict=True)
    )


def grid_buffer(out, resolution) -> np.ndarray:
    """``out`` checked as a C-contiguous float32 (nz, ny, nx) array, or a new one."""
    nx, ny, nz = resolution
    shape = (nz, ny, nx)
    if out is None:
        _memory.check(f"resolution = {(nx, ny, nz)}", nx * ny * nz * 4, per="4 B per cell")
        return np.empty(shape, np.float32)
    if (
        not isinstance(out, np.ndarray)
        or out.shape != shape
        or out.dtype != np.float32
        or not out.flags.c_contiguous
        or not out.flags.writeable
    ):
        raise ValueError(f"out must be a writable C-contiguous float32 array of shape {shape}")
    return out
