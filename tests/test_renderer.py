"""The renderer facade: layer order, styles, defaults, and bad input."""

import numpy as np
import pytest

import motes as mo
from motes.render import geometry


def still_system(positions, colors, size=0.1):
    system = mo.ParticleSystem(len(positions), attributes=("color", "size"))
    system.store.spawn(len(positions))
    system["position"] = positions
    system["velocity"] = 0.0
    system["color"] = colors
    system["size"] = size
    system["lifetime"] = np.inf
    return system


def camera(width=64, height=48):
    return mo.Camera((0, 0, 5), (0, 0, 0), fov=40, resolution=(width, height))


def test_additive_particles_add_light_to_the_background():
    system = still_system([[0, 0, 0]], [[1.0, 0.5, 0.25, 1.0]], size=0.5)
    base = mo.Renderer(camera(), background=(0.1, 0.1, 0.1), tonemap="clamp")
    hdr = base.render_hdr([system])
    centre = hdr.color[24, 32]
    # Unit-peak profile (1 - r²/R²)², R = 6.6 px: the pixel centre 0.7 px from the
    # particle gets 0.977 of the colour, on top of the background's 0.1.
    np.testing.assert_allclose(centre, 0.1 + 0.977 * np.array([1.0, 0.5, 0.25]), atol=0.01)
    np.testing.assert_allclose(hdr.color[0, 0], [0.1, 0.1, 0.1])


def test_opaque_geometry_hides_particles_behind_it():
    system = still_system([[0, 0, -2.0]], [[1.0, 0.0, 0.0, 1.0]], size=0.6)
    wall = geometry.Box((0, 0, 0), (4, 4, 0.1), color=(0.2, 0.2, 0.2))
    renderer = mo.Renderer(camera(), tonemap="clamp", supersample=1)
    behind = renderer.render_hdr([system], [wall])
    alone = renderer.render_hdr([system])
    wall_only = renderer.render_hdr([], [wall])
    assert alone.color[24, 32, 0] > 0.9
    np.testing.assert_array_equal(behind.color, wall_only.color)


def test_alpha_systems_are_composited_far_to_near_before_additive_ones():
    near = still_system([[0, 0, 1.0]], [[1.0, 0.0, 0.0, 1.0]], size=0.3)
    far = still_system([[0, 0, -1.0]], [[0.0, 1.0, 0.0, 1.0]], size=0.3)
    alpha = mo.SpriteStyle(blend="alpha", falloff="disc")
    renderer = mo.Renderer(camera(), tonemap="clamp")
    for order in ([(near, alpha), (far, alpha)], [(far, alpha), (near, alpha)]):
        centre = renderer.render_hdr(order).color[24, 32]
        # the near one on top (its opacity is 1 up to the energy normalisation, < 1 %)
        np.testing.assert_allclose(centre, [1.0, 0.0, 0.0], atol=0.01)


def test_systems_without_colour_or_size_attributes_draw_white_default_sprites():
    system = mo.ParticleSystem(10)
    system.store.spawn(1)
    system["position"] = [0, 0, 0]
    system["lifetime"] = np.inf
    hdr = mo.Renderer(camera(), tonemap="clamp").render_hdr([system])
    assert np.ptp(hdr.color[24, 32]) == 0 and hdr.color[24, 32, 0] > 0  # white
    # Radius 0.05 m is R = 0.66 px at 5 m; a sprite's light is the smooth profile's
    # area πR²/3 (unit peak), whatever footprint it is spread over.
    radius_px = 0.05 * camera().pixels_per_metre(5.0)
    assert hdr.color[..., 0].sum() == pytest.approx(np.pi * radius_px**2 / 3, rel=1e-4)


def test_render_returns_srgb_bytes_and_is_deterministic():
    rng = np.random.default_rng(0)
    system = still_system(rng.normal(0, 0.5, (500, 3)), rng.uniform(0, 1, (500, 4)), size=0.05)
    renderer = mo.Renderer(camera(), exposure=2.0)
    first = renderer.render([system])
    assert first.dtype == np.uint8 and first.shape == (48, 64, 3)
    np.testing.assert_array_equal(first, mo.Renderer(camera(), exposure=2.0).render([system]))


def test_render_reuses_its_frame_without_leaking_the_last_one():
    """render() keeps its frame between calls: what the last call drew (a box, particles)
    must not show in the next, nor after the camera's size changes."""
    system = still_system([[0, 0, -1.0]], [[1.0, 0.5, 0.25, 1.0]], size=0.5)  # behind
    wall = geometry.Box((0, 0, 0), (2, 2, 0.1), color=(0.6, 0.2, 0.2))
    kept = mo.Renderer(camera(), background=(0.1, 0.2, 0.3), supersample=1)
    kept.render([system], [wall])
    np.testing.assert_array_equal(
        kept.render([system]),
        mo.Renderer(camera(), background=(0.1, 0.2, 0.3), supersample=1).render([system]),
    )
    hdr = kept.render_hdr([system])
    assert hdr is not kept.render_hdr([system])  # render_hdr's frames are the caller's
    kept.camera = camera(32, 24)
    small = kept.render([], [wall])
    fresh = mo.Renderer(camera(32, 24), background=(0.1, 0.2, 0.3), supersample=1)
    np.testing.assert_array_equal(small, fresh.render([], [wall]))


def test_renderer_rejects_bad_arguments():
    with pytest.raises(TypeError, match="camera must be a Camera"):
        mo.Renderer("camera")
    with pytest.raises(ValueError, match="exposure must be > 0"):
        mo.Renderer(camera(), exposure=0)
    with pytest.raises(ValueError, match="tonemap must be one of"):
        mo.Renderer(camera(), tonemap="hable")
    system = still_system([[0, 0, 0]], [[1, 1, 1, 1]])
    with pytest.raises(TypeError, match="style must be a SpriteStyle"):
        mo.Renderer(camera()).render([(system, "additive")])
