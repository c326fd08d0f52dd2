"""Scene looks: emitter systems drawn as metaball surfaces, and keyframed cameras."""

import numpy as np
import pytest

from motes.render import geometry
from motes.render.water import Water
from motes.scene import SceneError, load_scene
from motes.scene.camera_path import CameraPath

BLOB = """
[scene]
fps = 10
seed = 1
[camera]
position = [0, 0, 3]
target = [0, 0, 0]
resolution = [64, 36]
[[system]]
name = "blob"
capacity = 200
  [[system.emitter]]
  shape = { type = "sphere", radius = 0.3 }
  rate = { type = "burst", count = 60 }
  speed = 0.0
  lifetime = 10
  color = "#ff8000"
  [system.render]
  kind = "surface"
  radius = 0.15
  cell_size = 0.05
"""


def test_an_emitter_system_drawn_as_a_metaball_surface_in_its_particles_colour():
    scene = load_scene(BLOB)
    scene.advance()
    image = scene.render()
    renderer = scene._renderers[(64, 36)]
    assert "blob" in renderer.surfaces and "blob" not in renderer.styles
    (mesh,) = renderer.surfaces["blob"].drawables(scene.systems["blob"])
    assert isinstance(mesh, geometry.Mesh)
    # Closed around the particles: every vertex within the field's reach of the cloud.
    vertices = mesh.mesh.vertices
    assert np.linalg.norm(vertices, axis=1).max() < 0.3 + 2 * 0.15
    # Shaded orange (the particles' colour, "#ff8000"): red well above blue in the middle.
    centre = image[12:24, 26:38].astype(int)
    assert centre[..., 0].mean() > centre[..., 2].mean() + 40


def test_surface_keys_are_checked_and_sprite_keys_refused():
    for change, path, message in (
        (("cell_size = 0.05", "cell_size = 0"), "system[0].render.cell_size", "must be > 0"),
        (("cell_size = 0.05", "threshold = -1"), "system[0].render.threshold", "must be > 0"),
        (("cell_size = 0.05", 'blend = "alpha"'), "system[0].render.blend", "unknown key"),
        (('kind = "surface"', 'kind = "sprite"'), "system[0].render.radius", "unknown key"),
    ):
        with pytest.raises(SceneError, match=message) as error:
            load_scene(BLOB.replace(*change))
        assert error.value.path == path


WATER = BLOB.replace(
    'kind = "surface"\n  radius = 0.15\n  cell_size = 0.05',
    'kind = "water"\n  radius = 0.1\n  clarity = 0.2',
)


def test_an_emitter_system_drawn_as_clear_water_tinted_by_its_particles():
    scene = load_scene(WATER.replace('color = "#ff8000"', "color = [1.0, 0.5, 0.1]"))
    scene.advance()
    image = scene.render()
    renderer = scene._renderers[(64, 36)]
    assert "blob" in renderer.surfaces and "blob" not in renderer.styles
    (water,) = renderer.surfaces["blob"].drawables(scene.systems["blob"])
    assert isinstance(water, Water) and water.radius == 0.1 and water.clarity == 0.2
    np.testing.assert_allclose(water.color, (1.0, 0.5, 0.1), rtol=1e-6)
    # over the black background the ball shows the light it scatters, in its tint
    centre = image[12:24, 26:38].astype(int)
    assert centre[..., 0].mean() > centre[..., 2].mean() + 10
    with pytest.raises(SceneError, match=r"each channel in \(0, 1\]") as error:
        load_scene(WATER.replace("clarity = 0.2", "color = [0.0, 0.5, 0.5]"))
    assert error.value.path == "system[0].render.color"


def test_a_camera_path_passes_its_keys_smoothly_and_holds_outside_them():
    times = [1.0, 2.0, 4.0]
    positions = [[0, 0, 5], [3, 1, 4], [5, 0, 0]]
    path = CameraPath(times, positions, [[0, 0, 0]] * 3, [40.0, 50.0, 30.0])
    for t, p in zip(times, positions, strict=True):
        np.testing.assert_allclose(path.at(t)[0], p, atol=1e-12)
    np.testing.assert_array_equal(path.at(0.0)[0], positions[0])
    np.testing.assert_array_equal(path.at(9.0)[0], positions[-1])
    # C1 at the inner key: one-sided difference quotients agree to O(h) (h = 1e-6 s,
    # second derivative of order 10 m/s^2 -> 1e-5 m/s); the tangent is Catmull-Rom's.
    h = 1e-6
    left = (path.at(2.0)[0] - path.at(2.0 - h)[0]) / h
    right = (path.at(2.0 + h)[0] - path.at(2.0)[0]) / h
    np.testing.assert_allclose(left, right, atol=1e-4)
    np.testing.assert_allclose(right, (np.array([5, 0, 0]) - [0, 0, 5]) / 3.0, atol=1e-4)
    # It eases out of the first key and into the last: zero velocity there.
    assert np.linalg.norm(path.at(1.0 + h)[0] - path.at(1.0)[0]) / h < 1e-4
    assert np.linalg.norm(path.at(4.0)[0] - path.at(4.0 - h)[0]) / h < 1e-4
    assert path.at(1.5)[2] == pytest.approx(45.0, abs=2.0)


MOVING = BLOB.replace(
    "resolution = [64, 36]",
    """resolution = [64, 36]
  [[camera.key]]
  time = 0
  [[camera.key]]
  time = 1
  position = [3, 0, 0]
  fov = 30""",
)


def test_scene_render_places_a_keyframed_camera_at_the_scene_time():
    scene = load_scene(MOVING)
    scene.advance()
    scene.render()
    renderer = scene._renderers[(64, 36)].renderer
    expected = scene.camera_path.at(0.1)
    np.testing.assert_allclose(renderer.camera.position, expected[0])
    assert renderer.camera.fov == pytest.approx(expected[2])
    for _ in range(12):
        scene.advance()
    scene.render()
    np.testing.assert_allclose(renderer.camera.position, [3, 0, 0])
    assert renderer.camera.fov == 30
    # The [camera] table's view is kept (screen-scaled emission uses it).
    np.testing.assert_array_equal(scene.camera.position, [0, 0, 3])
    # Another resolution renders from the same place.
    assert scene.camera_at(resolution=(32, 18)).resolution == (32, 18)


@pytest.mark.parametrize(
    ("change", "path", "message"),
    [
        (("time = 1", "time = 0"), "camera.key[1].time", "later than the key before"),
        (("position = [3, 0, 0]", "position = [0, 0, 0]"), "camera.key[1]", "differ"),
        (("fov = 30", "fov = 180"), "camera.key[1].fov", "must be < 180"),
        (("fov = 30", "zoom = 2"), "camera.key[1].zoom", "unknown key"),
        (("time = 0\n", ""), "camera.key[0].time", "is required"),
    ],
)
def test_camera_key_mistakes_name_the_key(change, path, message):
    with pytest.raises(SceneError, match=message) as error:
        load_scene(MOVING.replace(*change, 1))
    assert error.value.path.startswith(path)
