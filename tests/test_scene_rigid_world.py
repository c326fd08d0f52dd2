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


JOINTED = """
[scene]
fps = 30
substeps = 2
duration = 2
[camera]
position = [0, 1.5, 5]
target = [0, 1, 0]
resolution = [96, 54]
[[body]]
name = "rig"
type = "rigid"
iterations = 20
  [[body.box]]
  name = "door"
  center = [0.5, 1, 0]
  size = [1, 1.6, 0.05]
  [[body.box]]
  name = "arm"
  center = [-0.6, 1.5, 0]
  size = [0.6, 0.1, 0.1]
  [[body.box]]
  name = "forearm"
  center = [-1.2, 1.5, 0]
  size = [0.6, 0.1, 0.1]
  [[body.ball]]
  name = "bob"
  center = [2, 1, 0]
  radius = 0.05
  mass = 2
  [[body.joint]]
  type = "hinge"
  bodies = ["door"]
  at = [0, 1, 0]
  axis = [0, 1, 0]
  width = 1.2
  [[body.joint]]
  type = "ball"
  bodies = ["arm"]
  at = [-0.3, 1.5, 0]
  [[body.joint]]
  type = "ball"
  bodies = ["arm", "forearm"]
  at = [-0.9, 1.5, 0]
  [[body.spring]]
  between = [[2, 2, 0], "bob"]
  stiffness = 400
"""


def test_a_hinged_door_swings_about_its_hinge_and_a_chain_hangs_from_its_joints():
    scene = load_scene(JOINTED)
    body = scene.bodies["rig"]
    world = body.world
    world.set_velocity(world.bodies[0].particles, (0.0, 0.0, 1.0))  # push the door
    for _ in range(scene.frame_count):
        scene.advance()
    centre, _ = world.transforms()
    # The door turned about the vertical hinge line x = z = 0: its centre stays 0.5 m
    # from it at the same height, and it turned away from the x axis.
    assert np.hypot(centre[0][0], centre[0][2]) == pytest.approx(0.5, abs=0.01)
    assert centre[0][1] == pytest.approx(1.0, abs=0.01)
    assert abs(centre[0][2]) > 0.05
    # The arm hangs from its pinned ball joint; the forearm from the arm's free end.
    pivot = np.array([-0.3, 1.5, 0.0])
    assert np.linalg.norm(centre[1] - pivot) == pytest.approx(0.3, abs=0.01)
    elbow = pivot + 2 * (centre[1] - pivot)
    assert np.linalg.norm(centre[2] - elbow) == pytest.approx(0.3, abs=0.015)
    assert centre[2][1] < centre[1][1] < 1.5
    # The spring (k = 400 N/m, XPBD) holds the 2 kg bob: at rest it stretches m g / k,
    # swinging it averages about that; bounds wide enough for the swing.
    bob = world.position[3 * 8]
    stretch = 2.0 - bob[1] - 1.0  # rest length 1 m
    assert 0.0 < stretch < 4 * 2 * 9.81 / 400
    assert scene.render().std() > 5


def test_springs_are_xpbd_sticks_of_compliance_one_over_stiffness():
    text = """
[[body]]
name = "s"
type = "rigid"
iterations = 5
  [[body.ball]]
  name = "weight"
  center = [0, 0, 0]
  mass = 1
  [[body.spring]]
  between = [[0, 1, 0], "weight"]
  stiffness = 200
"""
    scene = load_scene(text)
    world = scene.bodies["s"].world
    world.damping = 5.0  # settle the bounce
    for _ in range(240):
        scene.advance()
    # Hanging at rest: stretched by m g / k below the 1 m rest length (XPBD's stiffness
    # does not depend on the five iterations; 1 % for the damping's residual).
    expected = 1.0 + 9.81 / 200
    assert 1.0 - world.position[0, 1] == pytest.approx(expected, rel=0.01)


def test_compliance_and_hinge_sides_reach_the_world():
    text = SCENE.replace("yaw = 90", "yaw = 90\n  hinge_sides = true\n  compliance = 1e-4")
    text = text.replace("edge = 0.5", "edge = 0.5\n  compliance = 1e-3")
    text = text.replace("segments = 10", "segments = 10\n  compliance = 1e-5")
    world = load_scene(text).bodies["things"].world
    alpha = world.constraints.compliance
    assert {1e-3, 1e-5, 1e-4} <= set(np.round(alpha, 12).tolist())


@pytest.mark.parametrize(
    ("change", "path", "message"),
    [
        (('between = [[2, 2, 0], "bob"]', 'between = ["bobby", "bob"]'),
         "body[0].spring[0].between[0]", "no part named 'bobby'"),
        (('between = [[2, 2, 0], "bob"]', 'between = ["door", "bob"]'),
         "body[0].spring[0].between[0]", "name one, e.g. 'door.0'"),
        (('between = [[2, 2, 0], "bob"]', 'between = ["door.8", "bob"]'),
         "body[0].spring[0].between[0]", "particles 0 to 7"),
        (('between = [[2, 2, 0], "bob"]', 'between = ["bob", "bob"]'),
         "body[0].spring[0].between", "two different particles"),
        (("stiffness = 400", "stiffness = 0"), "body[0].spring[0].stiffness", "must be > 0"),
        (('bodies = ["arm"]', 'bodies = ["bob"]'),
         "body[0].joint[1].bodies[0]", "not a named box or tetrahedron"),
        (('bodies = ["arm"]', 'bodies = ["arm", "arm"]'),
         "body[0].joint[1].bodies", "two different part names"),
        (('type = "hinge"', 'type = "slider"'), "body[0].joint[0].type", "one of"),
        (("axis = [0, 1, 0]", "axis = [0, 0, 0]"), "body[0].joint[0].axis", "non-zero"),
        (('name = "arm"', 'name = "door"'), "body[0].box[1].name", "used by another part"),
    ],
)  # fmt: skip
def test_spring_and_joint_mistakes_name_the_key(change, path, message):
    with pytest.raises(SceneError, match=message) as error:
        load_scene(JOINTED.replace(*change, 1))
    assert error.value.path == path
