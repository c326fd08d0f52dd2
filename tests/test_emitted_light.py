"""Glowing particles and hot volumes as point lights: where, how bright, and what they light."""

from __future__ import annotations

import numpy as np
import pytest

import motes as mo
from motes.render import geometry
from motes.render.emitted_light import particle_light, volume_light
from motes.render.shading import AmbientLight
from motes.render.volume import Volume
from motes.render.volume_blackbody import blackbody_rgb
from motes.state import Field, ParticleState


def sparks(positions, color, radius):
    positions = np.asarray(positions, float).T
    n = positions.shape[1]
    rgba = np.repeat(np.asarray(color, np.float32)[:, None], n, axis=1)
    return ParticleState(np.arange(n, dtype=np.int64), positions, np.zeros((3, n)),
                         np.full(n, radius), {"color": Field(rgba)})  # fmt: skip


def test_particles_light_from_the_centre_of_their_light():
    state = sparks([[-1.0, 2.0, 0.0], [1.0, 2.0, 0.0]], (1.0, 0.5, 0.25, 0.5), 0.1)
    style = mo.SpriteStyle(blend="additive", intensity=2.0, light=3.0)
    light = particle_light(state, style)
    assert np.allclose(light.position, [0.0, 2.0, 0.0])
    # each a disc of radiance colour x alpha x intensity and area pi r^2, times light
    power = 3.0 * 2 * np.array([1.0, 0.5, 0.25]) * 0.5 * 2.0 * np.pi * 0.1**2
    assert np.allclose(light.color * light.intensity, power)
    assert particle_light(state, mo.SpriteStyle(blend="additive")) is None  # light 0
    # no colour field: drawn white, so glowing white
    plain = ParticleState(np.arange(2, dtype=np.int64), state.positions, np.zeros((3, 2)),
                          np.full(2, 0.1))  # fmt: skip
    white = particle_light(plain, mo.SpriteStyle(light=1.0))
    assert np.allclose(white.color * white.intensity, 2 * np.pi * 0.1**2)


def test_a_hot_volume_lights_from_its_glow():
    density = np.zeros((8, 8, 8), np.float32)
    temperature = np.full((8, 8, 8), 300.0, np.float32)
    density[2:6, 1:5, 3:7] = 2.0
    temperature[2:6, 1:5, 3:7] = 1500.0
    volume = Volume(density, cell_size=0.1, origin=(1.0, 0.0, 0.0), temperature=temperature,
                    emission=0.5, light=0.25)  # fmt: skip
    light = volume_light(volume)
    assert np.allclose(light.position, [1.0 + 0.4, 0.3, 0.5])  # the hot block's centre
    power = 0.25 * 64 * 0.5 * 2.0 * 0.1**3 * blackbody_rgb(1500.0)
    assert np.allclose(light.color * light.intensity, power, rtol=1e-5)
    cold = Volume(density, cell_size=0.1, temperature=np.full((8, 8, 8), 700.0), emission=0.5,
                  light=1.0)  # fmt: skip
    assert volume_light(cold) is None  # below the glow of 798 K


def test_the_ground_under_a_glow_is_lit_as_by_a_point_light():
    """Straight below a light of intensity I at height h, a white-facing ground of
    albedo c gains c I / h² (``PointLight``'s law)."""
    height = 2.0
    state = sparks([[-0.3, height, 0.0], [0.3, height, 0.0]], (1.0, 0.6, 0.3, 1.0), 0.05)
    camera = mo.Camera((0.0, 3.0, 6.0), (0.0, 0.0, 0.0), resolution=(160, 90))
    ground = geometry.Ground(0.0, color=(0.5, 0.5, 0.5))
    images = {}
    for gain in (0.0, 40.0):
        style = mo.SpriteStyle(blend="additive", light=gain)
        renderer = mo.Renderer(camera, lights=[AmbientLight((0.0, 0.0, 0.0))], supersample=1)
        images[gain] = renderer.render_hdr([(state, style)], [ground]).color
    xy, _ = camera.project([[0.0, 0.0, 0.0]])
    x, y = np.floor(xy[0]).astype(int)
    light = particle_light(state, mo.SpriteStyle(blend="additive", light=40.0))
    gained = images[40.0][y, x] - images[0.0][y, x]
    expected = 0.5 * light.color * light.intensity / height**2
    assert np.allclose(gained, expected, rtol=0.05)
    assert images[40.0].sum() > images[0.0].sum()


def test_light_is_checked():
    with pytest.raises(ValueError, match="light"):
        mo.SpriteStyle(light=-1.0)
    with pytest.raises(ValueError, match="light"):
        Volume(np.zeros((2, 2, 2)), cell_size=0.1, light=-0.5)
