"""Shadows of opaque geometry from directional lights (``motes.render.shadows``)."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

import motes as mo
from motes.render.frame import Frame
from motes.render.geometry import Box, Capsule, Ground, Sphere, casters, draw_depth, draw_geometry
from motes.render.shading import AmbientLight, DirectionalLight
from motes.render.shadow_pass import prepare

# A top view of the ground: 200 px per metre over x in [-0.3, 1.7], z in [-1, 1].
SIZE, HEIGHT = 400, 2.0


def _top_view(objects, light_direction, shadows=True):
    camera = mo.Camera((0.7, 5.0, 0.0), (0.7, 0.0, 0.0), up=(0, 0, -1),
                       projection="orthographic", height=HEIGHT,
                       resolution=(SIZE, SIZE))  # fmt: skip
    frame = Frame(SIZE, SIZE)
    lights = [DirectionalLight(light_direction, shadows=shadows), AmbientLight((0.2,) * 3)]
    shadowing = prepare(lights, casters(objects), camera)
    draw_geometry(frame, camera, objects, lights=lights, supersample=1, shadowing=shadowing)
    right, up, _ = camera.basis
    j, i = np.mgrid[0:SIZE, 0:SIZE]
    offset = (i + 0.5 - SIZE / 2)[..., None] * right + (SIZE / 2 - j - 0.5)[..., None] * up
    world = camera.position + offset / camera.scale
    return frame.color[..., 0], world[..., 0], world[..., 2]


@pytest.mark.parametrize("tilt", [25.0, 40.0])
def test_a_spheres_shadow_is_the_ellipse_its_light_casts(tilt):
    """A sphere (radius R, centre h above the ground) under a light tilted by θ casts an
    ellipse with semi-axes R / cos θ (along the tilt) and R, centred h tan θ away. Where
    the sphere does not hide it from above, the shadowed pixels match the ellipse but
    for the pixels its outline crosses."""
    t = math.radians(tilt)
    radius, height = 0.5, 1.0
    color, x, z = _top_view(
        [Ground(0.0, color=(1, 1, 1)), Sphere((0, height, 0), radius, subdivisions=5)],
        (math.sin(t), -math.cos(t), 0.0),
    )
    lit = 0.2 + math.cos(t)
    region = x > radius + 0.02  # beyond the sphere's own disc seen from above
    shadowed = (color < 0.5 * (0.2 + lit)) & region
    ex = (x - height * math.tan(t)) * math.cos(t) / radius
    inside = (ex**2 + (z / radius) ** 2 <= 1.0) & region
    wrong = np.count_nonzero(shadowed != inside)
    # The outline crosses about perimeter x 200 px/m pixels; allow one in ten to differ.
    perimeter = 2 * math.pi * radius * (1 + 1 / math.cos(t)) / 2
    assert wrong <= 0.1 * perimeter * SIZE / HEIGHT
    assert np.count_nonzero(inside) > 10_000  # thousands of pixels, not a sliver
    np.testing.assert_allclose(color[shadowed & ~_near_edge(ex, z / radius)], 0.2, rtol=1e-5)
    np.testing.assert_allclose(color[region & ~inside & ~_near_edge(ex, z / radius)], lit,
                               rtol=1e-5)  # fmt: skip


def _near_edge(ex, ez):
    """Pixels within about two pixels of the ellipse's outline (where PCF blends)."""
    return np.abs(np.sqrt(ex**2 + ez**2) - 1.0) < 0.03


def test_without_shadows_nothing_darkens_and_a_box_shadows_itself_correctly():
    box = Box((0.7, 0.5, 0.0), (0.6, 1.0, 0.6))
    light = (0.3, -1.0, 0.2)
    plain, _, _ = _top_view([Ground(0.0, color=(1, 1, 1)), box], light, shadows=False)
    shaded, x, z = _top_view([Ground(0.0, color=(1, 1, 1)), box], light)
    # The box's top face is lit either way (it faces the light): no self-shadowing acne.
    top = (np.abs(x - 0.7) < 0.25) & (np.abs(z) < 0.25)
    np.testing.assert_array_equal(shaded[top], plain[top])
    # On the ground, something is darker with shadows, nothing is brighter.
    assert np.count_nonzero(shaded < plain - 0.1) > 1000
    assert np.all(shaded <= plain + 1e-6)


def test_a_shadow_maps_depth_is_the_drawn_depth_of_the_casters():
    """The shadow pass rasterises depth alone (no shading): the same depth, bit for bit,
    as drawing the casters shaded at one sample per pixel, on 1 and 2 threads."""
    objects = [
        Sphere((0.0, 1.0, 0.0), 0.5, subdivisions=4),
        Box((0.7, 0.5, 0.2), (0.6, 1.0, 0.6)),
        Capsule((-0.6, 0.1, -0.3), (0.4, 0.1, 0.5), 0.1),
    ]
    view = mo.Camera((2, 3, 1), (0, 0.5, 0), projection="orthographic", height=3.0,
                     resolution=(300, 200))  # fmt: skip
    frame = Frame(300, 200)
    draw_geometry(frame, view, objects, lights=[AmbientLight((0, 0, 0))], supersample=1)
    assert np.isfinite(frame.depth).sum() > 5_000
    previous = numba.get_num_threads()
    try:
        for threads in (1, min(2, numba.config.NUMBA_NUM_THREADS)):
            numba.set_num_threads(threads)
            np.testing.assert_array_equal(draw_depth(view, objects), frame.depth)
    finally:
        numba.set_num_threads(previous)


def test_a_shadow_map_has_about_a_texel_per_pixel_at_its_casters():
    from motes.render.shadows import MIN_RESOLUTION, RESOLUTION, map_resolution

    camera = mo.Camera((0, 0, 10), (0, 0, 0), fov=40, resolution=(1280, 720))
    sides = [map_resolution(camera, (0, 0, z), 1.0) for z in (-40, -10, 0, 5, 7, 8.5)]
    assert sides == sorted(sides) and all(side % 32 == 0 for side in sides)
    assert sides[0] == MIN_RESOLUTION and sides[-1] == RESOLUTION
    # 3 m away: 2 m across at 720 / (2 tan 20°) px per metre at 2 m (its nearest point)
    pixels = 2.0 * 360 / math.tan(math.radians(20)) / 2.0
    assert map_resolution(camera, (0, 0, 7), 1.0) == 32 * math.ceil(pixels / 32)
    assert map_resolution(camera, (0, 0, 9.5), 1.0) == RESOLUTION  # the eye is inside


def test_shadows_flag_is_checked():
    with pytest.raises(TypeError, match="shadows must be True or False"):
        DirectionalLight((0, -1, 0), shadows="yes")


def test_a_slab_of_particles_attenuates_the_light_as_beer_lambert_says():
    """40,000 particles (radius r, opacity α) spread uniformly through a slab above the
    ground: the light on the ground beneath is the key light times exp(-τ), with the slab's
    optical depth τ = N π r² (-ln(1 - α)) / area. The mean over the slab's middle matches
    within 5 % (the splat's texel-scale clumping makes it a little brighter, by about
    var(τ)/2 ≈ 2 %)."""
    rng = np.random.default_rng(2)
    n, r, alpha = 40_000, 0.03, 0.035
    positions = np.stack([rng.uniform(-1.0, 1.0, n), rng.uniform(0.5, 0.7, n),
                          rng.uniform(-1.0, 1.0, n)], axis=1)  # fmt: skip
    tau = n * math.pi * r * r * -math.log(1.0 - alpha) / 4.0
    camera = mo.Camera((0.0, 5.0, 0.0), (0.0, 0.0, 0.0), up=(0, 0, -1),
                       projection="orthographic", height=2.0, resolution=(100, 100))  # fmt: skip
    lights = [DirectionalLight((0, -1, 0), shadows=True), AmbientLight((0.2,) * 3)]
    shadowing = prepare(lights, [], camera, [(positions, np.full(n, r), np.full(n, alpha))])
    frame = Frame(100, 100)
    draw_geometry(frame, camera, [Ground(0.0, color=(1, 1, 1))], lights=lights,
                  shadowing=shadowing, supersample=1)  # fmt: skip
    middle = frame.color[25:75, 25:75, 0]
    assert tau == pytest.approx(1.0, abs=0.01)
    np.testing.assert_allclose((middle.mean() - 0.2) / 1.0, math.exp(-tau), rtol=0.05)
    # Outside the slab the ground gets the full light.
    outside = Frame(100, 100)
    wide = mo.Camera((0.0, 5.0, 0.0), (0.0, 0.0, 0.0), up=(0, 0, -1),
                     projection="orthographic", height=6.0, resolution=(100, 100))  # fmt: skip
    draw_geometry(outside, wide, [Ground(0.0, color=(1, 1, 1))], lights=lights,
                  shadowing=prepare(lights, [], wide, [(positions, np.full(n, r),
                                                        np.full(n, alpha))]),
                  supersample=1)  # fmt: skip
    np.testing.assert_allclose(outside.color[2, 2, 0], 1.2, rtol=1e-5)


def test_lit_particles_are_darker_in_the_shadow_of_others():
    """A dense puff above a particle shades it; a particle beside the puff is fully lit."""
    from motes.render.lighting import light_particles

    rng = np.random.default_rng(3)
    puff = rng.normal((0.0, 2.0, 0.0), 0.1, (3000, 3))
    probes = np.array([[0.0, 1.0, 0.0], [1.0, 1.0, 0.0]])  # lit, casting no shadow
    lights = [DirectionalLight((0, -1, 0), shadows=True), AmbientLight((0.1,) * 3)]
    camera = mo.Camera((0, 1, 5), (0, 1, 0))
    casting = [(puff, np.full(len(puff), 0.05), np.full(len(puff), 0.5))]
    shadowing = prepare(lights, [], camera, casting)
    rgb = np.ones((2, 3), np.float32)
    out = np.empty_like(rgb)
    light_particles(shadowing.lights, shadowing.ambient, shadowing.arrays, *probes.T.copy(), rgb,
                    out)  # fmt: skip
    assert out[0, 0] < 0.2  # under the puff: ambient and little else
    np.testing.assert_allclose(out[1], 1.1, rtol=1e-3)  # beside it: ambient + key light
