"""Clouds as volumes: procedural cumulus and particles splatted into a grid."""

from __future__ import annotations

import itertools
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import motes as mo
import naive_clouds as naive
from motes.clouds import kernels, procedural_cloud, splat_particles
from motes.clouds.splat import MIN_KERNEL_CELLS
from motes.forces.curl_noise import corner_tables, permutation_tables
from motes.state import ParticleState

#: A small sky: 24 x 20 x 16 cells of 50 m, the layer from 150 m to 850 m.
SKY = dict(
    resolution=(24, 20, 16), cell_size=50.0, base_height=150.0, top_height=850.0, scale=700.0,
    coverage=0.6, seed=5,
)  # fmt: skip


def sky(**change) -> np.ndarray:
    return procedural_cloud(**(SKY | change))


def cell_heights(resolution=SKY["resolution"], cell=SKY["cell_size"], origin_y=0.0):
    return origin_y + (np.arange(resolution[1]) + 0.5) * cell


# -- procedural ----------------------------------------------------------------------------
def test_the_same_seed_gives_the_same_bits_and_another_seed_other_clouds():
    a = sky()
    assert a.shape == (16, 20, 24) and a.dtype == np.float32
    assert (a > 0).mean() > 0.05  # a sky with clouds, or the test shows nothing
    assert_array_equal(a, sky())
    assert not np.array_equal(a, sky(seed=6))


def test_no_coverage_is_a_clear_sky_and_more_coverage_never_takes_density_away():
    """Every step after the coverage threshold is non-decreasing in its input, and
    rounding is monotone, so the density rises (or stays) cell by cell, bit for bit."""
    grids = [sky(coverage=c) for c in (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)]
    assert not grids[0].any()
    for low, high in itertools.pairwise(grids):
        assert (high >= low).all()
    totals = [g.sum(dtype=np.float64) for g in grids[2:]]
    assert all(b > a for a, b in itertools.pairwise(totals))


def test_there_is_no_density_below_the_base_or_above_the_top():
    grid = sky(coverage=1.0, origin=(0.0, -100.0, 0.0))
    y = cell_heights(origin_y=-100.0)
    outside = (y <= SKY["base_height"]) | (y >= SKY["top_height"])
    assert outside.any() and (~outside).any()
    assert not grid[:, outside, :].any()
    assert grid[:, ~outside, :].any()


@pytest.mark.parametrize(("axis", "cells"), [(2, 3), (0, 2), (2, -4)])
def test_an_offset_of_whole_cells_shifts_the_grid(axis, cells):
    """The noise is read at cell centres plus the offset, so an offset of ``m`` cells along
    x (axis 2 of the grid) or z (axis 0) reads what the cell ``m`` further along read.
    The two compute the same coordinate by different sums (``x0 + i h + m h`` against
    ``x0 + (i + m) h``), which may round differently in the last bit; through the noise
    that is below 1e-6 of the density (the densities here are about 0.1-0.5)."""
    h = SKY["cell_size"]
    offset = [0.0, 0.0, 0.0]
    offset[2 - axis] = cells * h  # grid axis 2 is world x, grid axis 0 world z
    moved = sky(offset=offset, origin=(-300.0, 0.0, 125.0))
    still = sky(origin=(-300.0, 0.0, 125.0))
    n = still.shape[axis]
    m = abs(cells)
    ahead = [slice(None)] * 3
    behind = [slice(None)] * 3
    ahead[axis] = slice(m, n) if cells > 0 else slice(0, n - m)
    behind[axis] = slice(0, n - m) if cells > 0 else slice(m, n)
    assert moved.any()
    assert_allclose(moved[tuple(behind)], still[tuple(ahead)], rtol=0, atol=1e-6)
    assert not np.array_equal(moved, still)


def test_the_detail_offset_moves_only_the_erosion():
    still = sky()
    boiled = sky(detail_offset=(0.0, 120.0, 0.0))
    assert not np.array_equal(still, boiled)
    # where the base shape is empty, no detail brings clouds back (erosion only removes)
    smooth = sky(erosion=0.0)
    assert not boiled[smooth == 0].any()
    assert_array_equal(sky(erosion=0.0, detail_offset=(5.0, 7.0, 9.0)), smooth)


def test_the_cloud_density_follows_its_equations():
    """The kernel against its equations written out in NumPy (naive_clouds.cumulus), on
    the same noise functions: the profile, the coverage threshold, the erosion, the
    offsets and the cell centres. The kernel's cell centres and lattice coordinates are
    computed by other sums and products than the twin's, so they may differ in the last
    bit; the densities (below 1) agree to 1e-6."""
    options = dict(origin=(10.0, -40.0, 5.0), coverage=0.7, erosion=0.3, density=1.7,
                   offset=(33.0, 11.0, -8.0), detail_offset=(3.0, 40.0, 0.0), octaves=3,
                   detail_octaves=2, detail_scale=90.0)  # fmt: skip
    resolution = (10, 18, 6)
    got = sky(resolution=resolution, **options)
    hash_pairs, ramp_pairs = corner_tables(permutation_tables(SKY["seed"]))
    key = np.uint64(np.random.default_rng([SKY["seed"], 1]).integers(1 << 32))
    expected = naive.cumulus(
        resolution, SKY["cell_size"], base=SKY["base_height"], top=SKY["top_height"],
        scale=SKY["scale"], hash_pairs=hash_pairs, ramp_pairs=ramp_pairs, key=key, **options,
    )  # fmt: skip
    assert (expected > 0).mean() > 0.1
    assert_allclose(got, expected, rtol=0, atol=1e-6)


def test_the_worley_search_over_27_cells_finds_the_nearest_feature_point():
    """One feature point per unit cell, searched in the 27 cells around: a point two cells
    away can in principle be nearer (it is more than 1 away, the own cell's may be up to
    √3), but that is rare: over 2 million random points the search missed once, by 0.011
    of a cell. These 200 points all agree with a search of the 125 cells around."""
    rng = np.random.default_rng(4)
    for x, y, z in rng.uniform(-40.0, 40.0, (200, 3)):
        assert kernels._worley(x, y, z, np.uint64(77)) == pytest.approx(
            naive.worley(x, y, z, 77), abs=1e-12
        )


# -- splatting -------------------------------------------------------------------------------
GRID = dict(resolution=(20, 16, 12), cell_size=0.1, origin=(-1.0, 0.0, -0.5))


def particle_mass(radius, density=1.0):
    return density * 4.0 / 3.0 * np.pi * np.asarray(radius, dtype=np.float64) ** 3


def test_particles_inside_the_grid_keep_their_mass():
    """The kernel is normalised on the lattice itself, so the grid holds exactly the
    particles' mass but for float32 rounding: each cell adds a few float32 terms
    (relative error ~1e-7 each), far below the tolerance of 1e-5."""
    rng = np.random.default_rng(1)
    n = 300
    radius = rng.uniform(0.02, 0.3, n)  # from a fifth of a cell to three cells
    lo = np.array(GRID["origin"]) + 0.35  # the largest kernel, whole inside
    hi = np.array(GRID["origin"]) + np.array(GRID["resolution"]) * 0.1 - 0.35
    positions = rng.uniform(lo, hi, (n, 3)).T
    density = rng.uniform(0.5, 2.0, n)
    grid = splat_particles(positions, radius, density=density, **GRID)
    mass = grid.sum(dtype=np.float64) * GRID["cell_size"] ** 3
    assert mass == pytest.approx(particle_mass(radius, density).sum(), rel=1e-5)
    assert grid.shape == (12, 16, 20) and grid.dtype == np.float32 and grid.min() >= 0


def test_a_particle_on_a_face_of_the_grid_leaves_half_its_mass_and_one_outside_none():
    """A particle centred on a face has its cells mirrored about the face, with the same
    weights: exactly half of its kernel's sum is inside."""
    r = 0.25
    on_face = np.array([[-1.0], [0.8], [0.1]])  # x on the grid's lowest face
    grid = splat_particles(on_face, r, **GRID)
    assert grid.sum(dtype=np.float64) * 1e-3 == pytest.approx(0.5 * particle_mass(r), rel=1e-5)
    outside = np.array([[-1.0 - r - 0.01, 0.5, 0.1], [0.5, 1.6 + r + 0.01, 0.1]]).T
    assert not splat_particles(outside, r, **GRID).any()


def test_the_splat_matches_its_numpy_twin():
    """Particles inside, across the faces and outside, larger and smaller than the kernel's
    floor, against the twin that evaluates every kernel on a padded grid. The kernel
    adds float32 terms; the twin float64: agreement to 1e-5 of the largest density."""
    rng = np.random.default_rng(2)
    n = 60
    lo = np.array(GRID["origin"]) - 0.3
    hi = np.array(GRID["origin"]) + np.array(GRID["resolution"]) * 0.1 + 0.3
    positions = rng.uniform(lo, hi, (n, 3)).T
    radius = rng.uniform(0.0, 0.4, n)
    radius[:5] = 0.0
    density = rng.uniform(0.0, 3.0, n)
    got = splat_particles(positions, radius, density=density, **GRID)
    expected = naive.splat(positions, radius, density, GRID["resolution"], 0.1, GRID["origin"])
    assert expected.max() > 1.0
    assert_allclose(got, expected, rtol=0, atol=1e-5 * expected.max())


def test_a_small_particle_is_spread_over_the_kernel_floor_and_keeps_its_mass():
    tiny = 0.01  # a tenth of a cell
    grid = splat_particles(np.array([[0.03], [0.81], [0.12]]), tiny, **GRID)
    assert (grid > 0).sum() >= 8  # never a single cell
    assert grid.sum(dtype=np.float64) * 1e-3 == pytest.approx(particle_mass(tiny), rel=1e-5)
    assert MIN_KERNEL_CELLS * GRID["cell_size"] > tiny


def test_a_particle_state_or_anything_with_particle_state_is_splatted_with_its_radius():
    rng = np.random.default_rng(3)
    n = 50
    positions = rng.uniform([-0.8, 0.2, -0.3], [0.8, 1.4, 0.5], (n, 3)).T
    radius = rng.uniform(0.05, 0.2, n)
    state = ParticleState(np.arange(n), positions, np.zeros((3, n)), radius)

    class Puffs:
        def particle_state(self):
            return state

    expected = splat_particles(positions, radius, **GRID)
    assert_array_equal(splat_particles(state, **GRID), expected)
    assert_array_equal(splat_particles(Puffs(), **GRID), expected)
    assert_array_equal(splat_particles(state, 0.1, **GRID), splat_particles(positions, 0.1, **GRID))


def test_the_out_buffer_is_overwritten_and_returned():
    out = np.full((12, 16, 20), 7.0, np.float32)
    positions = np.array([[0.0], [0.8], [0.1]])
    assert splat_particles(positions, 0.2, out=out, **GRID) is out
    assert_array_equal(out, splat_particles(positions, 0.2, **GRID))
    no_particles = splat_particles(np.zeros((3, 0)), np.zeros(0), out=out, **GRID)
    assert not no_particles.any()
    sky_out = np.empty((16, 20, 24), np.float32)
    assert sky(out=sky_out) is sky_out
    assert_array_equal(sky_out, sky())


# -- threads -------------------------------------------------------------------------------
def _both(path: str) -> None:
    """Both builders' grids, big enough that the splat runs on every thread."""
    rng = np.random.default_rng(8)
    n = 20_000
    positions = rng.uniform([-1.2, -0.2, -0.7], [1.2, 1.8, 0.9], (n, 3)).T
    radius = rng.uniform(0.02, 0.2, n)
    splat = splat_particles(positions, radius, **GRID)
    np.savez(path, splat=splat, sky=sky(resolution=(48, 20, 32)))


def test_one_and_two_threads_give_the_same_bits(tmp_path):
    """Rows (procedural) and planes (splat) are each computed by one thread in a fixed
    order: the grids do not depend on the thread count (fresh processes, as Numba reads
    NUMBA_NUM_THREADS at start-up)."""
    source = str(Path(mo.__file__).resolve().parents[1])
    here = Path(__file__).resolve().parent
    script = "import sys; from test_clouds import _both; _both(sys.argv[1])"
    grids = []
    for threads in (1, 2):
        path = tmp_path / f"clouds{threads}.npz"
        env = dict(os.environ, NUMBA_NUM_THREADS=str(threads),
                   PYTHONPATH=os.pathsep.join([source, str(here)]))  # fmt: skip
        result = subprocess.run([sys.executable, "-c", script, str(path)], env=env,
                                capture_output=True, text=True, check=False)  # fmt: skip
        assert result.returncode == 0, result.stderr[-3000:]
        grids.append(np.load(path))
    for name in ("splat", "sky"):
        assert grids[0][name].any()
        assert_array_equal(grids[0][name], grids[1][name], err_msg=name)


# -- bad input -------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("change", "error", "message"),
    [
        ({"resolution": (4, 4)}, ValueError, "resolution must be"),
        ({"resolution": (4, 0, 4)}, ValueError, "resolution y must be >= 1"),
        ({"resolution": (4, 2.5, 4)}, TypeError, "resolution y must be an integer"),
        ({"cell_size": 0.0}, ValueError, "cell_size must be > 0"),
        ({"top_height": 100.0}, ValueError, "top_height must be > base_height"),
        ({"scale": -1.0}, ValueError, "scale must be > 0"),
        ({"coverage": 1.5}, ValueError, "coverage must be <= 1"),
        ({"octaves": 0}, ValueError, "octaves must be >= 1"),
        ({"octaves": 17}, ValueError, "octaves must be <= 16"),
        ({"seed": -1}, ValueError, "seed must be >= 0"),
        ({"detail_scale": 0.0}, ValueError, "detail_scale must be > 0"),
        ({"detail_octaves": 7}, ValueError, "detail_octaves must be <= 6"),
        ({"erosion": 1.0}, ValueError, "erosion must be <= 0.95"),
        ({"density": -1.0}, ValueError, "density must be >= 0"),
        ({"offset": (1.0, math.nan, 0.0)}, ValueError, "offset must be finite"),
        ({"detail_offset": (1.0, 2.0)}, ValueError, "detail_offset must have shape"),
        ({"origin": "here"}, TypeError, "origin must be a sequence"),
        ({"out": np.zeros((4, 4, 4))}, ValueError, "out must be a writable C-contiguous"),
    ],
)
def test_bad_procedural_parameters_are_refused_by_name(change, error, message):
    with pytest.raises(error, match=message):
        sky(**change)


@pytest.mark.parametrize(
    ("change", "error", "message"),
    [
        ({"positions": np.zeros((2, 3))}, ValueError, "positions must have shape"),
        ({"positions": np.full((3, 2), np.inf)}, ValueError, "positions must be finite"),
        ({"positions": object()}, TypeError, "expected a ParticleState"),
        ({"radius": None}, TypeError, "radius is needed"),
        ({"radius": [0.1, -0.1]}, ValueError, "radius must be >= 0"),
        ({"radius": [0.1, 0.1, 0.1]}, ValueError, "radius must be a number or have shape"),
        ({"density": np.nan}, ValueError, "density must be finite"),
        ({"density": "thick"}, TypeError, "density must be a number"),
        ({"cell_size": -0.1}, ValueError, "cell_size must be > 0"),
        ({"resolution": (2, 2, 2, 2)}, ValueError, "resolution must be"),
        ({"origin": (0.0, 0.0)}, ValueError, "origin must have shape"),
        ({"out": np.zeros((12, 16, 20), np.float64)}, ValueError, "out must be"),
    ],
)
def test_bad_splat_parameters_are_refused_by_name(change, error, message):
    arguments = {"positions": np.zeros((3, 2)), "radius": 0.1} | GRID | change
    with pytest.raises(error, match=message):
        splat_particles(arguments.pop("positions"), arguments.pop("radius"), **arguments)
