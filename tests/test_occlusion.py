"""Screen-space ambient occlusion: contacts darken, open flat ground does not."""

from __future__ import annotations

import numba
import numpy as np
import pytest

import motes as mo
from motes.render import geometry
from motes.render.occlusion import AmbientOcclusion

CAMERA = mo.Camera((0.0, 1.2, 3.5), (0.0, 0.3, 0.0), resolution=(320, 180))


def depth_of(objects) -> np.ndarray:
    return mo.Renderer(CAMERA, supersample=1).render_hdr([], objects).depth


def pixel(point) -> tuple[int, int]:
    (x, y), _ = CAMERA.project([point])[0][0], None
    return int(y), int(x)


def test_open_flat_ground_is_not_occluded():
    share = AmbientOcclusion(radius=0.3).occlusion(depth_of([geometry.Ground(0.0)]), CAMERA)
    ground = share[CAMERA.resolution[1] // 2 :]  # the near half of the ground
    assert ground.max() < 0.02
    assert np.all(share[:40] == 0.0)  # the sky: no geometry, nothing taken


def test_a_sphere_on_the_ground_darkens_the_contact_and_not_the_open_ground():
    objects = [geometry.Ground(0.0), geometry.Sphere((0.0, 0.4, 0.0), 0.4)]
    share = AmbientOcclusion(radius=0.3).occlusion(depth_of(objects), CAMERA)
    beside = share[pixel((0.3, 0.0, 0.0))]  # the ground beside the contact, under the side
    far = share[pixel((1.4, 0.0, 0.8))]  # open ground
    top = share[pixel((0.0, 0.78, 0.1))]  # the sphere's open top
    assert beside > 0.1
    assert far < 0.02 and top < 0.05


def test_darkening_is_strength_times_the_share_and_the_bits_do_not_depend_on_threads():
    objects = [geometry.Ground(0.0), geometry.Box((0.0, 0.25, 0.0), (0.5, 0.5, 0.5))]
    renderer = mo.Renderer(CAMERA, supersample=1)
    plain = renderer.render_hdr([], objects)
    occlusion = AmbientOcclusion(radius=0.3, strength=0.5)
    shares = []
    for threads in (1, min(2, numba.config.NUMBA_NUM_THREADS)):
        numba.set_num_threads(threads)
        shares.append(occlusion.occlusion(plain.depth, CAMERA))
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert np.array_equal(shares[0], shares[1])
    shaded = mo.Renderer(CAMERA, supersample=1, ambient_occlusion=occlusion).render_hdr([], objects)
    expected = plain.color * (1.0 - 0.5 * shares[0])[..., None]
    assert np.allclose(shaded.color, expected, atol=1e-6)
    assert shares[0].max() > 0.2  # the box's foot is occluded


def test_bad_values_are_named():
    with pytest.raises(ValueError, match=r"ambient_occlusion\.radius"):
        AmbientOcclusion(radius=0.0)
    with pytest.raises(ValueError, match=r"ambient_occlusion\.strength"):
        AmbientOcclusion(strength=2.0)
    with pytest.raises(ValueError, match=r"depth must be \(height, width\) = \(180, 320\)"):
        AmbientOcclusion().occlusion(np.zeros((90, 160), np.float32), CAMERA)
    depth = np.full((180, 320), np.inf, np.float32)
    with pytest.raises(ValueError, match="color must be"):
        AmbientOcclusion().apply(np.zeros((180, 320), np.float32), depth, CAMERA)
    with pytest.raises(TypeError, match="ambient_occlusion must be"):
        mo.Renderer(CAMERA, ambient_occlusion=0.5)
