"""Lines lit as fibres (Kajiya & Kay 1989): the diffuse and highlight terms in the
configurations where each is known in closed form."""

import numpy as np
import pytest

from motes.render.camera import Camera
from motes.render.geometry import Lines
from motes.render.shading import AmbientLight, DirectionalLight, PointLight

BASE = np.array([0.5, 0.3, 0.1])


def fibre(**options) -> Lines:
    """One segment along +x from the origin, of colour BASE."""
    return Lines([[0, 0, 0], [1, 0, 0]], color=BASE, shading="hair", **options)


def camera_at(position) -> Camera:
    return Camera(position, (0.5, 0.0, 0.0), up=(0, 0, 1) if position[1] else (0, 1, 0))


def test_across_the_light_and_the_eye_the_fibre_shows_its_colour_and_full_highlight():
    # light from +y (it travels along -y), the eye far along +z: both across the fibre
    light = DirectionalLight((0, -1, 0), intensity=2.0)
    lit = fibre(specular=0.3, shininess=50).lit(camera_at((0.5, 0.0, 1e6)), [light])
    want = 2.0 * (BASE + 0.3 * (0.5 + 0.5 * BASE))  # sin = 1 for both: the highlight's peak
    np.testing.assert_allclose(lit.colors, np.broadcast_to(want, (1, 2, 3)), rtol=1e-5)


def test_a_light_along_the_fibre_gives_no_diffuse_and_a_highlight_only_on_its_cone():
    light = DirectionalLight((-1, 0, 0))  # travels along -x: toward it is +x, the fibre
    across = fibre().lit(camera_at((0.5, 0.0, 1e6)), [light])
    np.testing.assert_allclose(across.colors, 0.0, atol=1e-7)  # sin(t, l) = 0, no cone
    # the eye on the mirror cone: cos(t, e) = -cos(t, l) = -1, far along -x
    mirror = fibre(specular=0.4).lit(Camera((-1e6, 0, 0), (0.5, 0, 0)), [light])
    want = np.broadcast_to(0.4 * (0.5 + 0.5 * BASE), (1, 2, 3))
    np.testing.assert_allclose(mirror.colors, want, rtol=1e-5)


def test_ambient_and_point_lights():
    sky = AmbientLight((0.2, 0.2, 0.2), ground=(0.0, 0.0, 0.0), intensity=1.5)
    ambient = fibre(specular=0.0).lit(camera_at((0.5, 0.0, 5.0)), [sky])
    np.testing.assert_allclose(ambient.colors, np.broadcast_to(BASE * 0.15, (1, 2, 3)))
    # a point light 2 m above the segment's start: at the start it is straight across
    lamp = PointLight((0, 2, 0), intensity=4.0)
    lit = fibre(specular=0.0).lit(camera_at((0.5, 0.0, 5.0)), [lamp])
    np.testing.assert_allclose(lit.colors[0, 0], BASE * 4.0 / 4.0, rtol=1e-6)  # 1/d², sin 1
    sin = 2.0 / np.sqrt(5.0)  # at the end, 1 m along: the light at atan(2) from the fibre
    np.testing.assert_allclose(lit.colors[0, 1], BASE * sin * 4.0 / 5.0, rtol=1e-6)


def test_flat_lines_are_drawn_as_given_and_bad_options_are_refused():
    flat = Lines([[0, 0, 0], [1, 0, 0]], color=BASE)
    assert flat.lit(camera_at((0, 0, 5)), None) is flat
    with pytest.raises(ValueError, match="shading"):
        Lines([[0, 0, 0], [1, 0, 0]], shading="fur")
    with pytest.raises(ValueError, match="shininess"):
        Lines([[0, 0, 0], [1, 0, 0]], shading="hair", shininess=0)
