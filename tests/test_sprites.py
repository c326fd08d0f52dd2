"""The particle rasteriser: kernels against their NumPy twins, energy, order, soft particles.

Tolerances: the kernels project in float64, then round screen positions, radii and
depths to float32 and weigh and blend in float32; the twins (``naive_render``) work in
float64 throughout. A float32 position near x = 64 px is off by up to 4e-6 px, which
moves a weight of slope <= 2 / px by < 1e-5; colours are O(1) and a pixel sums a few
dozen fragments, each rounded to 6e-8 relative. So images agree to 2e-5 absolute.
"""

import math

import numba
import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import naive_render as naive
from motes.render.camera import Camera
from motes.render.frame import Frame
from motes.render.sprites import SpriteRasterizer, SpriteStyle, draw_particles

W, H = 64, 48
ATOL = 2e-5


def camera(**options) -> Camera:
    return Camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), resolution=(W, H), **options)


def cloud(rng, n=40):
    """Particles of every size class, some crossing the image edges, some culled.

    At 5 m a metre is 11.6 px, so radii of 0.01-0.2 m are 0.1-2.3 px (below the minimum
    footprint, the 3, 4 and 6 px windows) and 0.4-3 m are 5-35 px (the general path, and
    sprites larger than the fast path's reach). Two particles lie behind the camera and
    beyond the far plane.
    """
    positions = rng.uniform([-3.2, -2.4, -1.0], [3.2, 2.4, 1.0], (n, 3))
    positions[:2] = [[0.0, 0.0, 6.0], [0.0, 0.0, -2000.0]]
    radii = np.where(rng.random(n) < 0.75, rng.uniform(0.01, 0.2, n), rng.uniform(0.4, 3.0, n))
    colors = rng.uniform(0.0, 1.0, (n, 4))
    return positions, colors, radii, rng.uniform(-np.pi, np.pi, n), rng.normal(0, 4, (n, 3))


def scene_depth():
    """Opaque geometry at 5.3 m over the right half, nothing (inf) elsewhere."""
    depth = np.full((H, W), np.inf, np.float32)
    depth[:, W // 2 :] = 5.3
    return depth


def draw_both(style_options, rng, *, texture=None, n=40, lens=None):
    """The kernels' image and the twin's, from the same particles and frame (``lens``:
    the camera's options)."""
    positions, colors, radii, rotation, velocities = cloud(rng, n)
    frame = Frame(W, H)
    frame.color[:] = 0.1
    frame.depth[:] = scene_depth()
    style = SpriteStyle(texture=texture, **style_options)
    view = camera(**(lens or {}))
    draw_particles(
        frame, view, positions, colors, radii, style=style, rotation=rotation,
        velocities=velocities,
    )  # fmt: skip
    expected = naive.draw(
        np.full((H, W, 3), 0.1), scene_depth(), view, positions, colors, radii,
        texture=texture, rotation=rotation, velocities=velocities, **style_options,
    )  # fmt: skip
    return frame.color, expected


MODES = {
    "point additive": {"kind": "point"},
    "point alpha": {"kind": "point", "blend": "alpha"},
    "smooth additive": {},
    "smooth alpha": {"blend": "alpha"},
    "disc additive": {"falloff": "disc", "intensity": 2.5},
    "disc alpha": {"falloff": "disc", "blend": "alpha"},
    "point streak": {"kind": "point", "shutter": 0.04},
    "smooth streak": {"shutter": 0.04},
    "disc streak alpha": {"falloff": "disc", "shutter": 0.04, "blend": "alpha"},
    "soft additive": {"softness": 0.4},
    "soft alpha streak": {"softness": 0.4, "blend": "alpha", "shutter": 0.04},
}


#: Each mode compiles kernels of its own: the default tier keeps one per feature (point,
#: smooth, disc, additive, alpha, streak, soft); the others run in the slow tier.
SLOW_MODES = {
    "point alpha", "disc alpha", "point streak", "disc streak alpha", "soft additive",
    "disc additive", "smooth streak", "point additive",
}  # fmt: skip


@pytest.mark.parametrize(
    "options",
    [
        pytest.param(o, id=k, marks=[pytest.mark.slow] if k in SLOW_MODES else [])
        for k, o in MODES.items()
    ],
)
def test_kernels_match_the_naive_twin(rng, options):
    got, expected = draw_both(options, rng)
    assert np.abs(expected - 0.1).max() > 0.1  # something was drawn
    assert_allclose(got, expected, rtol=0, atol=ATOL)


def test_sprites_through_an_orthographic_camera_match_the_naive_twin(rng):
    got, expected = draw_both({}, rng, n=200, lens={"projection": "orthographic", "height": 5.0})
    assert np.abs(expected - 0.1).max() > 0.1
    assert_allclose(got, expected, rtol=0, atol=ATOL)


@pytest.mark.parametrize("blend", ["additive", "alpha"])
def test_textured_rotated_sprites_match_the_naive_twin(rng, blend):
    texture = rng.uniform(0.0, 1.0, (5, 7, 4)).astype(np.float32)
    got, expected = draw_both({"blend": blend, "softness": 0.2}, rng, texture=texture)
    assert_allclose(got, expected, rtol=0, atol=ATOL)


def one_particle(style, position=(0.0, 0.0, 0.0), radius=0.1, color=(1.0, 0.5, 0.25, 0.8), **kw):
    frame = Frame(W, H)
    drawn = draw_particles(frame, camera(), [position], [color], [radius], style=style, **kw)
    return frame, drawn


def pixel_radius(radius, depth=5.0):
    return radius * float(camera().pixels_per_metre(depth))


@pytest.mark.parametrize("offset", [(0.0, 0.0), (0.013, -0.021), (0.043, 0.043)])
def test_a_point_deposits_its_colour_times_alpha_times_intensity(offset):
    style = SpriteStyle("point", intensity=3.0)
    frame, drawn = one_particle(style, (offset[0], offset[1], 0.0))
    assert drawn == 1
    assert np.count_nonzero(frame.color[..., 0]) <= 4  # the bilinear tent's 2 x 2 pixels
    # Four tent weights summing to 1, each product rounded once: float32 round-off.
    assert_allclose(frame.color.sum(axis=(0, 1)), 3.0 * 0.8 * np.array([1.0, 0.5, 0.25]), rtol=1e-6)


@pytest.mark.parametrize("falloff", ["smooth", "disc"])
@pytest.mark.parametrize("radius", [0.02, 0.09, 0.13, 0.22, 0.4, 1.75])
def test_a_sprite_deposits_its_footprint_area(falloff, radius):
    """Energy = the unit-peak profile's area at the true radius, below the minimum too.

    The radii are 0.23 px (spread over the minimum footprint), 1, 1.5 and 2.5 px (the
    fast path's 3, 4 and 6 px windows), 4.6 px (its general loop) and 20 px (the general
    tile path, with the analytic normalisation of boxes over 1024 px², exact to 3e-4),
    all inside the frame.
    """
    style = SpriteStyle(falloff=falloff)
    frame, _ = one_particle(style, (0.011, 0.007, 0.0), radius)
    r = pixel_radius(radius)
    assert_allclose(style.footprint_area(r), math.pi * (r * r + (falloff == "disc") / 12) / (
        3 if falloff == "smooth" else 1
    ))  # fmt: skip
    reach = r + 0.5 if falloff == "disc" else r
    exact = (2 * reach) ** 2 <= 1024
    energy = frame.color.sum(axis=(0, 1)) / (0.8 * np.array([1.0, 0.5, 0.25]))
    assert_allclose(energy, style.footprint_area(r), rtol=2e-6 if exact else 3e-4)


def test_a_textured_sprite_deposits_four_r_squared_times_the_mean_alpha(rng):
    texture = rng.uniform(0.0, 1.0, (6, 4, 4)).astype(np.float32)
    texture[..., :3] = 1.0  # white: the colour is the particle's
    style = SpriteStyle(texture=texture)
    frame, _ = one_particle(style, radius=0.3, rotation=[0.7])
    r = pixel_radius(0.3)
    assert_allclose(style.footprint_area(r), 4 * r * r * texture[..., 3].mean(), rtol=1e-6)
    energy = frame.color.sum(axis=(0, 1)) / (0.8 * np.array([1.0, 0.5, 0.25]))
    assert_allclose(energy, style.footprint_area(r), rtol=1e-5)


@pytest.mark.parametrize(("kind", "radius"), [("point", 0.1), ("sprite", 0.03), ("sprite", 0.15)])
def test_a_streak_deposits_the_energy_of_the_still_particle(kind, radius):
    still, _ = one_particle(SpriteStyle(kind), radius=radius)
    moving, _ = one_particle(
        SpriteStyle(kind, shutter=0.1), radius=radius, velocities=[[14.0, 6.0, 3.0]]
    )
    # Drawn along a 16 px streak, not on the spot: the light moved, its total did not.
    assert np.count_nonzero(moving.color[..., 0]) > 3 * np.count_nonzero(still.color[..., 0])
    assert_allclose(moving.color.sum(axis=(0, 1)), still.color.sum(axis=(0, 1)), rtol=2e-6)


def test_a_streak_in_alpha_over_is_as_opaque_in_total_as_the_still_sprite():
    """Opacity along the streak is scaled by still area / streak area."""
    black = (0.0, 0.0, 0.0, 0.5)
    covered = []
    for shutter, velocity in ((0.0, None), (0.1, [[14.0, 0.0, 0.0]])):
        frame = Frame(W, H)
        frame.color[:] = 1.0
        style = SpriteStyle(blend="alpha", shutter=shutter)
        velocities = None if velocity is None else velocity
        draw_particles(frame, camera(), [[0, 0, 0]], [black], [0.2], style=style,
                       velocities=velocities)  # fmt: skip
        covered.append(float((1.0 - frame.color[..., 0]).sum()))  # Σ alpha over pixels
    # Each pixel is composited once, so Σ a is exactly alpha x the still area.
    assert_allclose(covered[1], covered[0], rtol=1e-5)


@pytest.mark.parametrize("falloff", ["smooth", "disc"])
def test_alpha_over_shows_the_near_sprite_whatever_the_input_order(falloff):
    red, green = (1.0, 0.0, 0.0, 1.0), (0.0, 1.0, 0.0, 1.0)
    near, far = (0.0, 0.0, 1.0), (0.05, 0.02, -1.0)
    style = SpriteStyle(blend="alpha", falloff=falloff)
    images = []
    for order in ((0, 1), (1, 0)):
        frame = Frame(W, H)
        positions = np.array([near, far])[list(order)]
        colors = np.array([red, green])[list(order)]
        radii = np.array([0.8, 2.4])[list(order)]  # 11.6 and 23 px
        draw_particles(frame, camera(), positions, colors, radii, style=style)
        images.append(frame.color)
    assert_array_equal(images[0], images[1])
    # The pixel next to the centre (0.7 px away): opacity 1 for the disc, (1 - 0.5 /
    # 11.6²)² = 0.993 for the smooth profile, up to the normalisation's sampling error.
    centre = images[0][H // 2, W // 2]
    assert centre[0] > 0.99 and centre[1] < 0.01
    # The far green sprite shows around the red one (the smooth profile is 0.53 at 12 px).
    assert images[0][..., 1].max() > 0.5


class TestSoftParticles:
    """A still particle over a flat opaque surface at depth D = 5.5 m: the three cases."""

    D, S = 5.5, 0.4

    def draw(self, z, softness, blend="additive", surface=D):
        frame = Frame(W, H)
        frame.depth[:] = surface
        draw_particles(frame, camera(), [[0.0, 0.0, z]], [[1.0, 0.6, 0.3, 1.0]], [0.3],
                       style=SpriteStyle(softness=softness, blend=blend))  # fmt: skip
        return frame.color

    def test_far_in_front_it_is_unchanged(self):
        # Depth 5 m: D - d = 0.5 m > s.
        for blend in ("additive", "alpha"):
            unoccluded = self.draw(0.0, self.S, blend, surface=np.inf)
            assert_array_equal(self.draw(0.0, self.S, blend), unoccluded)

    def test_near_the_surface_it_fades_by_the_distance_over_the_softness(self):
        # Depth 5.4 m: D - d = 0.1 m = s / 4, the same for every fragment of a still sprite.
        near = self.draw(-0.4, self.S)
        unfaded = self.draw(-0.4, self.S, surface=np.inf)
        assert near.max() > 0
        assert_allclose(near, 0.25 * unfaded, rtol=1e-5, atol=1e-7)

    def test_behind_the_surface_it_is_hidden(self):
        for softness in (self.S, 0.0):
            for blend in ("additive", "alpha"):
                assert not self.draw(-0.6, softness, blend).any()  # depth 5.6 m > D

    def test_a_hard_test_draws_whatever_is_in_front_unchanged(self):
        in_front = self.draw(-0.4, 0.0)  # depth 5.4 m < D
        assert in_front.max() > 0
        assert_array_equal(in_front, self.draw(-0.4, 0.0, surface=np.inf))


def test_particles_outside_the_depth_range_are_culled():
    cam = Camera((0, 0, 5), (0, 0, 0), resolution=(W, H), near=1.0, far=8.0)
    frame = Frame(W, H)
    positions = [[0, 0, 4.5], [0, 0, -3.5], [0, 0, 0], [30, 0, 0]]  # near, far, in, off-image
    drawn = draw_particles(frame, cam, positions, np.ones((4, 4)), [0.1] * 4)
    assert drawn == 1


def test_a_rotated_texture_turns_counter_clockwise_on_screen():
    texture = np.zeros((8, 8, 4), np.float32)
    texture[:4, 4:] = 1.0  # the top-right quadrant is opaque white
    style = SpriteStyle(texture=texture)
    quadrant_sums = []
    for angle in (0.0, np.pi / 2):
        frame, _ = one_particle(style, radius=1.0, color=(1, 1, 1, 1), rotation=[angle])
        c = frame.color[..., 0]
        quadrant_sums.append(
            {
                "top-right": c[: H // 2, W // 2 :].sum(),
                "top-left": c[: H // 2, : W // 2].sum(),
            }
        )
    # Bilinear lookups blur the quadrant's edge over one texel (1/8 of the sprite), which
    # spills a few per cent of it across the centre line.
    assert quadrant_sums[0]["top-left"] < 0.03 * quadrant_sums[0]["top-right"]
    # A quarter turn counter-clockwise takes the top-right quadrant to the top left.
    assert quadrant_sums[1]["top-right"] < 0.03 * quadrant_sums[1]["top-left"]


def _busy_scene(rng, n=30_000):
    positions = rng.uniform([-6, -4, -3], [6, 4, 3], (n, 3))
    radii = np.where(rng.random(n) < 0.9, rng.uniform(0.005, 0.05, n), rng.uniform(0.1, 1.5, n))
    return positions, rng.uniform(0, 1, (n, 4)), radii, rng.normal(0, 3, (n, 3))


@pytest.mark.parametrize(
    "options", [{}, {"blend": "alpha", "softness": 0.3}, {"kind": "point", "shutter": 0.03}]
)
def test_images_do_not_depend_on_the_thread_count(rng, options):
    # 30k particles: above the one-thread threshold, over 48 tiles of a 256 x 160 frame.
    positions, colors, radii, velocities = _busy_scene(rng)
    cam = Camera((0, 0, 10), (0, 0, 0), resolution=(256, 160))
    rasterizer = SpriteRasterizer(SpriteStyle(**options))
    images = []
    threads = numba.get_num_threads()
    try:
        for count in (1, 2, 2):
            numba.set_num_threads(min(count, numba.config.NUMBA_NUM_THREADS))
            frame = Frame(256, 160)
            frame.depth[40:100] = 9.5
            rasterizer.draw(frame, cam, positions, colors, radii, velocities=velocities)
            images.append(frame.color)
    finally:
        numba.set_num_threads(threads)
    assert images[0].max() > 0
    assert_array_equal(images[0], images[1])
    assert_array_equal(images[1], images[2])


def test_reused_rasterizer_buffers_give_the_same_image(rng):
    positions, colors, radii, _ = _busy_scene(rng, 2_000)
    rasterizer = SpriteRasterizer()
    big = _busy_scene(rng, 5_000)
    rasterizer.draw(Frame(W, H), camera(), *big[:3])  # grows the buffers
    first, second = Frame(W, H), Frame(W, H)
    rasterizer.draw(first, camera(), positions, colors, radii)
    SpriteRasterizer().draw(second, camera(), positions, colors, radii)
    assert_array_equal(first.color, second.color)


def test_store_views_and_float64_inputs_draw_like_contiguous_float32(rng):
    positions, colors, radii, _ = _busy_scene(rng, 500)
    rows = np.ascontiguousarray(positions.T, dtype=np.float32)  # (3, n), as a store keeps them
    a, b = Frame(W, H), Frame(W, H)
    draw_particles(a, camera(), rows.T, colors, radii)
    draw_particles(b, camera(), positions.astype(np.float32), colors.astype(np.float32), radii)
    assert_array_equal(a.color, b.color)


def test_empty_input_draws_nothing():
    frame = Frame(W, H)
    assert draw_particles(frame, camera(), np.zeros((0, 3)), np.zeros((0, 4)), np.zeros(0)) == 0
    assert not frame.color.any()


class TestBadInput:
    def call(self, **changes):
        args = {
            "frame": Frame(W, H),
            "camera": camera(),
            "positions": np.zeros((3, 3)),
            "colors": np.ones((3, 4)),
            "radii": np.full(3, 0.1),
        }
        args |= changes
        style = args.pop("style", None)
        extra = {k: args.pop(k) for k in ("rotation", "velocities") if k in args}
        return draw_particles(*args.values(), style=style, **extra)

    @pytest.mark.parametrize(
        ("changes", "message"),
        [
            ({"positions": np.zeros((3, 2))}, r"positions must have shape \(n, 3\)"),
            ({"colors": np.ones((3, 3))}, r"colors must have shape \(3, 4\)"),
            ({"radii": np.ones(4)}, r"radii must have shape \(3,\)"),
            ({"radii": None}, "radii are required for sprites"),
            ({"positions": [[0, 0, 0], [0, np.nan, 0], [0, 0, 0]]}, "positions must be finite"),
            ({"colors": [[1, 1, 1, 1], [1, 1, np.inf, 1], [1, 1, 1, 1]]}, "colors must be"),
            ({"radii": [0.1, -0.1, 0.1]}, "radii must be >= 0"),
            ({"radii": [0.1, np.nan, 0.1]}, "radii must be finite"),
            ({"style": SpriteStyle(shutter=0.1)}, "velocities are required"),
            (
                {"style": SpriteStyle(shutter=0.1), "velocities": np.full((3, 3), np.nan)},
                "velocities must be finite",
            ),
            (
                {"style": SpriteStyle(texture=np.ones((2, 2, 4))), "rotation": [0, np.inf, 0]},
                "rotation must be finite",
            ),
            ({"camera": camera().with_resolution((32, 32))}, "must match the frame"),
            ({"positions": "abc"}, "positions must be an array of numbers"),
        ],
    )
    def test_clear_errors(self, changes, message):
        with pytest.raises((ValueError, TypeError), match=message):
            self.call(**changes)

    def test_nothing_is_drawn_when_an_input_is_bad(self):
        frame = Frame(W, H)
        with pytest.raises(ValueError, match="positions must be finite"):
            self.call(frame=frame, positions=[[0, 0, 0], [0, 0, 0], [np.nan, 0, 0]])
        assert not frame.color.any()

    @pytest.mark.parametrize("layout", ["c", "state rows", "strided", "read-only"])
    @pytest.mark.parametrize(("field", "column"), [("positions", 2), ("colors", 3), ("radii", 0)])
    def test_a_bad_value_is_found_in_every_layout(self, layout, field, column):
        """The finiteness test reads contiguous columns, whole C arrays, or a copy: a NaN
        in the last particle's last column is found in each, and good arrays of every
        layout draw the same image."""
        rng = np.random.default_rng(5)
        n = 40_000  # three of the projection's chunks
        good = {
            "positions": rng.uniform(-1, 1, (n, 3)),
            "colors": rng.uniform(0, 1, (n, 4)),
            "radii": rng.uniform(0.01, 0.1, n),
        }

        def laid_out(array):
            array = np.asarray(array, np.float32)
            if layout == "state rows":  # (c, capacity) rows, the first n columns, transposed
                rows = np.zeros((*array.shape[1:], n + 7), np.float32).reshape(-1, n + 7)
                rows[:, :n] = array.reshape(n, -1).T
                return rows[:, :n].T.reshape(array.shape)
            if layout == "strided":
                spread = np.zeros((2 * n, *array.shape[1:]), np.float32)
                spread[::2] = array
                return spread[::2]
            if layout == "read-only":
                array.flags.writeable = False
            return array

        for bad in (False, True):
            arrays = dict(good)
            if bad:
                arrays[field] = arrays[field].copy()
                arrays[field][(-1, column) if arrays[field].ndim == 2 else -1] = np.nan
            frame = Frame(W, H)
            call = {name: laid_out(a) for name, a in arrays.items()}
            if bad:
                with pytest.raises(ValueError, match=f"{field} must be finite"):
                    self.call(frame=frame, **call)
            else:
                self.call(frame=frame, **call)
                plain = Frame(W, H)
                self.call(frame=plain, **{k: np.asarray(a, np.float32) for k, a in good.items()})
                assert_array_equal(frame.color, plain.color)

    def test_frame_and_camera_types(self):
        with pytest.raises(TypeError, match="frame must be a Frame"):
            self.call(frame=np.zeros((H, W, 3)))
        with pytest.raises(TypeError, match="camera must be a Camera"):
            self.call(camera="camera")

    @pytest.mark.parametrize(
        ("options", "error", "message"),
        [
            ({"kind": "blob"}, ValueError, "kind must be one of 'point', 'sprite'"),
            ({"falloff": "hard"}, ValueError, "falloff must be one of"),
            ({"blend": "multiply"}, ValueError, "blend must be one of 'additive', 'alpha'"),
            ({"softness": -1.0}, ValueError, "softness must be >= 0"),
            ({"shutter": float("nan")}, ValueError, "shutter must be finite"),
            ({"intensity": "2"}, TypeError, "intensity must be a real number"),
            ({"texture": np.ones((4, 4, 3))}, ValueError, r"texture must have shape \(th, tw, 4\)"),
            ({"texture": -np.ones((4, 4, 4))}, ValueError, "texture values must be finite"),
            ({"kind": "point", "texture": np.ones((2, 2, 4))}, ValueError, "texture needs"),
            ({"shutter": 0.1, "texture": np.ones((2, 2, 4))}, ValueError, "no textured streaks"),
        ],
    )
    def test_style_rejects_bad_options(self, options, error, message):
        with pytest.raises(error, match=message):
            SpriteStyle(**options)

    def test_rasterizer_needs_a_style(self):
        with pytest.raises(TypeError, match="style must be a SpriteStyle"):
            SpriteRasterizer("additive")


def test_style_is_immutable_and_keeps_a_read_only_texture_copy():
    texture = np.ones((2, 2, 4))
    style = SpriteStyle(texture=texture)
    texture[:] = 0
    assert style.texture.min() == 1.0 and style.texture.dtype == np.float32
    with pytest.raises(ValueError, match="read-only"):
        style.texture[0, 0, 0] = 2.0
    with pytest.raises(AttributeError):
        style.softness = 1.0


def test_docstring_examples_run():
    import doctest

    import motes.render.sprites

    assert doctest.testmod(motes.render.sprites).failed == 0
