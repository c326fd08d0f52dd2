"""Ray-marched volumes (``motes.render.volume``): closed forms, naive twins, compositing
with geometry and particles, the blackbody ramp, determinism and bad input."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import motes as mo
import naive_volume as naive
from motes.render import geometry
from motes.render import volume as vol
from motes.render import volume_light as vl
from motes.render.frame import Frame
from motes.render.shading import AmbientLight, DirectionalLight, PointLight
from motes.render.shadow_pass import prepare
from motes.render.shadows import unshadowed
from motes.render.sprites import SpriteRasterizer, SpriteStyle
from motes.render.volume import Volume, blackbody_rgb, blackbody_xyz, draw_volumes, light_volume
from motes.state import Field, ParticleState

BACKGROUND = (0.6, 0.5, 0.4)


def slab(depth=0.2, *, cells=4, extinction=5.0, **options) -> Volume:
    """A uniform slab of density 1, ``depth`` thick along z (centred on z = 0), 2 m wide
    in x and y."""
    cell = depth / cells
    side = round(2.0 / cell)
    density = np.ones((side, side, cells), np.float32)
    return Volume(density, cell_size=cell, origin=(-1.0, -1.0, -depth / 2),
                  extinction=extinction, **options)  # fmt: skip


def noise_volume(shape=(10, 8, 9), seed=1, **options) -> Volume:
    """Sparse random density (some voxels exactly 0) in a box about the origin."""
    rng = np.random.default_rng(seed)
    density = np.clip(rng.normal(0.4, 0.5, shape), 0.0, None).astype(np.float32)
    settings = {"cell_size": 0.1, "origin": (-0.5, -0.4, -0.45), "extinction": 6.0} | options
    return Volume(density, **settings)


def particles(positions, rgba, radius=0.05) -> ParticleState:
    positions = np.asarray(positions, dtype=np.float64)
    n = len(positions)
    return ParticleState(
        np.arange(n, dtype=np.int64), positions.T.copy(), np.zeros((3, n)), np.full(n, radius),
        {"color": Field(np.asarray(rgba, dtype=np.float64).T.copy())},
    )  # fmt: skip


# -- closed forms ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("angle", "projection"), [(0.0, "perspective"), (0.0, "orthographic"), (35.0, "orthographic")]
)
def test_a_slab_transmits_the_background_times_exp_minus_sigma_d(angle, projection):
    """Beer–Lambert: a uniform, purely absorbing slab of thickness d in front of a constant
    background leaves B exp(-σ d / cos θ) on a ray crossing it at θ. Each ray segment is
    integrated exactly for a constant medium, so only float32 rounding remains (the brief
    asks for 1 %; 1e-5 relative is what round-off allows)."""
    t = math.radians(angle)
    camera = mo.Camera((5 * math.sin(t), 0, 5 * math.cos(t)), (0, 0, 0), projection=projection,
                       height=0.5, fov=20, resolution=(32, 24))  # fmt: skip
    renderer = mo.Renderer(camera, background=BACKGROUND, lights=[])
    frame = renderer.render_hdr([], [slab(albedo=0.0)])
    for row, col in [(12, 16), (8, 12), (15, 19)]:
        _, ray = naive.camera_ray(camera, col + 0.5, row + 0.5)
        cos = abs(ray[2]) / np.linalg.norm(ray)  # cos θ of this pixel's ray
        if projection == "orthographic":
            assert cos == pytest.approx(math.cos(t))
        expected = np.array(BACKGROUND) * math.exp(-5.0 * 0.2 / cos)
        np.testing.assert_allclose(frame.color[row, col], expected, rtol=1e-5)


def test_an_emitting_slab_glows_with_the_absorbing_emitting_closed_form():
    """dL/ds = -σ L + e ρ B(T) with uniform ρ = 1 and T gives, over a thickness d and no
    light behind, L = e B(T) (1 - exp(-σ_t d)) / σ_t. 1500 K is an entry of the kernels'
    blackbody table, so only float32 rounding separates them (1e-5)."""
    d, sigma, e = 0.2, 4.0, 3.0
    temperature = np.full((40, 40, 4), 1500.0, np.float32)
    volume = slab(d, extinction=sigma, albedo=0.0, temperature=temperature, emission=e)
    camera = mo.Camera((0, 0, 5), (0, 0, 0), fov=20, resolution=(16, 12))
    frame = mo.Renderer(camera, background=(0, 0, 0), lights=[]).render_hdr([], [volume])
    _, ray = naive.camera_ray(camera, 8.5, 6.5)
    path = d * np.linalg.norm(ray) / abs(ray[2])  # the pixel's ray is slightly oblique
    expected = e * blackbody_rgb(1500.0) * (1 - math.exp(-sigma * path)) / sigma
    np.testing.assert_allclose(frame.color[6, 8], expected, rtol=1e-5)


@pytest.mark.parametrize("g", [0.0, 0.4])
def test_single_scattering_of_an_unshadowed_slab_matches_its_closed_form(g):
    """Without self-shadowing every voxel sees the full light, so the source function
    j / σ is the constant a (p̂(cos θ) L + (S + G) / 2) and the slab shows
    B e^{-σd} + a (p̂ L + (S + G)/2)(1 - e^{-σd}); p̂ is Henyey–Greenstein times 4π
    (1 for g = 0). Exact for a constant medium: float32 rounding only."""
    d, sigma, albedo = 0.2, 5.0, np.array([0.9, 0.6, 0.3])
    toward = np.array([0.6, 0.0, 0.8])  # the light comes from the camera's side
    lights = [DirectionalLight(-toward, color=(1.0, 0.9, 0.8), intensity=2.0),
              AmbientLight((0.3, 0.35, 0.4), ground=(0.1, 0.08, 0.06))]  # fmt: skip
    camera = mo.Camera((0, 0, 5), (0, 0, 0), fov=20, resolution=(16, 12))
    volume = slab(d, extinction=sigma, albedo=albedo, anisotropy=g, shadows=False)
    frame = mo.Renderer(camera, background=BACKGROUND, lights=lights).render_hdr([], [volume])
    _, ray = naive.camera_ray(camera, 8.5, 6.5)
    ray /= np.linalg.norm(ray)
    phase = naive.henyey_greenstein(g, float(toward @ ray))
    light = phase * 2.0 * np.array([1.0, 0.9, 0.8]) + 0.5 * np.array([0.4, 0.43, 0.46])
    kept = math.exp(-sigma * d / float(-ray[2]))
    expected = np.array(BACKGROUND) * kept + albedo * light * (1 - kept)
    np.testing.assert_allclose(frame.color[6, 8], expected, rtol=1e-5)


# -- kernels against their naive twins --------------------------------------------------


def test_brick_maxima_and_distances_match_their_twins():
    rng = np.random.default_rng(3)
    density = np.where(rng.random((13, 9, 11)) < 0.03, 1.0, 0.0).astype(np.float32)
    maxima = np.empty((4, 3, 3), np.float32)
    vl.brick_maxima(density, 4, maxima)
    np.testing.assert_array_equal(maxima, naive.brick_maxima(density, 4))
    distances = np.empty(maxima.shape, np.int32)
    vl.brick_distances(maxima, 64, distances)
    np.testing.assert_array_equal(distances, naive.brick_distances(maxima, 64))
    vl.brick_distances(np.zeros_like(maxima), 5, distances)
    assert (distances == 5).all()


@pytest.mark.parametrize(
    "toward",
    [(1, 0, 0), (-0.8, 0.3, -0.52), (0.2, 1.0, 0.4), (0.3, -0.9, 0.1), (0.1, 0.25, -1.0),
     (0.5, 0.1, 0.6)],
)  # fmt: skip
def test_the_directional_light_sweep_matches_its_twin(toward):
    """The float32 kernel against the float64 twin: sums of ~10 float32 terms, 1e-5."""
    volume = noise_volume()
    toward = np.asarray(toward, float) / np.linalg.norm(toward)
    tau = np.empty(volume.shape, np.float32)
    vol._sweep(volume, toward, tau)
    expected = naive.sweep_depth(volume.density, toward, volume.extinction, volume.cell_size)
    np.testing.assert_allclose(tau, expected, rtol=1e-5, atol=1e-6)


def test_the_sweep_is_exact_in_a_uniform_medium():
    """In a uniform medium the optical depth toward the light is σ times the distance
    to the face it enters by, for voxels whose ray stays inside the box (bilinear and
    trapezoidal steps are exact for a linear field)."""
    density = np.ones((12, 12, 12), np.float32)
    volume = Volume(density, cell_size=0.1, extinction=2.0)
    toward = np.array([0.9, 0.3, -0.2])
    toward /= np.linalg.norm(toward)
    tau = np.empty(volume.shape, np.float32)
    vol._sweep(volume, toward, tau)
    centre = (np.arange(12) + 0.5) * 0.1
    x = centre[:, None, None]
    distance = (1.2 - x) / toward[0]
    reach_y = centre[None, :, None] + distance * toward[1]
    reach_z = centre[None, None, :] + distance * toward[2]
    inside = (reach_y > 0.05) & (reach_y < 1.15) & (reach_z > 0.05) & (reach_z < 1.15)
    inside = np.broadcast_to(inside, tau.shape)
    assert inside.sum() > 500
    np.testing.assert_allclose(tau[inside], np.broadcast_to(2.0 * distance, tau.shape)[inside],
                               rtol=1e-5)  # fmt: skip


def test_the_ambient_columns_match_their_twin():
    volume = noise_volume()
    above = np.empty(volume.shape, np.float32)
    below = np.empty(volume.shape, np.float32)
    vl.columns(volume.density, 0.5 * volume.extinction * volume.cell_size, above, below)
    expected = naive.column_depths(volume.density, volume.extinction, volume.cell_size)
    np.testing.assert_allclose(above, expected[0], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(below, expected[1], rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize(("position", "factor"), [((0.1, 0.2, 1.5), 1), ((0.0, 0.0, 0.1), 2)])
def test_the_point_light_march_matches_its_twin(position, factor):
    """Outside and inside the box, on the fine grid and a coarse one (float32 density,
    float64 sums in both: 1e-6)."""
    volume = noise_volume(shadow_step=0.7)
    lo, hi = volume.bounds
    coarse = np.empty(tuple(-(-n // factor) for n in volume.shape), np.float32)
    bricks = np.zeros(tuple(-(-n // vl.BRICK) for n in volume.shape), np.int32)  # all hold medium
    vl.march_point(volume.density[..., None], bricks, vl.BRICK, lo, hi, volume.cell_size,
                   volume.extinction, *position, 0.7 * volume.cell_size, float(factor),
                   coarse)  # fmt: skip
    expected = naive.point_transmittance(volume, position, factor, 0.7 * volume.cell_size)
    np.testing.assert_allclose(coarse, expected, rtol=1e-6, atol=1e-7)


def _lit_scene(**options):
    temperature = np.random.default_rng(5).uniform(600, 1900, (10, 8, 9)).astype(np.float32)
    volume = noise_volume(temperature=temperature, emission=0.4, anisotropy=0.3,
                          albedo=(0.9, 0.7, 0.5), **options)  # fmt: skip
    lights = [DirectionalLight((-0.7, -0.5, -0.3), intensity=1.5),
              PointLight((0.8, 0.6, 0.9), color=(1.0, 0.6, 0.3), intensity=2.0),
              AmbientLight((0.3, 0.3, 0.4), ground=(0.1, 0.1, 0.05))]  # fmt: skip
    return volume, unshadowed(lights)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_camera_rays_match_their_twin(projection):
    """Every pixel of a small image through a noisy, lit, emitting volume, with opaque
    depths cutting some rays: the kernel (with empty-space leaps) against the twin
    (without), given the same packed light volumes. The kernel interpolates the
    blackbody from a 4 K table, the twin evaluates it (within 0.3 % above 1000 K, and
    below 1e-3 of the reference luminance under it), hence 3e-3."""
    volume, shadowing = _lit_scene()
    camera = mo.Camera((0.6, 0.5, 2.0), (0, 0, 0), projection=projection, height=1.2,
                       fov=35, resolution=(14, 10))  # fmt: skip
    lit = light_volume(volume, shadowing)
    frame = Frame(14, 10)
    frame.color[:] = BACKGROUND
    depth = np.random.default_rng(2).uniform(1.5, 2.6, (10, 14)).astype(np.float32)
    depth[::3] = np.inf
    frame.depth[:] = depth
    trans = np.ones((10, 14), np.float32)
    vol.march_volume(frame, camera, lit, trans)
    assert (trans < 0.9).sum() > 20  # most rays cross the medium
    for row in range(10):
        for col in range(14):
            light, seen, _ = naive.march_ray(
                volume, lit, camera, col + 0.5, row + 0.5, stop=depth[row, col],
                offset=naive.pixel_hash(row, col),
            )  # fmt: skip
            np.testing.assert_allclose(trans[row, col], seen, rtol=1e-5, atol=1e-7)
            np.testing.assert_allclose(frame.color[row, col],
                                       np.array(BACKGROUND) * seen + light, rtol=3e-3,
                                       atol=1e-5)  # fmt: skip


def test_froxels_match_their_twin():
    """Each froxel column holds (S, T) at the slice depths, as the twin marches them (the
    pixels' lattice cut at the slices, no jitter, no leaping); a particle's lookup is the
    trilinear interpolation of the grid."""
    volume, shadowing = _lit_scene()
    camera = mo.Camera((0.6, 0.5, 2.0), (0, 0, 0), fov=35, resolution=(40, 30))
    lit = light_volume(volume, shadowing)
    froxels = vol.froxel_grid(camera, lit)
    gh, gw, slices = froxels.grid.shape[:3]
    cuts = [froxels.z0 + s * froxels.dz for s in range(slices)]
    crossed = 0
    for gi, gj in [(gh // 2, gw // 2), (1, gw // 3), (gh - 2, 2), (gh // 3, gw - 3)]:
        sx = froxels.x0 + (gj + 0.5) * froxels.factor
        sy = froxels.y0 + (gi + 0.5) * froxels.factor
        *_, expected = naive.march_ray(volume, lit, camera, sx, sy, cuts=cuts)
        got = froxels.grid[gi, gj]
        crossed += expected[-1, 3] < 0.9
        np.testing.assert_allclose(got[:, 3], expected[:, 3], rtol=1e-5, atol=1e-7)
        # the blackbody table against the function, as for camera rays
        np.testing.assert_allclose(got[:, :3], expected[:, :3], rtol=3e-3, atol=1e-5)
    assert crossed >= 2  # rays through the medium, not only past it
    points = np.array([[0.05, 0.02, 0.1], [-0.2, 0.1, -0.3], [3.0, 0.0, 0.0]])
    xy, depth = camera.project(points)
    got = froxels.lookup(camera, points)
    for p in range(len(points)):
        f = froxels
        expected = naive.froxel_lookup(
            f.grid.astype(np.float64), f.x0, f.y0, f.factor, f.z0, f.dz, *xy[p], depth[p]
        )
        np.testing.assert_allclose(got[p], expected, rtol=1e-5, atol=1e-7)


# -- lighting and compositing --------------------------------------------------------


def test_a_smoke_sphere_lit_from_plus_x_is_brighter_on_its_plus_x_side():
    """Self-shadowing: light from +x crosses the dense sphere (optical depth ~10 along a
    diameter) to reach the -x half, so the -x half shows several times less scattered
    light; without self-shadowing both halves are alike."""
    n = 24
    u = (np.arange(n) + 0.5) / n * 2 - 1
    x, y, z = np.meshgrid(u, u, u, indexing="ij")
    density = (x**2 + y**2 + z**2 < 0.8**2).astype(np.float32)
    camera = mo.Camera((0, 0, 5), (0, 0, 0), fov=30, resolution=(48, 36))
    lights = [DirectionalLight((-1.0, 0.0, 0.0), intensity=2.0)]
    halves = []
    for shadows in (True, False):
        volume = Volume(density, cell_size=2 / n, origin=(-1, -1, -1), extinction=6.0,
                        albedo=1.0, shadows=shadows)  # fmt: skip
        image = mo.Renderer(camera, background=(0, 0, 0), lights=lights).render_hdr([], [volume])
        luminance = image.color[10:26].sum(axis=2)
        halves.append((luminance[:, 26:40].mean(), luminance[:, 8:22].mean()))
    (lit_side, dark_side), (plain_right, plain_left) = halves
    assert lit_side > 3.0 * dark_side
    assert abs(plain_right / plain_left - 1) < 0.05


def test_opaque_geometry_inside_the_volume_cuts_the_rays():
    """A box whose front face is 0.1 m inside an absorbing slab: the pixel in front of it
    shows the box's colour times exp(-σ · 0.1), only the slab before it; beside the box the
    whole slab (0.4 m) attenuates the background. Exact segments: float32 rounding only."""
    box = geometry.Box((0, 0, -0.25), (0.6, 0.6, 0.7), color=(0.8, 0.7, 0.6))
    camera = mo.Camera((0, 0, 4), (0, 0, 0), fov=30, resolution=(32, 24))
    lights = [AmbientLight((0.5, 0.5, 0.5))]
    renderer = mo.Renderer(camera, background=BACKGROUND, lights=lights, supersample=1)
    volume = slab(0.4, cells=8, extinction=3.0, albedo=0.0)
    plain = renderer.render_hdr([], [box])
    through = renderer.render_hdr([], [box, volume])
    for (row, col), inside in [((12, 16), 0.1), ((12, 8), 0.4)]:
        _, ray = naive.camera_ray(camera, col + 0.5, row + 0.5)
        path = inside * np.linalg.norm(ray) / abs(ray[2])
        expected = plain.color[row, col] * math.exp(-3.0 * path)
        np.testing.assert_allclose(through.color[row, col], expected, rtol=1e-5)
    np.testing.assert_array_equal(through.depth, plain.depth)


def test_an_additive_particle_behind_a_slab_is_attenuated_by_exp_minus_sigma_d():
    """Over a black background, an absorbing slab leaves T c of the particle's light;
    behind the slab the froxel grid's last slice holds the full slab's T = e^{-σd / cos θ}
    of each froxel ray. The particle sits on the view axis and the four froxel rays around
    it are ≤ 2.8 px (0.06 rad at 45 px/m) off it: their paths are longer by ≤ θ²/2, which
    bilinear interpolation does not cancel: T within 2e-3 of e^{-σd}."""
    camera = mo.Camera((0, 0, 4), (0, 0, 0), fov=30, resolution=(32, 24))
    renderer = mo.Renderer(camera, background=(0, 0, 0), lights=[])
    light = particles([[0.0, 0.0, -0.5]], [[1.0, 0.6, 0.3, 1.0]], radius=0.3)
    alone = renderer.render_hdr([light]).color
    behind = renderer.render_hdr([light], [slab(albedo=0.0)]).color
    assert alone[12, 16, 0] > 0.5
    np.testing.assert_allclose(behind, alone * math.exp(-1.0), rtol=2e-3, atol=1e-7)


def test_an_alpha_particle_in_front_of_the_volume_keeps_its_colour():
    """In front of the volume's box S = 0 and T = 1: the particle is drawn with its own
    colour over the volume (bit for bit what drawing it over the volume's frame gives)."""
    camera = mo.Camera((0, 0, 4), (0, 0, 0), fov=30, resolution=(32, 24))
    lights = [DirectionalLight((-1, -1, -1)), AmbientLight((0.2, 0.2, 0.2))]
    renderer = mo.Renderer(camera, background=BACKGROUND, lights=lights)
    style = SpriteStyle(blend="alpha", falloff="disc")
    puff = particles([[0.0, 0.0, 0.6]], [[1.0, 0.2, 0.1, 0.7]], radius=0.15)
    volume = slab(albedo=0.8)
    together = renderer.render_hdr([(puff, style)], [volume])
    expected = renderer.render_hdr([], [volume])
    SpriteRasterizer(style).draw(expected, camera, puff.positions.T, puff["color"].T, puff.radius)
    np.testing.assert_array_equal(together.color, expected.color)


@pytest.mark.parametrize(
    ("eye", "tolerance"),
    [
        # Head-on, a slab face is at one view depth over the image: froxel rays differ
        # from the particle's only by their angle (≤ 2.8 px / 90 px/m, so path lengths
        # by Δθ²/2 ~ 5e-4); depth slices 0.2/48 m apart give (σΔz)²/8 ~ 5e-5 and the
        # 0.25-voxel segments a midpoint error ~ 4e-5 in S: 2e-3.
        ((0.0, 0.0, 3.0), 2e-3),
        # Obliquely, the slab's front face crosses the slices, so at one view depth the
        # path inside the medium changes by ~6 % from one froxel column to the next and
        # the screen-space interpolation of its convex S and T errs by ~4e-3: 1e-2.
        ((0.3, 0.2, 3.0), 1e-2),
    ],
)
@pytest.mark.parametrize("depth", [-0.07, 0.0, 0.031, 0.09])
def test_particles_inside_a_lit_slab_take_the_exact_compositing_colour(eye, tolerance, depth):
    """A particle at depth z inside a lit, self-shadowed slab is drawn with S(z)/k + T(z) c
    (alpha) and T(z) c (additive), S and T from the froxel grid, against S and T marched
    finely to the particle's depth along its own ray (the exact values for this medium)."""
    lights = [DirectionalLight((-0.6, -0.5, -0.4), intensity=1.5), AmbientLight((0.2, 0.25, 0.3))]
    shadowing = unshadowed(lights)
    camera = mo.Camera(eye, (0, 0, 0), fov=30, resolution=(64, 48))
    volume = slab(0.2, cells=8, extinction=5.0, albedo=0.7, step=0.25, jitter=False)
    layer = draw_volumes(Frame(64, 48), camera, [volume], shadowing)
    position = np.array([[0.05, -0.03, depth]])
    rgba = np.array([[0.9, 0.5, 0.2, 0.6]])
    xy, view_depth = camera.project(position)
    lit = light_volume(volume, shadowing)
    light, seen = naive.march_to_depth(volume, lit, camera, *xy[0], view_depth[0], step=0.002)
    assert 0.3 < seen < 0.97 and light.min() > 0.01  # inside the medium
    for style, expected in [
        (SpriteStyle(blend="alpha", intensity=2.0), light / 2.0 + seen * rgba[0, :3]),
        (SpriteStyle(blend="additive", intensity=2.0), seen * rgba[0, :3]),
    ]:
        got = layer.through(camera, position, rgba, style)
        np.testing.assert_allclose(got[0, :3], expected, rtol=tolerance)
        assert got[0, 3] == np.float32(rgba[0, 3])


def test_volumes_in_a_transparent_frame_cover_one_minus_their_transmittance():
    """Over nothing, the colour is premultiplied and alpha = 1 - (1 - alpha) T; over the
    background B, color + (1 - alpha) B is the frame drawn on B (float32 rounding)."""
    camera = mo.Camera((0, 0, 4), (0.2, 0, 0), fov=30, resolution=(32, 24))
    lights = [DirectionalLight((-1, -0.3, -0.5)), AmbientLight((0.2, 0.2, 0.2))]
    # one sample per pixel: a supersampled geometry edge is partly background, which a
    # transparent frame does not hold (its alpha is 1 wherever a sample hit geometry)
    renderer = mo.Renderer(camera, background=BACKGROUND, lights=lights, supersample=1)
    rgba = [[1, 0.3, 0.1, 0.5], [0.2, 0.8, 0.3, 0.8]]
    puff = particles([[0.1, 0.0, 0.0], [0.3, 0.1, -0.3]], rgba, radius=0.2)
    objects = [slab(albedo=0.8), geometry.Sphere((0.6, 0.0, -0.6), 0.3)]
    systems = [(puff, SpriteStyle(blend="alpha"))]
    over = renderer.render_hdr(systems, objects, transparent=True)
    drawn = renderer.render_hdr(systems, objects)
    assert over.alpha.min() < 0.5 < over.alpha.max()
    composite = over.color + (1 - over.alpha)[..., None] * np.array(BACKGROUND, np.float32)
    np.testing.assert_allclose(composite, drawn.color, atol=2e-6)


def test_opaque_casters_shadow_the_volume():
    """A sphere above the smoke, between it and a shadow-casting light: voxels straight
    under it get none of the light (its shadow map), voxels away from it all of it (the
    medium is unshadowed here)."""
    volume = slab(0.2, cells=4, extinction=5.0, shadows=False)
    ball = geometry.Sphere((0.0, 0.0, 1.0), 0.3)
    camera = mo.Camera((0, 0, 4), (0, 0, 0), resolution=(32, 24))
    shadowing = prepare([DirectionalLight((0, 0, -1), shadows=True)], [ball], camera)
    lit = light_volume(volume, shadowing)
    light = lit.grid[..., int(lit.medium[vol.LIGHTS_CH])]
    assert light[20, 20].max() < 0.01  # voxels around (0, 0) are in the shadow
    assert light[2, 2].min() == 1.0


def test_a_slab_shadows_the_ground_by_its_transmittance():
    """Seen from above, ground under a slab lit straight down by a shadow-casting light
    receives e^{-σd} of that light (the slab splatted into the opacity shadow map, whose
    blocks' profiles sum flat to 5 %): 0.2 + e^{-1} with the ambient, seen through the
    slab's own e^{-1} (exact); beside it, and under a slab that does not shadow itself
    (``shadows=False``), all of the light: 1.2."""
    camera = mo.Camera((0.0, 5.0, 0.0), (0.0, 0.0, 0.0), up=(0, 0, -1),
                       projection="orthographic", height=4.0, resolution=(40, 40))  # fmt: skip
    lights = [DirectionalLight((0, -1, 0), shadows=True), AmbientLight((0.2, 0.2, 0.2))]
    renderer = mo.Renderer(camera, background=(0, 0, 0), lights=lights, supersample=1)
    ground = geometry.Ground(0.0, color=(1.0, 1.0, 1.0))
    density = np.ones((10, 2, 10), np.float32)
    for shadows, expected, tolerance in [(True, 0.2 + math.exp(-1.0), 0.05), (False, 1.2, 1e-5)]:
        volume = Volume(density, cell_size=0.1, origin=(-0.5, 1.0, -0.5), extinction=5.0,
                        albedo=0.0, shadows=shadows)  # fmt: skip
        frame = renderer.render_hdr([], [ground, volume]).color[..., 0]
        assert frame[5, 5] == pytest.approx(1.2, rel=1e-5)
        under = frame[16:24, 16:24] / math.exp(-1.0)
        np.testing.assert_allclose(under, expected, rtol=tolerance)


# -- the blackbody ramp -------------------------------------------------------------------

#: Chromaticity (x, y) of the Planckian locus, CIE 1931 2° observer (Wyszecki & Stiles,
#: Color Science, table 1(3.11)).
PLANCKIAN = {1000: (0.6528, 0.3444), 1500: (0.5857, 0.3931), 2000: (0.5267, 0.4133),
             3000: (0.4369, 0.4041), 4000: (0.3805, 0.3768), 6500: (0.3135, 0.3236),
             10000: (0.2807, 0.2884)}  # fmt: skip


@pytest.mark.parametrize("kelvin", sorted(PLANCKIAN))
def test_the_blackbody_chromaticity_is_on_the_planckian_locus(kelvin):
    """Planck's law against the Wyman-Sloan-Shirley fit of the colour-matching functions:
    the fit's error (a few % in the far red, which dominates a 1000 K spectrum) moves
    the chromaticity by up to 0.012 at 1000 K and 0.005 from 1500 K up."""
    xyz = blackbody_xyz(float(kelvin))
    x, y = xyz[:2] / xyz.sum()
    tolerance = 0.012 if kelvin <= 1000 else 0.005
    assert abs(x - PLANCKIAN[kelvin][0]) < tolerance
    assert abs(y - PLANCKIAN[kelvin][1]) < tolerance


def test_the_blackbody_ramp_is_neutral_at_6500_k_red_hot_at_1500_k_and_monotone():
    """6500 K is near D65, sRGB's white: the channels within 7 % of each other; 1500 K is
    red-orange (no blue in gamut, green under a fifth of red); green/red and blue/red grow
    with temperature; luminance is 1 at the 1500 K reference (the clipped negative blue
    adds 0.2 %), rises steeply (Planck), and is 0 below Draper's point."""
    white = blackbody_rgb(6500.0)
    assert white.max() / white.min() < 1.07
    red = blackbody_rgb(1500.0)
    assert red[2] == 0.0 and 0 < red[1] < 0.2 * red[0]
    luminance = red @ [0.2126, 0.7152, 0.0722]
    assert abs(luminance - 1.0) < 0.01
    kelvin = np.arange(1000.0, 12000.0, 250.0)
    rgb = blackbody_rgb(kelvin)
    assert np.all(np.diff(rgb[:, 1] / rgb[:, 0]) > 0)
    assert np.all(np.diff(rgb[:, 2] / rgb[:, 0]) >= 0)
    assert np.all(np.diff(rgb @ [0.2126, 0.7152, 0.0722]) > 0)
    assert (blackbody_rgb([0.0, 300.0, 797.0]) == 0).all()
    assert 1e-7 < (blackbody_rgb(800.0) @ [0.2126, 0.7152, 0.0722]) < 1e-5


def test_the_kernels_blackbody_table_follows_the_function():
    """Linear interpolation every 4 K: within 0.3 % where the glow is visible (above
    1000 K), where ln B changes by under 10 % between entries."""
    table = vol.blackbody_table()
    kelvin = np.array([1001.0, 1333.0, 1777.7, 2500.5, 6502.0])
    u = kelvin / vol.TABLE_STEP_K
    e = u.astype(int)
    f = (u - e)[:, None]
    interpolated = table[e] * (1 - f) + table[e + 1] * f
    exact = blackbody_rgb(kelvin)
    np.testing.assert_allclose(interpolated, exact, rtol=3e-3, atol=1e-9)


# -- determinism and bad input -------------------------------------------------------------


def _scene_frame():
    volume, _ = _lit_scene()
    camera = mo.Camera((0.6, 0.5, 2.0), (0, 0, 0), fov=35, resolution=(40, 30))
    renderer = mo.Renderer(camera, background=BACKGROUND, lights=[
        DirectionalLight((-0.7, -0.5, -0.3), intensity=1.5),
        PointLight((0.8, 0.6, 0.9), intensity=2.0), AmbientLight((0.3, 0.3, 0.4))])  # fmt: skip
    puff = particles([[0.0, 0.0, 0.0], [0.1, 0.1, 0.3]], [[1, 0.5, 0.2, 0.6]] * 2, radius=0.1)
    return renderer.render_hdr([(puff, SpriteStyle(blend="alpha"))], [volume]).color


def test_the_same_scene_renders_the_same_bits_twice():
    np.testing.assert_array_equal(_scene_frame(), _scene_frame())


def test_one_and_two_threads_render_the_same_bits(tmp_path):
    """Rows and voxel rows are independent and each one serial: the image does not depend
    on the number of threads (each in a fresh process, as NUMBA_NUM_THREADS is read at
    start-up)."""
    source = str(Path(mo.__file__).resolve().parents[1])
    here = Path(__file__).resolve().parent
    root = str(here.parent)
    script = (
        "import sys, numpy as np; from test_volume_render import _scene_frame; "
        "np.save(sys.argv[1], _scene_frame())"
    )
    outputs = []
    for threads in (1, 2):
        path = tmp_path / f"frame{threads}.npy"
        env = dict(os.environ, NUMBA_NUM_THREADS=str(threads),
                   PYTHONPATH=os.pathsep.join([source, str(here), root]))  # fmt: skip
        result = subprocess.run([sys.executable, "-c", script, str(path)], env=env, cwd=root,
                                capture_output=True, text=True, check=False)  # fmt: skip
        assert result.returncode == 0, result.stderr[-3000:]
        outputs.append(np.load(path))
    np.testing.assert_array_equal(outputs[0], outputs[1])


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"density": np.ones((4, 4), np.float32)}, "density must have shape"),
        ({"density": np.full((3, 3, 3), np.nan, np.float32)}, "density must be finite"),
        ({"density": -np.ones((3, 3, 3), np.float32)}, "density must be >= 0"),
        ({"temperature": np.ones((3, 3, 2), np.float32)}, "temperature must have the density"),
        ({"temperature": np.full((3, 3, 3), np.inf, np.float32)}, "temperature must be finite"),
        ({"extinction": -1.0}, "extinction must be >= 0"),
        ({"cell_size": 0.0}, "cell_size must be > 0"),
        ({"albedo": (0.5, 1.2, 0.5)}, "albedo must be in"),
        ({"anisotropy": 1.0}, "anisotropy must be < 1"),
        ({"emission": -0.5}, "emission must be >= 0"),
        ({"emission": 1.0, "temperature": None}, "emission > 0 needs a temperature"),
        ({"step": 0.0}, "step must be >= 0.05"),
        ({"shadow_step": 9.0}, "shadow_step must be <= 8"),
        ({"origin": (0, 0)}, "origin must have shape"),
    ],
)
def test_bad_volume_parameters_are_refused_with_their_name(change, message):
    arguments = {"density": np.ones((3, 3, 3), np.float32), "cell_size": 0.1,
                 "temperature": np.full((3, 3, 3), 1000.0, np.float32)} | change  # fmt: skip
    with pytest.raises(ValueError, match=message):
        Volume(arguments.pop("density"), **arguments)


def test_grids_indexed_z_first_are_turned_to_x_first():
    """A grid fluid's (nz, ny, nx) fields give the same volume as their transposes."""
    rng = np.random.default_rng(9)
    density = rng.random((5, 4, 3)).astype(np.float32)
    temperature = rng.uniform(500, 2000, (5, 4, 3)).astype(np.float32)
    volume = Volume.from_zyx(density, temperature=temperature, cell_size=0.1, emission=1.0)
    np.testing.assert_array_equal(volume.density, density.transpose(2, 1, 0))
    np.testing.assert_array_equal(volume.temperature, temperature.transpose(2, 1, 0))
    with pytest.raises(ValueError, match="density must have shape"):
        Volume.from_zyx(np.ones((3, 3)), cell_size=0.1)


def test_the_module_examples_run():
    import doctest

    from motes.render import volume_blackbody

    for module in (vol, volume_blackbody):
        assert doctest.testmod(module).failed == 0


def test_flags_must_be_booleans():
    with pytest.raises(TypeError, match="shadows must be True or False"):
        Volume(np.ones((2, 2, 2)), cell_size=0.1, shadows=1)


def test_the_ambient_blur_matches_its_twin():
    """The column transmittances are box-filtered in each horizontal plane (sliding sums:
    float32 rounding over a few hundred additions, 1e-6)."""
    values = np.random.default_rng(3).random((20, 3, 17)).astype(np.float32)
    expected = naive.box_blur_xz(values, 4)
    scratch = np.empty_like(values)
    vl.blur_xz(values, 4, scratch)
    np.testing.assert_allclose(values, expected, atol=1e-6)
