"""Tone mapping, sRGB encoding and backgrounds."""

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from motes.color import linear_to_srgb, parse_color, srgb_to_linear
from motes.render.background import Background
from motes.render.frame import Frame
from motes.render.tonemap import ToneMap, _output_table, to_srgb8

CURVES = {
    "clamp": lambda x: x,
    "reinhard": lambda x: x / (1 + x),
    "aces": lambda x: (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14),
}


@pytest.mark.parametrize("exposure", [1.5, 1e-3, 1e3])
@pytest.mark.parametrize("curve", sorted(CURVES))
def test_tonemap_is_the_exact_curve_rounded(curve, exposure):
    rng = np.random.default_rng(0)
    color = (rng.uniform(0, 4, (40, 50, 3)) * 10.0 ** rng.uniform(-4, 4, (40, 50, 3))).astype(
        np.float32
    )
    color[0, :, 0] = np.linspace(0, 0.02, 50) / exposure  # the linear toe of sRGB
    # Each output step's least float, and the float just below it.
    steps = _output_table(ToneMap(curve), exposure)[1][1:256].view(np.float32)
    color[1:7, :, 1] = np.pad(steps, (0, 300 - 255)).reshape(6, 50)
    color[1:7, :, 2] = np.nextafter(color[1:7, :, 1], np.float32(0))
    out = to_srgb8(color, tonemap=curve, exposure=exposure)
    y = CURVES[curve](exposure * color.astype(np.float64))
    exact = np.round(255 * linear_to_srgb(np.minimum(y, 1))).astype(int)
    assert_array_equal(out, exact)


def test_tonemap_of_values_out_of_range():
    color = np.array([[[-1.0, -0.0, 0.0], [np.inf, 3e38, 1e-45]]], np.float32)
    assert_array_equal(to_srgb8(color, tonemap="aces"), [[[0, 0, 0], [255, 255, 0]]])


def test_hex_colours_round_trip_through_linear_light():
    rgba = parse_color("#ff7a1a80")
    assert_allclose(rgba[3], 128 / 255)
    assert_allclose(srgb_to_linear(linear_to_srgb(rgba[:3])), rgba[:3], atol=1e-12)
    frame = Frame(4, 2)
    Background("#ff7a1a").fill(frame)
    assert (to_srgb8(frame.color, tonemap="clamp") == [255, 122, 26]).all()


def test_gradient_background_blends_rows_linearly():
    frame = Frame(3, 4)
    Background((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)).fill(frame)
    assert_allclose(frame.color[:, 0, 0], [0.875, 0.625, 0.375, 0.125])
    assert_allclose(frame.color[:, 2, 2], [0.125, 0.375, 0.625, 0.875])
    wide = Frame(37, 4)  # copied across in doubling blocks: an odd width too
    Background((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)).fill(wide)
    assert (wide.color == wide.color[:, :1, :]).all()
    assert_allclose(wide.color[:, 0, 0], [0.875, 0.625, 0.375, 0.125])


def test_tonemap_rejects_bad_options():
    with pytest.raises(ValueError, match="tonemap must be one of"):
        to_srgb8(np.zeros((2, 2, 3), np.float32), tonemap="filmic")
    with pytest.raises(ValueError, match="exposure must be > 0"):
        to_srgb8(np.zeros((2, 2, 3), np.float32), exposure=0)


def test_a_buffer_out_of_shape_or_layout_is_named():
    color = np.ones((4, 6, 3), np.float32)
    good = np.empty((4, 6, 3), np.uint8)
    assert to_srgb8(color, out=good) is good
    with pytest.raises(ValueError, match="out must be a C-contiguous uint8"):
        to_srgb8(color, out=np.empty((6, 4, 3), np.uint8).transpose(1, 0, 2))
    with pytest.raises(ValueError, match="out must be"):
        to_srgb8(color, out=np.empty((4, 6, 3), np.float32))
