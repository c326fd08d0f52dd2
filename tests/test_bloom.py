"""Bloom: light moved, not added; its spread as stated; only light above the threshold."""

from __future__ import annotations

import numba
import numpy as np
import pytest

import motes as mo
from motes.render.bloom import LEVELS, Bloom
from motes.scene import SceneError, load_scene


def point_glow(height: int, width: int, radius: float) -> tuple[np.ndarray, tuple[int, int]]:
    image = np.zeros((height, width, 3), np.float32)
    centre = (height // 2 + 1, width // 2)
    image[centre] = 1000.0
    Bloom(strength=1.0, radius=radius, threshold=0.0).apply(image)
    return image[..., 0].astype(np.float64), centre


@pytest.mark.parametrize(("height", "width"), [(720, 1280), (101, 77)])
def test_bloom_moves_light_and_adds_none(rng, height, width):
    image = rng.uniform(0.0, 0.5, (height, width, 3)).astype(np.float32)
    image[rng.integers(0, height, 40), rng.integers(0, width, 40)] = 40.0  # sparks
    before = image.sum(axis=(0, 1), dtype=np.float64)
    Bloom(strength=0.6, radius=0.05).apply(image)
    after = image.sum(axis=(0, 1), dtype=np.float64)
    assert np.allclose(after, before, rtol=0.01)  # moved, within 1 %
    assert image.min() >= 0.0


def test_a_frame_without_light_above_the_threshold_is_left_as_it_was(rng):
    image = rng.uniform(0.0, 0.99, (90, 160, 3)).astype(np.float32)
    kept = image.copy()
    Bloom(threshold=1.0).apply(image)
    assert np.array_equal(image, kept)
    # the threshold is on exposed light: at exposure 2, 0.6 is above 1
    Bloom(threshold=1.0).apply(image, exposure=2.0)
    assert not np.array_equal(image, kept)


@pytest.mark.parametrize("radius", [0.02, 0.06])
def test_a_point_spreads_as_the_mean_of_its_gaussians(radius):
    height, width = 360, 640
    glow, (cy, cx) = point_glow(height, width, radius)
    ys, xs = np.mgrid[:height, :width]
    total = glow.sum()
    assert total == pytest.approx(1000.0, rel=1e-3)
    # centred (a pyramid level's blocks may move a single pixel's light by half a block)
    sigma = radius * height
    assert abs((glow * xs).sum() / total - cx) < 0.1 * sigma
    assert abs((glow * ys).sum() / total - cy) < 0.1 * sigma
    # variance per axis: the mean of the Gaussians' (sigma, sigma / 2, ...) within 10 %
    expected = np.mean([(sigma / 2**k) ** 2 for k in range(LEVELS)])
    variance = (glow * (xs - cx) ** 2).sum() / total
    assert variance == pytest.approx(expected, rel=0.10)
    # falling off: a quarter of the way out is brighter than half way
    assert glow[cy, cx + int(sigma / 2)] > glow[cy, cx + int(sigma)] > glow[cy, cx + int(2 * sigma)]


def test_the_thread_count_does_not_change_the_bits(rng):
    image = rng.uniform(0.0, 3.0, (181, 243, 3)).astype(np.float32)
    results = []
    for threads in (1, min(2, numba.config.NUMBA_NUM_THREADS)):
        numba.set_num_threads(threads)
        copy = image.copy()
        Bloom().apply(copy)
        results.append(copy)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert np.array_equal(results[0], results[1])


def test_bad_values_are_named():
    with pytest.raises(ValueError, match=r"bloom\.strength"):
        Bloom(strength=1.5)
    with pytest.raises(ValueError, match=r"bloom\.radius"):
        Bloom(radius=0.0)
    with pytest.raises(ValueError, match=r"color must be .*\(height, width, 3\) float32"):
        Bloom().apply(np.zeros((9, 16, 4), np.float32))  # RGBA
    with pytest.raises(ValueError, match="color must be"):
        Bloom().apply(np.zeros((9, 16, 3)))  # float64
    with pytest.raises(TypeError, match="bloom must be a Bloom"):
        mo.Renderer(mo.Camera((0, 0, 3), (0, 0, 0), resolution=(32, 18)), bloom=0.3)


SCENE = """
[scene]
duration = 0.1
[camera]
position = [0, 0.5, 3]
target = [0, 0.5, 0]
resolution = [160, 90]
[render]
bloom = {bloom}
[[system]]
name = "spark"
capacity = 10
  [[system.emitter]]
  shape = {{ type = "point" }}
  position = [0, 0.5, 0]
  rate = {{ type = "burst", count = 1 }}
  speed = 0.0
  lifetime = 10.0
  size = 0.02
  color = [40.0, 30.0, 20.0, 1.0]
  [system.render]
  blend = "additive"
"""


def test_a_scene_blooms_around_a_bright_spark(tmp_path):
    images = {}
    for name, bloom in (("off", "false"), ("on", "{ strength = 0.5, radius = 0.05 }")):
        path = tmp_path / f"{name}.toml"
        path.write_text(SCENE.format(bloom=bloom))
        scene = load_scene(path)
        scene.advance()
        images[name] = scene.renderer().render_scene_hdr(scene).color
    off, on = images["off"], images["on"]
    lit_off, lit_on = (off.max(axis=2) > 0.05).sum(), (on.max(axis=2) > 0.05).sum()
    assert lit_on > 3 * lit_off  # the glow reaches well past the spark
    assert on.sum() == pytest.approx(off.sum(), rel=0.01)


def test_scene_values_are_checked(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(SCENE.format(bloom="{ strength = 2.0 }"))
    with pytest.raises(SceneError, match=r"render\.bloom\.strength"):
        load_scene(path)
    path.write_text(SCENE.format(bloom="0.5"))
    with pytest.raises(SceneError, match=r"render\.bloom.*true, false or a table"):
        load_scene(path)
