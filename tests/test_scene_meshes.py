"""Mesh files in scenes: mesh-surface emitters, triangle-mesh colliders and fluid walls,
read relative to the scene file and never from outside its folder by a relative path."""

import numpy as np
import pytest

from motes.collide.mesh import TriangleMeshCollider
from motes.fluids import MeshWall
from motes.scene import SceneError, load_scene

# A 2 m x 2 m square in the plane y = 0, two triangles facing up.
SQUARE = "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 3 2\nf 1 4 3\n"

EMITTER = """
[scene]
fps = 10
[[system]]
name = "spray"
capacity = 2000
  [[system.emitter]]
  position = [0, 1, 0]
  shape = { type = "mesh", path = "square.obj", scale = 0.5, rotation = [90, 0, 0] }
  rate = { type = "burst", count = 500 }
  speed = 0.0
  lifetime = 5
"""

RIGID = """
[scene]
fps = 30
substeps = 2
duration = 1.5
[[collider]]
type = "mesh"
path = "square.obj"
position = [0, 0.5, 0]
friction = 0.5
visible = true
[[body]]
name = "world"
type = "rigid"
  [[body.ball]]
  center = [0.2, 1.5, 0.1]
  radius = 0.05
"""


def _write(tmp_path, text, name="scene.toml"):
    (tmp_path / "square.obj").write_text(SQUARE)
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_mesh_emitter_places_particles_on_the_moved_scaled_and_turned_surface(tmp_path):
    scene = load_scene(_write(tmp_path, EMITTER))
    scene.advance()
    p = scene.systems["spray"]["position"]
    assert len(p) == 500
    # Scaled to 1 m x 1 m, turned about x into the plane z = 0, centred on the emitter.
    np.testing.assert_allclose(p[:, 2], 0.0, atol=1e-5)
    assert np.all(np.abs(p[:, 0]) <= 0.5 + 1e-5) and np.all(np.abs(p[:, 1] - 1.0) <= 0.5 + 1e-5)
    # Uniform over the area: each quarter of the square gets about a quarter (3 sigma).
    quarter = np.sum((p[:, 0] > 0) & (p[:, 1] > 1.0))
    assert abs(quarter - 125) < 3 * np.sqrt(500 * 0.25 * 0.75)


def test_mesh_paths_stay_in_the_scene_folder_unless_absolute(tmp_path):
    inner = tmp_path / "scenes"
    inner.mkdir()
    (tmp_path / "outside.obj").write_text(SQUARE)
    path = _write(inner, EMITTER.replace("square.obj", "../outside.obj"))
    with pytest.raises(SceneError, match="leaves the scene file's folder") as error:
        load_scene(path)
    assert error.value.path == "system[0].emitter[0].shape.path"
    # The same file by its absolute path is fine, and so is a sub-folder.
    path.write_text(EMITTER.replace("square.obj", str(tmp_path / "outside.obj")))
    assert len(load_scene(path).systems) == 1
    (inner / "meshes").mkdir()
    (inner / "meshes" / "m.ply").write_text(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
        "end_header\n0 0 0\n1 0 0\n0 0 1\n3 0 1 2\n"
    )
    path.write_text(EMITTER.replace("square.obj", "meshes/./m.ply"))
    assert len(load_scene(path).systems) == 1


@pytest.mark.parametrize(
    ("replace", "message"),
    [
        ("missing.obj", "mesh file not found"),
        ("square.stl", "must be a .obj, .ply file"),
        ("", "must be a file name"),
    ],
)
def test_bad_mesh_files_name_the_key(tmp_path, replace, message):
    (tmp_path / "square.stl").write_text("solid")
    path = _write(tmp_path, EMITTER.replace("square.obj", replace))
    with pytest.raises(SceneError, match=message) as error:
        load_scene(path)
    assert error.value.path == "system[0].emitter[0].shape.path"


def test_a_broken_mesh_file_is_reported_at_its_key(tmp_path):
    path = _write(tmp_path, EMITTER)
    (tmp_path / "square.obj").write_text("v 0 0 0\nf 1 2 3\n")
    with pytest.raises(SceneError) as error:
        load_scene(path)
    assert error.value.path == "system[0].emitter[0].shape.path"


def test_a_ball_lands_on_a_mesh_collider_in_a_rigid_world_and_the_mesh_is_drawn(tmp_path):
    scene = load_scene(_write(tmp_path, RIGID))
    world = scene.bodies["world"].world
    assert isinstance(world.colliders[0], TriangleMeshCollider)
    for _ in range(scene.frame_count):
        scene.advance()
    # Resting on the square moved up to y = 0.5 (within the contact radius).
    assert world.position[0, 1] == pytest.approx(0.55, abs=0.01)
    assert [o.kind for o in scene.objects] == ["mesh"]
    assert scene.render((48, 27)).std() > 0


def test_a_cloth_falls_onto_a_mesh_collider(tmp_path):
    text = RIGID.replace(
        """type = "rigid"
  [[body.ball]]
  center = [0.2, 1.5, 0.1]
  radius = 0.05""",
        """type = "cloth"
grid = [6, 6]
size = [0.8, 0.8]
origin = [-0.4, 0.8, 0.0]
rotation = [90, 0, 0]""",
    )
    scene = load_scene(_write(tmp_path, text))
    cloth = scene.bodies["world"].cloth
    for _ in range(scene.frame_count):
        scene.advance()
    # It came down 0.3 m and stopped on the shell (thickness 5 mm by default).
    assert cloth.position[1].min() > 0.5 - 1e-3
    assert cloth.position[1].max() < 0.52


@pytest.mark.slow
def test_a_fluid_takes_a_mesh_wall(tmp_path):
    text = """
[[body]]
name = "water"
type = "fluid"
spacing = 0.05
  [[body.block]]
  lower = [-0.1, 0.6, -0.1]
  upper = [0.1, 0.7, 0.1]
  [[body.wall]]
  type = "mesh"
  path = "square.obj"
  position = [0, 0.5, 0]
  friction = 0.2
"""
    scene = load_scene(_write(tmp_path, text))
    water = scene.bodies["water"].fluid
    assert isinstance(water.model.boundaries[0], MeshWall)
    for _ in range(10):
        scene.advance()
    assert water.positions[1].min() > 0.5 - 1e-6
    assert any(type(d).__name__ == "Mesh" for d in scene.bodies["water"].drawables())


RAIN = """
[scene]
fps = 30
duration = 1.0
[[collider]]
type = "mesh"
path = "square.obj"
restitution = 0.0
[[system]]
name = "rain"
capacity = 500
  [[system.emitter]]
  position = [0, 1, 0]
  shape = { type = "box", size = [1.0, 0.2, 1.0] }
  rate = { type = "burst", count = 400 }
  speed = 0.0
  lifetime = 5
  [[system.force]]
  type = "gravity"
"""


@pytest.mark.slow
def test_emitter_particles_land_on_a_shared_mesh_collider(tmp_path):
    scene = load_scene(_write(tmp_path, RAIN))
    collider = scene.systems["rain"].colliders[0]
    assert isinstance(collider, TriangleMeshCollider) and collider.swept  # priori by default
    for _ in range(scene.frame_count):
        scene.advance()
    y = scene.systems["rain"]["position"][:, 1]
    assert len(y) == 400 and y.min() >= -1e-5 and y.max() < 0.01  # resting on the square
    # Opting out of the shared colliders lets the mesh serve bodies only: the rain falls.
    opted_out = RAIN.replace('name = "rain"', 'name = "rain"\nshared_colliders = false')
    scene = load_scene(_write(tmp_path, opted_out))
    for _ in range(scene.frame_count):
        scene.advance()
    assert scene.systems["rain"]["position"][:, 1].max() < -3.0


@pytest.mark.slow
def test_a_mesh_collider_of_a_system_kills_what_it_touches(tmp_path):
    own = RAIN.replace('[[collider]]\ntype = "mesh"\npath = "square.obj"\nrestitution = 0.0\n', "")
    own += '  [[system.collider]]\n  type = "mesh"\n  path = "square.obj"\n  response = "kill"\n'
    scene = load_scene(_write(tmp_path, own))
    for _ in range(scene.frame_count):
        scene.advance()
    assert len(scene.systems["rain"]) == 0


def test_hair_refuses_a_mesh_collider(tmp_path):
    text = RIGID.replace(
        """type = "rigid"
  [[body.ball]]
  center = [0.2, 1.5, 0.1]
  radius = 0.05""",
        'type = "hair"\nstrands = 4',
    )
    with pytest.raises(SceneError, match="triangle-mesh collider") as error:
        load_scene(_write(tmp_path, text))
    assert error.value.path == "body[0].colliders"


def test_mesh_collider_keys_are_checked(tmp_path):
    for key, message in (
        ("inside = true", r"unknown key; did you mean 'visible'\? allowed here: type, path"),
        ("thickness = -1", "must be >= 0"),
        ("scale = 0", "must be > 0"),
    ):
        text = RIGID.replace("friction = 0.5", key)
        with pytest.raises(SceneError, match=message):
            load_scene(_write(tmp_path, text))
