"""Strands that cast soft shadows through the opacity maps, on the ground and on strands."""

from __future__ import annotations

import numpy as np
import pytest

import motes as mo
from motes.render import geometry
from motes.render.geometry import _light_share
from motes.render.shading import AmbientLight, DirectionalLight
from motes.render.shadow_pass import prepare


def strand(y: float, *, z: float = 0.0, shadow_radius: float = 0.0, opacity: float = 0.5):
    """A straight strand along x at height ``y``: 20 segments from x = -0.5 to 0.5."""
    points = np.stack([np.linspace(-0.5, 0.5, 21), np.full(21, y), np.full(21, z)], axis=1)
    return geometry.Lines(points, color=(0.6, 0.4, 0.2), shading="hair",
                          shadow_radius=shadow_radius, shadow_opacity=opacity)  # fmt: skip


LIGHTS = [DirectionalLight((0.0, -1.0, 0.0), shadows=True), AmbientLight((0.1, 0.1, 0.1))]
CAMERA = mo.Camera((0.0, 1.5, 3.0), (0.0, 0.3, 0.0), resolution=(160, 90))


def test_a_strand_casts_blobs_at_its_midpoints():
    lines = strand(1.0, shadow_radius=0.03, opacity=0.4)
    centres, radius, alpha = lines.opacity_casters()
    assert centres.shape == (20, 3) and np.allclose(centres[:, 1], 1.0)
    assert np.allclose(centres[:, 0], np.linspace(-0.475, 0.475, 20))
    assert np.all(radius == 0.03) and np.all(alpha == 0.4)
    with pytest.raises(ValueError, match="shadow_opacity"):
        strand(1.0, opacity=1.5)


def test_a_strand_below_another_gets_less_light():
    upper = strand(1.0, shadow_radius=0.04, opacity=0.6)
    shadowing = prepare(LIGHTS, [], CAMERA, [upper.opacity_casters()])
    below = strand(0.5).ends()
    aside = strand(0.5, z=0.6).ends()  # out of the upper strand's shadow
    share_below = _light_share(shadowing, below)
    share_aside = _light_share(shadowing, aside)
    assert np.all(share_aside > 0.99)
    # the light through a strand of blobs of opacity 0.6 is well under full, the ambient kept
    assert np.all(share_below[2:-2] < 0.8) and np.all(share_below > 0.05)


def test_strands_that_cast_darken_the_ground_beneath():
    images = {}
    for radius in (0.0, 0.04):
        renderer = mo.Renderer(CAMERA, lights=LIGHTS, supersample=1)
        ground = geometry.Ground(0.0, color=(0.5, 0.5, 0.5))
        images[radius] = renderer.render_hdr([], [ground, strand(0.6, shadow_radius=radius,
                                                                 opacity=0.8)]).color  # fmt: skip
    (x, y), _ = CAMERA.project([[0.0, 0.0, 0.0]])[0][0], None
    below = images[0.04][int(y), int(x)].sum()
    assert below < 0.8 * images[0.0][int(y), int(x)].sum()
    (fx, fy), _ = CAMERA.project([[0.0, 0.0, 0.8]])[0][0], None  # far from the shadow
    assert images[0.04][int(fy), int(fx)].sum() == pytest.approx(
        images[0.0][int(fy), int(fx)].sum(), rel=1e-3
    )
