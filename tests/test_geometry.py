"""Opaque geometry: rasteriser against ray casting, analytic coverage, depth and shading."""

import math

import numba
import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import motes as mo
import naive_geometry as naive
from motes.geometry import TriangleMesh
from motes.render.frame import Frame
from motes.render.geometry import Box, Ground, Lines, Mesh, Sphere, draw_geometry, icosphere
from motes.render.shading import AmbientLight, DirectionalLight, Material

W, H = 48, 32
# Ambient light of 1 from every direction and no directional light: every surface shows
# exactly its albedo, so colours identify what was drawn.
FLAT_WHITE = [AmbientLight((1.0, 1.0, 1.0))]
# Float32 storage of depth [m] and colour: 2^-24 relative, with room for the kernel and
# the ray caster computing the same quantity by different formulas in float64.
RTOL32 = 1e-6


def perspective(**options):
    return mo.Camera((0.3, 0.2, 4.0), (0.0, 0.0, 0.0), fov=50, resolution=(W, H), **options)


def orthographic(**options):
    # 8 px per metre.
    return mo.Camera(
        (0, 0, 5), (0, 0, 0), projection="orthographic", height=4.0, resolution=(W, H), **options
    )


def triangle_soup(corners, colors):
    """A Mesh of separate triangles, each with its own corner colours."""
    corners = np.asarray(corners, dtype=np.float64)
    mesh = TriangleMesh(corners.reshape(-1, 3), np.arange(3 * len(corners)).reshape(-1, 3))
    return Mesh(mesh, vertex_colors=np.asarray(colors).reshape(-1, 3), smooth=False)


def draw(camera, objects, *, lights=FLAT_WHITE, supersample=1, frame=None):
    frame = Frame(*camera.resolution) if frame is None else frame
    draw_geometry(frame, camera, objects, lights=lights, supersample=supersample)
    return frame


# --- against the ray caster ---------------------------------------------------------------


@pytest.mark.parametrize("camera", [perspective(), orthographic()], ids=["perspective", "ortho"])
def test_triangles_match_ray_casting(camera, rng):
    corners = rng.uniform(-1.6, 1.6, (6, 3, 3))
    corners[:, :, 2] *= 0.6
    # One triangle reaches behind the camera (perspective: through the near plane).
    corners[0] = [[-0.5, -0.6, 0.0], [0.8, -0.4, 0.5], [0.1, 0.3, 6.0]]
    colors = rng.uniform(0.1, 1.0, (6, 3, 3))
    frame = draw(camera, [triangle_soup(corners, colors)])

    depth, index, bary = naive.ray_cast(camera, corners)
    covered = np.isfinite(depth)
    assert 100 < covered.sum() < W * H  # a meaningful mix of covered and empty pixels
    # Coverage decides on the sign of an edge function; ray casting on the sign of a
    # barycentric from another formula. They can disagree only for a sample within
    # ~1e-12 px of an edge, which random corners do not produce.
    assert_array_equal(np.isfinite(frame.depth), covered)
    assert_allclose(frame.depth[covered], depth[covered], rtol=RTOL32)
    # Perspective-correct interpolation: the ray's own barycentrics weight the corners.
    expected = np.einsum("pk,pkc->pc", bary[covered], colors[index[covered]])
    assert_allclose(frame.color[covered], expected, rtol=1e-5, atol=1e-6)
    assert_array_equal(frame.color[~covered], 0.0)


def test_lines_match_naive_twin(rng):
    camera = perspective()
    points = rng.uniform(-1.5, 1.5, (8, 3))
    points[0] = [0.2, -0.3, 5.0]  # the first segment crosses the near plane
    segments = np.array([[0, 1], [1, 2], [3, 4], [5, 6], [6, 7], [2, 5]])
    point_colors = rng.uniform(0, 1, (8, 3))
    widths = np.array([0.6, 1.0, 2.5, 4.0, 1.5, 3.0])
    box = Box((0.0, 0.0, -0.5), (0.8, 0.8, 0.8), color=(0.2, 0.3, 0.4))
    lines = Lines(points, segments, point_colors=point_colors, width=widths)
    tris = box.triangles(camera)
    for ss in (1, 2):
        frame = draw(camera, [box, lines], supersample=ss)
        # Samples of the box by ray casting (flat white light: its albedo), lines over them.
        depth, index, _ = naive.ray_cast(camera, tris.positions[tris.faces], ss)
        # Depth buffered in float32 like the kernel's: where segments meet at a polyline
        # joint their depths tie, and the rounding decides whether the second one draws.
        depth = depth.astype(np.float32)
        sample_color = np.where(index[..., None] >= 0, box.color, 0.0)
        drawn = naive.draw_lines(
            camera, points[segments], point_colors[segments], widths, sample_color, depth, ss
        )
        expected = Frame(W, H)
        naive.resolve(sample_color, depth, drawn | (index >= 0), expected.color, expected.depth, ss)
        assert drawn.sum() > 100 * ss * ss
        assert_allclose(frame.color, expected.color, rtol=1e-5, atol=1e-6)
        assert_allclose(frame.depth, expected.depth, rtol=RTOL32)


def test_line_strips_join_consecutive_points():
    a = np.zeros((3, 3))
    b = np.ones((2, 3))
    lines = Lines.strips([a, b], color=[[1, 0, 0], [0, 1, 0]], width=2.0)
    assert_array_equal(lines.segments, [[0, 1], [1, 2], [3, 4]])
    assert_array_equal(lines.colors[:, 0], [[1, 0, 0], [1, 0, 0], [0, 1, 0]])
    assert_array_equal(lines.colors[:, 1], lines.colors[:, 0])
    assert_array_equal(lines.width, [2.0, 2.0, 2.0])


# --- analytic coverage and depth ----------------------------------------------------------


@pytest.mark.parametrize(
    "shape",
    [
        Sphere((1, 2, 3), 0.7, subdivisions=2),
        Box((1, 2, 3), (0.5, 1.0, 2.0), rotation=np.eye(3)[[1, 2, 0]]),
    ],
    ids=["sphere", "box"],
)
def test_closed_shapes_wind_counter_clockwise_outward(shape):
    tris = shape.triangles(perspective())
    p = tris.positions[tris.faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    outward = np.einsum("ij,ij->i", normal, p.mean(axis=1) - [1, 2, 3])
    assert np.all(outward > 0)


def lattice_count(cx, cy, radius):
    """Pixel centres (col + 1/2, row + 1/2) strictly inside a disc of the image."""
    y, x = np.mgrid[0:H, 0:W] + 0.5
    return int(((x - cx) ** 2 + (y - cy) ** 2 < radius**2).sum())


def test_sphere_covers_its_disc_and_has_the_right_depth():
    camera = orthographic()
    r = 1.5  # 12 px
    frame = draw(camera, [Sphere((0, 0, 0), r, subdivisions=3)])
    unit, faces = icosphere(3)
    # The icosphere is inscribed: it contains the sphere of radius r_in (its nearest face
    # plane) and lies inside the sphere of radius r, so its orthographic silhouette lies
    # between discs of 8 r_in and 8 r px.
    a, b, c = unit[faces[:, 0]], unit[faces[:, 1]], unit[faces[:, 2]]
    n = np.cross(b - a, c - a)
    r_in = r * np.min(np.abs(np.einsum("ij,ij->i", a, n)) / np.linalg.norm(n, axis=1))
    assert 0.995 * r < r_in < r
    covered = int(np.isfinite(frame.depth).sum())
    assert lattice_count(24, 16, 8 * r_in) <= covered <= lattice_count(24, 16, 8 * r)
    assert covered == pytest.approx(math.pi * (8 * r) ** 2, rel=0.03)  # π r² px² (lattice)
    # Centre pixel (row 15, col 23): its centre is ρ = √2/16 m off the axis, and the
    # surface there lies between the two spheres.
    rho2 = 2 * (1 / 16) ** 2
    assert 5 - math.sqrt(r**2 - rho2) <= frame.depth[15, 23] <= 5 - math.sqrt(r_in**2 - rho2)


def horizon_camera():
    # Eye 1.5 m up looking down 10° ; near 0.05 m, far 100 m.
    pitch = math.radians(10)
    eye = np.array([0.0, 1.5, 0.0])
    return mo.Camera(
        eye,
        eye + np.array([0, -math.sin(pitch), -math.cos(pitch)]),
        fov=60,
        resolution=(W, H),
        far=100,
    ), pitch


@pytest.mark.parametrize("size", [400.0, None], ids=["square", "to-far-plane"])
def test_ground_under_the_camera_fills_the_image_below_the_far_line(size):
    camera, pitch = horizon_camera()
    frame = draw(camera, [Ground(0.0, size=size)])
    # A ground point at view depth z projects to row H/2 - scale (sin a - h/z) / cos a
    # (a: pitch, h: eye height). Depth grows toward the horizon, so the ground covers
    # the rows below the image of the far plane's cut, and the rows under the eye come
    # from triangles clipped at the near plane.
    h, f = 1.5, camera.scale
    far_row = H / 2 - f * (math.sin(pitch) - h / camera.far) / math.cos(pitch)
    rows = np.arange(H) + 0.5
    assert_array_equal(np.isfinite(frame.depth).all(axis=1), rows > far_row)
    assert_array_equal(np.isfinite(frame.depth).any(axis=1), rows > far_row)
    below = rows > far_row
    z = h / (math.sin(pitch) - math.cos(pitch) * (H / 2 - rows[below]) / f)
    assert_allclose(frame.depth[below], np.broadcast_to(z[:, None], (below.sum(), W)), rtol=RTOL32)


def test_triangles_beyond_the_far_plane_are_culled():
    camera = perspective(far=3.0)
    frame = draw(camera, [Sphere((0, 0, -2.0), 0.5)])  # 6.3 m away
    assert np.isinf(frame.depth).all()


def test_near_box_hides_far_sphere():
    camera = orthographic()
    sphere = Sphere((0, 0, -2), 1.5, color=(0, 0, 1))
    box = Box((0.5, 0.25, 2), (1.0, 1.0, 1.0), color=(1, 0, 0))
    for objects in ([sphere, box], [box, sphere]):
        frame = draw(camera, objects)
        # Box front face z = 2.5 is 2.5 m from the eye at z = 5; pixel columns 24..31 and
        # rows 12..19 (x in [0, 1], y in [-0.25, 0.75] at 8 px/m).
        face = (slice(12, 18), slice(24, 32))
        assert_array_equal(frame.depth[face], 2.5)
        assert_array_equal(frame.color[face], np.broadcast_to([1, 0, 0], (6, 8, 3)))
        sphere_only = np.isfinite(frame.depth) & (frame.depth > 2.5)
        assert sphere_only.sum() > 300
        assert np.all(frame.depth[sphere_only] >= 7 - 1.5)
        assert_array_equal(
            frame.color[sphere_only], np.broadcast_to([0, 0, 1], (sphere_only.sum(), 3))
        )


def test_shared_edges_leave_no_gaps_and_no_overlap():
    # A 4 × 3 grid of 0.5 m squares in the orthographic view: corners on whole pixels, so
    # diagonals pass exactly through pixel centres and the tie rule decides them.
    camera = orthographic()
    u, v = np.meshgrid(np.arange(5) * 0.5 - 1.0, np.arange(4) * 0.5 - 0.75)
    vertices = np.stack([u, v, np.zeros_like(u)], axis=-1).reshape(-1, 3)
    idx = np.arange(20).reshape(4, 5)
    a, b, c, d = (
        idx[:-1, :-1].ravel(),
        idx[:-1, 1:].ravel(),
        idx[1:, 1:].ravel(),
        idx[1:, :-1].ravel(),
    )
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    # Line segments through pixel centres make ties; a line is drawn over the grid,
    # additive-free, so double coverage cannot show, but missed samples would.
    frame = draw(camera, [Mesh(TriangleMesh(vertices, faces))])
    covered = np.isfinite(frame.depth)
    expected = np.zeros((H, W), dtype=bool)
    expected[16 - 6 : 16 + 6, 24 - 8 : 24 + 8] = True
    assert_array_equal(covered, expected)
    # Each sample is owned by exactly one of two triangles sharing an edge: drawing the
    # halves separately gives disjoint coverages whose union is the rectangle.
    first = np.isfinite(draw(camera, [Mesh(TriangleMesh(vertices, faces[:12]))]).depth)
    second = np.isfinite(draw(camera, [Mesh(TriangleMesh(vertices, faces[12:]))]).depth)
    assert not np.any(first & second)
    assert_array_equal(first | second, expected)


# --- shading ------------------------------------------------------------------------------


def quad(z=0.0, *, facing_camera=True):
    vertices = np.array([[-1.0, -1, z], [1, -1, z], [1, 1, z], [-1, 1, z]])
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    if not facing_camera:
        faces = faces[:, ::-1]
    return TriangleMesh(vertices, faces)


@pytest.mark.parametrize("smooth", [True, False], ids=["smooth", "flat"])
@pytest.mark.parametrize("theta", [0.0, 30.0, 60.0, 89.0])
def test_lambert_quad_lit_at_an_angle(theta, smooth):
    camera = orthographic()
    t = math.radians(theta)
    color, ambient = np.array([0.8, 0.5, 0.25]), 0.1
    lights = [
        DirectionalLight((-math.sin(t), 0, -math.cos(t)), intensity=2.0),
        AmbientLight((ambient,) * 3),
    ]
    frame = draw(camera, [Mesh(quad(), color=color, smooth=smooth)], lights=lights)
    inside = frame.color[9:23, 17:31]
    assert_allclose(
        inside, np.broadcast_to(color * (ambient + 2.0 * math.cos(t)), inside.shape), rtol=RTOL32
    )


def test_blinn_phong_highlight():
    camera = orthographic()
    t = math.radians(40)
    material = Material(specular=0.5, shininess=20)
    lights = [DirectionalLight((-math.sin(t), 0, -math.cos(t)))]
    frame = draw(camera, [Mesh(quad(), color=(0.5, 0.5, 0.5), material=material)], lights=lights)
    # Orthographic view along -z: v = +z, so the half vector makes t/2 with the normal.
    expected = 0.5 * math.cos(t) + 0.5 * math.cos(t / 2) ** 20
    assert_allclose(frame.color[16, 24], [expected] * 3, rtol=RTOL32)


def test_point_light_falls_off_with_the_square_of_the_distance():
    """A point light straight in front of the quad (at the pixel's own x, y) lights it
    with intensity / d²; without falloff with the intensity; from behind not at all."""
    camera = orthographic()
    color = np.array([0.8, 0.5, 0.25])
    # Pixel (16, 24)'s centre on the quad (8 px per metre, the view centred on 0).
    x, y = (24 + 0.5 - W / 2) / 8, (H / 2 - 16 - 0.5) / 8
    probe = frame_point = None
    for d in (1.0, 2.0, 4.0):
        frame = draw(camera, [Mesh(quad(), color=color)], lights=[mo.render.shading.PointLight(
            (0.0, 0.0, d), intensity=2.0)])  # fmt: skip
        centre = frame.color[16, 24]
        r2 = x * x + y * y + d * d  # Lambert's cosine d / r, over r²
        # rtol: the 2 x 2 samples of a pixel average a smooth falloff (error ~ (0.03/d)²).
        assert_allclose(centre, color * 2.0 * (d / np.sqrt(r2)) / r2, rtol=3e-3)
        probe, frame_point = centre, frame
    flat = mo.render.shading.PointLight((0.0, 0.0, 4.0), intensity=2.0, falloff=False)
    frame = draw(camera, [Mesh(quad(), color=color)], lights=[flat])
    assert_allclose(frame.color[16, 24], color * 2.0 * 4.0 / np.sqrt(x * x + y * y + 16.0),
                    rtol=3e-3)  # fmt: skip
    behind = mo.render.shading.PointLight((0.0, 0.0, -1.0), intensity=2.0)
    frame = draw(camera, [Mesh(quad(), color=color)], lights=[behind])
    assert_allclose(frame.color[16, 24], 0.0, atol=1e-7)
    # Off-centre pixels see the light at a slant and farther: darker than the centre.
    assert frame_point.color[16, 30].sum() < probe.sum()


def test_emission_and_hemisphere_ambient():
    camera = orthographic()
    lights = [AmbientLight((0.6, 0.6, 0.6), ground=(0.2, 0.2, 0.2))]
    emissive = Material(emission=(0.05, 0.1, 0.0))
    frame = draw(camera, [Mesh(quad(), color=(1, 1, 1), material=emissive)], lights=lights)
    # Normal +z is horizontal: halfway between ground and sky.
    assert_allclose(frame.color[16, 24], [0.45, 0.5, 0.4], rtol=RTOL32)


def test_back_faces_are_lit_as_seen_from_the_camera():
    camera = orthographic()
    light = [DirectionalLight((0, 0, -1)), AmbientLight((0.1, 0.1, 0.1))]
    front = draw(camera, [Mesh(quad(), color=(1, 1, 1))], lights=light)
    back = draw(camera, [Mesh(quad(facing_camera=False), color=(1, 1, 1))], lights=light)
    assert_allclose(front.color[16, 24], [1.1] * 3, rtol=RTOL32)
    assert_array_equal(back.color, front.color)
    # Lit from behind, the visible side gets only the ambient light.
    behind = [DirectionalLight((0, 0, 1)), AmbientLight((0.1, 0.1, 0.1))]
    for facing in (True, False):
        frame = draw(camera, [Mesh(quad(facing_camera=facing), color=(1, 1, 1))], lights=behind)
        assert_allclose(frame.color[16, 24], [0.1] * 3, rtol=RTOL32)


def test_ground_checker_parity():
    camera = mo.Camera(
        (0, 5, 0),
        (0, 0, 0),
        up=(0, 0, -1),
        projection="orthographic",
        height=4.0,
        resolution=(W, H),
    )
    ground = Ground(0.0, size=10.0, color=(1, 1, 1), checker=((0, 0, 0), 0.5))
    frame = draw(camera, [ground])
    # Looking down with -z up: pixel (row, col) sees x = (col + 0.5 - 24) / 8 and
    # z = (row + 0.5 - 16) / 8. The second colour where floor(x/0.5) + floor(z/0.5) is odd.
    rows, cols = np.mgrid[0:H, 0:W] + 0.5
    x, z = (cols - 24) / 8, (rows - 16) / 8
    odd = (np.floor(x / 0.5) + np.floor(z / 0.5)) % 2 == 1
    # Filtered over a pixel (1/8 m): pixel centres 1/16 m from a cell edge still see pure
    # colours, up to the filter's 1e-4-cell regularisation.
    assert_allclose(frame.color[..., 0], np.where(odd, 0.0, 1.0), atol=1e-3)


# --- anti-aliasing, resolve, determinism --------------------------------------------------


def white_triangle():
    corners = [[[-1.3, -1.1, 0], [1.4, -0.7, 0], [0.2, 1.5, 0]]]
    return triangle_soup(corners, np.ones((1, 3, 3)))


def test_supersampling_gives_edge_pixels_intermediate_values():
    camera = perspective()
    hard = draw(camera, [white_triangle()], supersample=1).color[..., 0]
    assert set(np.unique(hard)) == {0.0, 1.0}
    for ss in (2, 3, 4):
        frame = draw(camera, [white_triangle()], supersample=ss)
        soft = frame.color[..., 0]
        partial = (soft > 0) & (soft < 1)
        assert partial.sum() > 10
        # Values are multiples of 1/ss²; a pixel with any covered sample takes the
        # nearest (minimum) depth of its samples.
        assert_allclose(soft * ss * ss, np.round(soft * ss * ss), atol=1e-5)
        assert np.all(np.isfinite(frame.depth[soft > 0]))
        assert np.all(np.isinf(frame.depth[soft == 0]))


def test_pixels_without_geometry_keep_the_background_bit_for_bit(rng):
    camera = perspective()
    frame = Frame(W, H)
    frame.color[:] = rng.uniform(0, 3, frame.color.shape).astype(np.float32)
    frame.depth[:] = rng.uniform(1.0, 50.0, frame.depth.shape).astype(np.float32)
    before_color, before_depth = frame.color.copy(), frame.depth.copy()
    draw(camera, [white_triangle()], supersample=3, frame=frame)
    untouched = np.all(frame.color == before_color, axis=-1)
    assert 0 < untouched.sum() < W * H
    assert_array_equal(frame.depth[untouched], before_depth[untouched])
    # The supersampled buffer starts from the frame: geometry behind the existing depth
    # stays hidden.
    hidden = Frame(W, H)
    hidden.depth[:] = 1.0
    draw(camera, [white_triangle()], frame=hidden)
    assert_array_equal(hidden.color, 0.0)


def showcase(n=24):
    u, v = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n))
    cloth = np.stack([u, 0.9 + 0.1 * np.sin(3 * u) * np.cos(2 * v), v], axis=-1).reshape(-1, 3)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = (
        idx[:-1, :-1].ravel(),
        idx[:-1, 1:].ravel(),
        idx[1:, 1:].ravel(),
        idx[1:, :-1].ravel(),
    )
    faces = np.concatenate([np.stack([a, d, c], 1), np.stack([a, c, b], 1)])
    rotation = np.array([[0.8, 0, 0.6], [0, 1, 0], [-0.6, 0, 0.8]])
    return [
        Ground(checker=((0.2, 0.2, 0.2), 0.5)),
        Sphere((0.6, 0.4, 0.3), 0.4, material=Material(specular=0.4)),
        Box((-0.7, 0.3, 0.2), (0.5, 0.6, 0.4), rotation=rotation, color="#3366cc"),
        Mesh(TriangleMesh(cloth, faces), color=(0.8, 0.3, 0.2)),
        Lines.strips(
            [np.c_[np.linspace(-1, 1, 9), np.full(9, 1.4), np.sin(np.arange(9))]], width=1.5
        ),
    ]


def test_thread_count_does_not_change_the_image():
    camera = mo.Camera((0.5, 2.0, 3.5), (0, 0.5, 0), resolution=(96, 64))
    objects = showcase()
    previous = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = draw(camera, objects, lights=None, supersample=2)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = draw(camera, objects, lights=None, supersample=2)
        again = draw(camera, objects, lights=None, supersample=2)
    finally:
        numba.set_num_threads(previous)
    assert np.isfinite(one.depth).sum() > 0.8 * 96 * 64
    assert_array_equal(one.color, two.color)
    assert_array_equal(one.depth, two.depth)
    assert_array_equal(two.color, again.color)


# --- bad input ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("make", "error", "match"),
    [
        (lambda: Sphere((0, 0, 0), -1.0), ValueError, "radius must be > 0"),
        (lambda: Sphere((0, 0), 1.0), ValueError, "center must have shape"),
        (lambda: Sphere(subdivisions=7), ValueError, "subdivisions must be <= 6"),
        (lambda: Sphere(color="red"), ValueError, "color must be a colour"),
        (lambda: Box(size=(1, 0, 1)), ValueError, "size must be > 0"),
        (lambda: Box(rotation=np.diag([1, 1, -1])), ValueError, "rotation must be a proper"),
        (lambda: Box(rotation=np.eye(2)), ValueError, "rotation must be a finite"),
        (lambda: Ground(size=0), ValueError, "size must be > 0"),
        (lambda: Ground(checker=(1, 2, 3)), ValueError, "checker must be"),
        (lambda: Ground(checker=((1, 1, 1), -1)), ValueError, "checker cell size must be > 0"),
        (lambda: Mesh(np.zeros((3, 3))), TypeError, "mesh must be a TriangleMesh"),
        (
            lambda: Mesh(quad(), vertex_colors=np.ones((3, 3))),
            ValueError,
            r"vertex_colors must .* \(4, 3\)",
        ),
        (lambda: Lines(np.zeros((3, 3)), [[0, 3]]), ValueError, "segments must index points"),
        (lambda: Lines(np.zeros((3, 3)), [[0.0, 1.0]]), ValueError, "segments must be an"),
        (lambda: Lines(np.zeros((3, 3)), width=0), ValueError, "width must be finite and > 0"),
        (lambda: Lines(np.zeros((3, 3)), width=[1, 2, 3]), ValueError, r"width must be .* \(2,\)"),
        (lambda: Lines(np.zeros((1, 3))), ValueError, "at least 2 rows"),
        (lambda: Lines(np.full((2, 3), np.nan)), ValueError, "points must be finite"),
        (lambda: Lines.strips([]), ValueError, "at least one polyline"),
        (lambda: Material(shininess=0.5), ValueError, "shininess must be >= 1"),
        (lambda: Material(specular=-1), ValueError, "specular must be >= 0"),
        (lambda: DirectionalLight((0, 0, 0)), ValueError, "direction must have non-zero length"),
        (lambda: AmbientLight(intensity=-1), ValueError, "intensity must be >= 0"),
    ],
)
def test_bad_objects_are_refused(make, error, match):
    with pytest.raises(error, match=match):
        make()


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"supersample": 5}, ValueError, "supersample must be <= 4"),
        ({"supersample": 0}, ValueError, "supersample must be >= 1"),
        ({"supersample": 2.0}, TypeError, "supersample must be an integer"),
        ({"objects": [Sphere(), "box"]}, TypeError, r"objects\[1\] must be"),
        ({"lights": [AmbientLight(), AmbientLight()]}, ValueError, "at most one AmbientLight"),
        ({"lights": ["sun"]}, TypeError, r"lights\[0\] must be"),
        ({"frame": Frame(W + 1, H)}, ValueError, "must match the camera resolution"),
        ({"frame": np.zeros((H, W, 3))}, TypeError, "frame must be a Frame"),
    ],
)
def test_bad_draw_arguments_are_refused(kwargs, error, match):
    args = {"frame": Frame(W, H), "camera": perspective(), "objects": [Sphere()]} | kwargs
    frame, camera, objects = args.pop("frame"), args.pop("camera"), args.pop("objects")
    with pytest.raises(error, match=match):
        draw_geometry(frame, camera, objects, **args)
