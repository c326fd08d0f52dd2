"""The screen-space liquid (motes.render.water) and the foam potentials (motes.fluids.foam)."""

import math

import numba
import numpy as np
import pytest

import motes as mo
from motes.fluids.foam import foam, potentials
from motes.render.frame import Frame
from motes.render.water_kernels import EMPTY
from motes.state import Field, ParticleState

SIZE = 64
EXTENT = 1.0  # the orthographic view's height [m]: 64 px per metre


def top_down(size: int = SIZE) -> mo.Camera:
    """Orthographic camera at z = 5 looking down -z: view depth = 5 - z."""
    return mo.Camera(
        (0, 0, 5), (0, 0, 0), resolution=(size, size), projection="orthographic",
        height=EXTENT, near=0.1, far=50,
    )  # fmt: skip


def clear_water(positions, radius, **look) -> mo.Water:
    """Water that only absorbs: no reflection, highlight, scattering or refraction."""
    settings = dict(reflectance=0.0, specular=0.0, scatter=0.0, refraction=0.0)
    settings.update(look)
    return mo.Water(positions, radius, **settings)


def test_a_sphere_gives_its_chords_and_its_front():
    radius = 0.2
    water = clear_water([[0.0, 0.0, 0.0]], radius, iterations=0)
    surface, thickness, _, drawn = water.passes(Frame(SIZE, SIZE), top_down())
    assert drawn == 1
    ppm = SIZE / EXTENT
    centre = (np.arange(SIZE) + 0.5 - SIZE / 2) / ppm  # pixel centres [m]
    d2 = centre[:, None] ** 2 + centre[None, :] ** 2
    inside = d2 < radius**2
    chord = 2 * np.sqrt(np.maximum(radius**2 - d2, 0.0))
    np.testing.assert_allclose(thickness[inside], chord[inside], rtol=1e-4, atol=1e-6)
    assert (thickness[~inside] == 0).all()
    np.testing.assert_allclose(surface[inside], 5 - chord[inside] / 2, rtol=1e-5)
    assert (surface[~inside] == EMPTY).all()


def test_opaque_geometry_cuts_the_chords():
    """A wall through the sphere's centre keeps the liquid in front of it (half the
    chord) and hides none of its front; a wall in front of it hides it all."""
    radius = 0.2
    frame = Frame(SIZE, SIZE)
    frame.depth[:] = 5.0
    surface, thickness, _, _ = clear_water([[0.0, 0.0, 0.0]], radius, iterations=0).passes(
        frame, top_down()
    )
    middle = SIZE // 2
    offset = 0.5 * EXTENT / SIZE  # the pixel centre's distance from the axis, in x and y
    half = math.sqrt(radius**2 - 2 * offset**2)
    assert thickness[middle, middle] == pytest.approx(half, rel=1e-4)
    assert surface[middle, middle] == pytest.approx(5 - half, rel=1e-5)
    frame.depth[:] = 5.0 - 1.5 * radius  # a wall in front of the whole sphere
    surface, thickness, _, _ = clear_water([[0.0, 0.0, 0.0]], radius).passes(frame, top_down())
    assert (thickness == 0).all() and (surface == EMPTY).all()


def slab(depth: float, spacing: float, width: float = 0.8) -> np.ndarray:
    """A lattice of particles filling ``width`` x ``width`` x ``depth`` around z = 0."""
    side = np.arange(-width / 2, width / 2, spacing) + spacing / 2
    layers = np.arange(-depth / 2, depth / 2, spacing) + spacing / 2
    x, y, z = np.meshgrid(side, side, layers, indexing="ij")
    return np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)


def test_a_slab_transmits_exp_minus_sigma_times_its_depth():
    """Beer-Lambert: a white background seen through a lattice slab of depth L keeps
    ``exp(-sigma L)`` of each channel (sigma from the colour and clarity), within 3 %."""
    spacing, depth = 0.02, 0.3
    color, clarity = (0.5, 0.7, 0.9), 0.25
    water = clear_water(slab(depth, spacing), spacing, volume=spacing**3, color=color,
                        clarity=clarity)  # fmt: skip
    frame = Frame(SIZE, SIZE)
    frame.color[:] = 1.0
    thickness = water.passes(frame, top_down()).thickness
    middle = (slice(SIZE // 2 - 8, SIZE // 2 + 8),) * 2
    # The lattice's volume: its spheres' chords, scaled to s^3 a particle, sum to L.
    assert thickness[middle].mean() == pytest.approx(depth, rel=0.03)
    water.draw(frame, top_down(), background=mo.Background("#000000"))
    expected = np.exp(-water.absorption * depth)
    np.testing.assert_allclose(frame.color[middle].mean(axis=(0, 1)), expected, rtol=0.03)
    # and the flat face, smoothed, faces the camera: the pixel's own background
    assert water.absorption == pytest.approx(-np.log(color) / clarity)


def test_a_wide_smoothing_at_half_size_keeps_the_slab_flat_and_its_depth():
    """A smoothing sigma of 8 px (2.5 radii of 3.2 px): the smoothing runs at half size
    and is brought back; the slab's face stays flat (its normal faces the camera: the
    background shows unshifted) and its thickness and transmittance keep to 3 %."""
    spacing, depth = 0.02, 0.3
    camera = top_down(160)  # 160 px per metre: a particle's radius is 3.2 px
    water = clear_water(slab(depth, spacing, width=0.9), spacing, volume=spacing**3,
                        smoothing=2.5, refraction=0.5, color=(0.5, 0.7, 0.9),
                        clarity=0.25)  # fmt: skip
    frame = Frame(160, 160)
    frame.color[:] = ((np.arange(160) // 3) % 2)[None, :, None]  # stripes 3 px wide
    before = frame.color.copy()
    surface, thickness, _, _ = water.passes(frame, camera)
    middle = (slice(40, 120),) * 2
    assert thickness[middle].mean() == pytest.approx(depth, rel=0.03)
    flat = surface[middle]
    assert flat.max() - flat.min() < 0.1 * spacing
    water.draw(frame, camera, background=mo.Background("#000000"))
    shown = frame.color[middle] / np.exp(-water.absorption * depth)
    np.testing.assert_allclose(shown, before[middle], atol=0.05)


def test_fresnel_reflects_two_percent_face_on_and_most_at_a_grazing_angle():
    """Over black, under a red sky: what the flat top of a slab shows is the sky times
    Schlick's reflectance, 0.02 face on and far more seen at 80 degrees from the normal."""
    red = (1.0, 0.0, 0.0)
    water = clear_water(slab(0.2, 0.02, width=2.0), 0.02, volume=0.02**3, reflectance=0.02,
                        sky=(red, red), color=(0.01, 0.01, 0.01))  # fmt: skip
    # the slab's top faces +z; turn it so that it faces up (+y) as water does
    water.positions = water.positions[:, [0, 2, 1]]
    shown = {}
    for angle in (0.0, 80.0):
        a = math.radians(angle)
        eye = (0.0, 5 * math.cos(a), 5 * math.sin(a))
        camera = mo.Camera(eye, (0, 0, 0), up=(0, 0, -1) if angle == 0 else (0, 1, 0),
                           resolution=(SIZE, SIZE), fov=10)  # fmt: skip
        frame = Frame(SIZE, SIZE)
        water.draw(frame, camera, background=mo.Background("#000000"))
        middle = (slice(SIZE // 2 - 4, SIZE // 2 + 4),) * 2
        shown[angle] = float(frame.color[middle][..., 0].mean())
    assert shown[0.0] == pytest.approx(0.02, abs=0.004)
    schlick = 0.02 + 0.98 * (1 - math.cos(math.radians(80))) ** 5
    assert shown[80.0] == pytest.approx(schlick, rel=0.25)


def test_refraction_bends_what_lies_behind_a_curved_surface_only():
    """A drop over stripes: with refraction, its rim (tilted) shows other stripes, its
    centre (facing the eye) the same; outside it nothing changes."""
    block = slab(0.4, 0.02, width=0.4)
    drop = block[np.linalg.norm(block, axis=1) < 0.2]
    frames = {}
    for refraction in (0.0, 0.5):
        frame = Frame(SIZE, SIZE)
        frame.color[:] = ((np.arange(SIZE) // 4) % 2)[None, :, None]
        water = clear_water(drop, 0.02, volume=0.02**3, refraction=refraction,
                            color=(0.99, 0.99, 0.99))  # fmt: skip
        water.draw(frame, top_down(), background=mo.Background("#000000"))
        frames[refraction] = frame.color[..., 0]
    changed = np.abs(frames[0.5] - frames[0.0]) > 0.05
    assert changed.any()
    rows, cols = np.nonzero(changed)
    middle = SIZE // 2
    # only within the drop (0.44 m wide with its spheres: 14 px from the middle) and the
    # smoothing's reach past its outline (2 sigma: 8 px), and not at its centre
    assert np.abs(rows - middle).max() <= 22 and np.abs(cols - middle).max() <= 22
    assert not changed[middle - 2 : middle + 2, middle - 2 : middle + 2].any()


def test_the_liquid_hides_particles_behind_it():
    water = mo.Water(slab(0.2, 0.02, width=0.6), 0.02, volume=0.02**3, color=(0.02, 0.02, 0.02),
                     clarity=0.01)  # fmt: skip
    camera = top_down()
    behind = ParticleState(
        np.zeros(1, np.int64), np.array([[0.0], [0.0], [-1.0]]), np.zeros((3, 1)),
        np.array([0.1]), {"color": Field(np.ones((4, 1), np.float32), "1", "linear RGBA")},
    )  # fmt: skip
    renderer = mo.Renderer(camera, background="#000000", tonemap="clamp")
    alone = renderer.render_hdr([behind]).color
    covered = renderer.render_hdr([behind], [water]).color
    middle = SIZE // 2
    assert alone[middle, middle].max() > 0.5
    assert covered[middle, middle].max() < 0.05  # dark water, opaque at this depth


def test_the_thread_count_does_not_change_the_bits():
    positions = np.random.default_rng(3).uniform(-0.3, 0.3, (2000, 3))
    camera = mo.Camera((0.3, 0.8, 1.5), (0, 0, 0), resolution=(96, 64))
    images = []
    for threads in (1, 2):
        numba.set_num_threads(threads)
        try:
            frame = Frame(96, 64)
            frame.color[:] = 0.3
            mo.Water(positions, 0.04).draw(frame, camera)
            images.append(frame.color)
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert np.array_equal(images[0], images[1])


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (dict(radius=0.0), "radius must be > 0"),
        (dict(color=(0.5, 0.0, 0.5)), "color must have each channel in (0, 1]"),
        (dict(clarity=-1.0), "clarity must be > 0"),
        (dict(iterations=9), "iterations must be <= 8"),
        (dict(scatter=2.0), "scatter must be <= 1"),
        (dict(sky=("#ffffff",)), "sky must be (zenith, horizon) colours"),
        (dict(positions=[[0.0, np.nan, 0.0]]), "positions must be finite"),
        (dict(positions=[0.0, 1.0]), "positions must have shape (n, 3)"),
    ],
)
def test_bad_values_are_named(options, message):
    settings = dict(positions=[[0.0, 0.0, 0.0]], radius=0.1)
    settings.update(options)
    with pytest.raises(ValueError) as caught:
        mo.Water(settings.pop("positions"), settings.pop("radius"), **settings)
    assert message in str(caught.value)


def test_trapped_air_counts_particles_meeting_not_parting():
    h = 0.1
    x = np.array([[0.0, 0.05], [0.0, 0.0], [0.0, 0.0]])
    meeting = np.array([[1.0, -1.0], [0.0, 0.0], [0.0, 0.0]])
    trapped, _, kinetic = potentials(x, meeting, h)
    # |v_ij| = 2, head on (1 - cos = 2), W = 1 - 0.05 / 0.1 = 0.5
    np.testing.assert_allclose(trapped, [2.0, 2.0], rtol=1e-5)
    np.testing.assert_allclose(kinetic, [0.5, 0.5])
    trapped, _, _ = potentials(x, -meeting, h)
    np.testing.assert_allclose(trapped, [0.0, 0.0], atol=1e-6)


def test_liquid_at_rest_has_no_foam_and_the_rim_of_a_rising_face_has_crests():
    block = slab(0.2, 0.02, width=0.2).T
    still = foam(block, np.zeros_like(block), 0.05)
    assert (still == 0).all()
    rising = np.zeros_like(block)
    rising[2] = 3.0  # the block thrown along +z: its top face moves out along its normal
    crest = potentials(block, rising, 0.05)[1]
    top = block[2] > block[2].max() - 0.01
    across = np.abs(block[:2]).max(axis=0)
    rim, centre = top & (across > 0.08), top & (across < 0.03)
    # the rim of the face is convex, its centre flat; the bottom moves into the liquid
    assert crest[rim].mean() > 2.5 * crest[centre].mean()
    assert (crest[block[2] < 0] == 0).all()
    froth = foam(block, rising, 0.05)
    assert froth[rim].mean() > 2 * froth[centre].mean() and froth[rim].mean() > 0.1
