"""``[[body]] type = "rigid"``: rigid worlds composed in a scene file."""

import numpy as np
import pytest

from motes.scene import SceneError, load_scene

SCENE = """
[scene]
fps = 30
substeps = 2
duration = 2
[camera]
position = [0, 2, 6]
target = [0, 0.5, 0]
resolution = [96, 54]
[[collider]]
type = "plane"
friction = 0.6
visible = true
[[body]]
name = "things"
type = "rigid"
  [[body.box]]
  center = [-1.5, 0.6, 0]
  size = [0.4, 0.4, 0.4]
  rotation = [0, 20, 0]
  [[body.tetrahedron]]
  center = [1.5, 1.0, 0]
  edge = 0.5
  rotation = [30, 0, 10]
  [[body.ball]]
  center = [0, 2.0, -1]
  radius = 0.1
  velocity = [0.5, 0, 0]
  [[body.rope]]
  start = [0, 2.5, 1]
  end = [1, 2.5, 1]
  segments = 10
  [[body.ragdoll]]
  position = [-0.3, 0.5, 0]
  height = 1.2
  yaw = 90
"""


def test_a_composed_rigid_world_settles_on_the_ground_and_draws():
    scene = load_scene(SCENE)
    body = scene.bodies["things"]
    world = body.world
    rope_start = world.position[world.count - 26]  # the rope's first particle (before the doll)
    start = rope_start.copy()
    for _ in range(scene.frame_count):
        scene.advance()
    position = world.position
    # Nothing fell through the ground (contact radii are a few millimetres at most).
    assert position[:, 1].min() > -0.01
    # The box (first body) rests on its face: centre height half its size, level.
    centre, rotation = world.transforms()
    assert centre[0][1] == pytest.approx(0.2, abs=0.01)
    assert abs(rotation[0][1, 1]) == pytest.approx(1.0, abs=1e-3)
    # The rope hangs from its pinned start.
    np.testing.assert_array_equal(world.position[world.count - 26], start)
    assert scene.counts()["things"] == world.count
    image = scene.render()
    assert image.shape == (54, 96, 3) and image.std() > 5


def test_swept_detection_stops_a_fast_ball_at_a_thin_wall():
    wall = '[[collider]]\ntype = "box"\ncenter = [1, 1, 0]\nsize = [0.01, 2, 2]\n'
    ball = (
        '[[body]]\nname = "shot"\ntype = "rigid"\ngravity = [0, 0, 0]\ndetection = "{}"\n'
        "  [[body.ball]]\n  center = [0, 1, 0]\n  radius = 0.001\n  velocity = [100, 0, 0]\n"
    )
    head = SCENE.split("[[collider]]")[0]
    for detection, passes in (("priori", False), ("posteriori", True)):
        scene = load_scene(head + wall + ball.format(detection))
        for _ in range(10):
            scene.advance()
        x = scene.bodies["shot"].world.position[0, 0]
        assert bool(x > 1.0) is passes, (detection, x)


@pytest.mark.parametrize(
    ("change", "path", "message"),
    [
        (("edge = 0.5", "edge = -1"), "body[0].tetrahedron[0].edge", "must be > 0"),
        (("segments = 10", "segments = 10\n  knots = 3"), "body[0].rope[0].knots", "unknown key"),
        (("end = [1, 2.5, 1]", "end = [0, 2.5, 1]"), "body[0].rope[0].end", "must differ"),
        (("yaw = 90", "yaw = 90\n  pin = 1"), "body[0].ragdoll[0].pin", "unknown key"),
        (('type = "rigid"', 'type = "rigid"\ndetection = "later"'), "body[0].detection", "one of"),
    ],
)
def test_mistakes_name_the_part(change, path, message):
    with pytest.raises(SceneError, match=message) as error:
        load_scene(SCENE.replace(*change))
    assert error.value.path.startswith(path)


def test_an_empty_rigid_body_is_an_error():
    empty = SCENE.split("  [[body.box]]")[0]
    with pytest.raises(SceneError, match="at least one of: box"):
        load_scene(empty)


def test_balls_collide_with_each_other():
    balls = (
        '[[body]]\nname = "pool"\ntype = "rigid"\ngravity = [0, 0, 0]\n'
        "  [[body.ball]]\n  center = [-0.5, 1, 0]\n  velocity = [1, 0, 0]\n  restitution = 1\n"
        "  [[body.ball]]\n  center = [0.5, 1, 0]\n  restitution = 1\n"
    )
    scene = load_scene(SCENE.split("[[collider]]")[0] + balls)
    for _ in range(scene.frame_count):
        scene.advance()
    world = scene.bodies["pool"].world
    # Equal masses, elastic, head-on: the first stops and the second takes its velocity.
    np.testing.assert_allclose(world.velocity[:, 0], [0.0, 1.0], atol=1e-6)
