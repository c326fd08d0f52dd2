"""The render benchmark: its JSON contract, and that its additive baseline draws the same image.

No timing asserts: only that the figures exist and are positive and finite, and that the
NumPy baseline the additive figure is a ratio against does the same work as motes.
"""

import numpy as np
from benchmarks import render
from numpy.testing import assert_allclose

from benchmark_contract import quick_figures
from motes.render.frame import Frame
from motes.render.sprites import SpriteRasterizer

REQUIRED = (
    "additive_1m_ms",
    "additive_1m_speedup_vs_numpy",
    "additive_1m_1thread_ms",
    "alpha_100k_ms",
    "alpha_100k_speedup_vs_numpy",
    "bloom_720p_ms",
    "bloom_speedup_vs_scipy",
    "occlusion_720p_ms",
    "fire_shadow_cost_ratio",
    "water_frame_ms",
    "surface_frame_ms",
    "water_over_surface",
)


def test_quick_run_ends_with_one_json_line_of_positive_finite_figures(capsys):
    figures = quick_figures(render, capsys, REQUIRED)
    assert figures["quick"] is True
    assert figures["additive_1m_drawn"] > 0.9 * figures["sizes"]["additive"]


def test_numpy_additive_baseline_draws_what_motes_draws():
    cam = render.camera()
    positions, colors, radii = render.sprite_cloud(20_000, 3.0, seed=5)
    ours, theirs = Frame(render.WIDTH, render.HEIGHT), Frame(render.WIDTH, render.HEIGHT)
    ours.depth[300:400] = theirs.depth[300:400] = 10.0  # some sprites hidden
    SpriteRasterizer().draw(ours, cam, positions, colors, radii)
    render.numpy_additive(theirs, cam, positions, colors, radii)
    assert ours.color.max() > 0.5
    # The same float32 footprints summed in another order: pixels of O(1) that sum a few
    # fragments agree to float32 round-off.
    assert_allclose(theirs.color, ours.color, rtol=0, atol=2e-5)


def test_sprite_cloud_has_the_stated_sizes():
    positions, _, radii = render.sprite_cloud(1_000, 3.0)
    r = render.numpy_project(render.camera(), positions, radii)[3]
    assert np.all((2 * r > 0.83 * 3.0 - 1e-3) & (2 * r < 1.25 * 3.0 + 1e-3))
    assert positions.shape == (1_000, 3) and not positions.flags.c_contiguous  # store-like
