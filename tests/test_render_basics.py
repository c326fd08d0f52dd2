"""Camera projection and tile binning."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import motes as mo
from motes.render.tiles import TILE, bin_boxes


def test_perspective_projection_matches_pinhole_formula():
    cam = mo.Camera((0, 0, 5), (0, 0, 0), fov=90, resolution=(200, 100))
    xy, depth = cam.project([[0, 0, 0], [1, 0.5, 0], [0, 0, 10]])
    # fov 90°: focal length = half the image height = 50 px per unit at unit depth.
    assert_allclose(depth, [5, 5, -5])
    assert_allclose(xy[0], [100, 50])
    assert_allclose(xy[1], [100 + 50 * 1 / 5, 50 - 50 * 0.5 / 5])
    assert np.isnan(xy[2]).all()  # behind the eye
    assert_allclose(cam.pixels_per_metre(5.0), 10.0)


def test_orthographic_projection_ignores_depth():
    cam = mo.Camera((0, 0, 5), (0, 0, 0), projection="orthographic", height=4, resolution=(80, 40))
    xy, depth = cam.project([[1, 1, 0], [1, 1, -20]])
    assert_allclose(xy, [[50, 10], [50, 10]])  # 10 px per metre
    assert_allclose(depth, [5, 25])


def test_basis_is_right_handed_with_y_up():
    cam = mo.Camera((3, 2, 1), (0, 0, 0))
    right, up, forward = cam.basis
    assert_allclose(np.cross(right, up), -forward, atol=1e-12)  # x × y = −z in view space
    assert up[1] > 0
    assert_allclose(cam.to_view([[0, 0, 0]])[0], [0, 0, math.sqrt(14)], atol=1e-12)


def test_screen_fraction_of_a_centred_sphere():
    cam = mo.Camera((0, 0, 3), (0, 0, 0), fov=60, resolution=(400, 400))
    r = 0.5 * 200 / math.tan(math.pi / 6) / 3  # projected radius [px]
    assert cam.screen_fraction((0, 0, 0), 0.5) == pytest.approx(math.pi * r * r / 400**2)
    assert cam.screen_fraction((0, 0, 2.9), 0.5) == 1.0  # contains the eye
    assert cam.screen_fraction((0, 0, 9), 0.5) == 0.0  # behind


def test_camera_rejects_bad_parameters():
    with pytest.raises(ValueError, match="up must not be parallel"):
        mo.Camera((0, 5, 0), (0, 0, 0))
    with pytest.raises(ValueError, match="far must be > near"):
        mo.Camera(near=2, far=1)
    with pytest.raises(ValueError, match="projection must be one of"):
        mo.Camera(projection="fisheye")
    with pytest.raises(ValueError, match="resolution width must be >= 1"):
        mo.Camera(resolution=(0, 10))


def test_tile_bins_list_every_overlapping_tile_in_input_order():
    rng = np.random.default_rng(3)
    width, height, n = 150, 70, 40_000
    x0 = rng.integers(-5, width, n)
    y0 = rng.integers(-5, height, n)
    x1 = x0 + rng.integers(-2, 40, n)
    y1 = y0 + rng.integers(-2, 40, n)
    x0, y0 = np.maximum(x0, 0), np.maximum(y0, 0)
    x1, y1 = np.minimum(x1, width - 1), np.minimum(y1, height - 1)
    boxes = [a.astype(np.int32) for a in (x0, y0, x1, y1)]
    bins = bin_boxes(*boxes, width, height)
    for t in range(bins.tiles_x * bins.tiles_y):
        tx, ty = t % bins.tiles_x, t // bins.tiles_x
        expected = np.flatnonzero(
            (x0 <= tx * TILE + TILE - 1)
            & (x1 >= tx * TILE)
            & (y0 <= ty * TILE + TILE - 1)
            & (y1 >= ty * TILE)
            & (x1 >= x0)
            & (y1 >= y0)
        )
        assert_array_equal(bins.items[bins.starts[t] : bins.starts[t + 1]], expected)


def test_tile_nearest_is_the_least_depth_over_each_tile_and_its_neighbours():
    from motes.render.splat_kernels import tile_nearest

    rng = np.random.default_rng(5)
    width, height = 150, 70  # partial tiles on the right and at the bottom
    depth = rng.uniform(1.0, 50.0, (height, width)).astype(np.float32)
    depth[rng.random((height, width)) < 0.7] = np.inf  # no geometry there
    depth[:, : 2 * TILE] = np.inf  # whole tiles without geometry
    tiles_y, tiles_x = -(-height // TILE), -(-width // TILE)
    got = np.empty((tiles_y, tiles_x), np.float32)
    tile_nearest(depth, got)
    padded = np.full((tiles_y * TILE, tiles_x * TILE), np.inf, np.float32)
    padded[:height, :width] = depth
    own = padded.reshape(tiles_y, TILE, tiles_x, TILE).min(axis=(1, 3))
    around = np.pad(own, 1, constant_values=np.inf)
    expected = np.min(
        [around[dy : dy + tiles_y, dx : dx + tiles_x] for dy in range(3) for dx in range(3)],
        axis=0,
    )
    assert_array_equal(got, expected)
    assert np.isinf(got[:, 0]).all() and np.isfinite(got[:, 1:]).all()
