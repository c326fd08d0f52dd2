"""The ``[[body]]`` extension point: registration, stepping, drawing, errors."""

import numpy as np
import pytest

from motes.render import geometry
from motes.scene import SceneError, bodies, load_scene
from motes.scene.schema import positive


class Ball(bodies.Body):
    """A sphere falling at constant acceleration: enough to see the scene drive a body."""

    def __init__(self, radius, seed):
        self.radius = radius
        self.seed = seed
        self.height = 1.0
        self.speed = 0.0
        self.steps = 0

    def step(self, dt):
        self.speed -= 9.81 * dt
        self.height += self.speed * dt
        self.steps += 1

    def drawables(self):
        return [geometry.Sphere((0.0, self.height, 0.0), self.radius, color=(1.0, 0.2, 0.1))]

    def count(self):
        return 1


@pytest.fixture
def ball_type():
    @bodies.register("test_ball")
    def build(table, context):
        return Ball(table.get("radius", positive(), 0.2), context.seed)

    yield
    del bodies.BODY_TYPES["test_ball"]


SCENE = """
[scene]
fps = 30
substeps = 2
duration = 1
seed = 5
[camera]
position = [0, 1, 4]
target = [0, 0.5, 0]
resolution = [64, 48]
[[body]]
name = "ball"
type = "test_ball"
radius = 0.3
"""


def test_a_body_is_stepped_each_substep_and_drawn(ball_type):
    scene = load_scene(SCENE)
    ball = scene.bodies["ball"]
    assert ball.radius == 0.3
    empty = load_scene(SCENE.replace("radius = 0.3", "radius = 0.01")).render()
    scene.advance()
    assert ball.steps == 2
    assert scene.counts() == {"ball": 1}
    image = scene.render()
    # The big ball covers pixels the tiny one leaves to the background.
    assert np.abs(image.astype(int) - empty.astype(int)).sum() > 1000


def test_bodies_get_their_own_seeds_and_keep_the_systems_streams(ball_type):
    system = (
        '\n[[system]]\nname = "dust"\n[[system.emitter]]\n'
        'rate = { type = "per_second", rate = 300 }\n'
    )
    with_body = SCENE.replace("[[body]]", system + "[[body]]")
    a, b = load_scene(with_body), load_scene(with_body)
    assert a.bodies["ball"].seed == b.bodies["ball"].seed
    assert a.bodies["ball"].seed != load_scene(with_body, seed=6).bodies["ball"].seed
    without_body = load_scene(SCENE.split("[[body]]")[0] + system)
    a.advance()
    without_body.advance()
    assert len(a.systems["dust"]) > 0
    np.testing.assert_array_equal(
        a.systems["dust"]["position"], without_body.systems["dust"]["position"]
    )


@pytest.mark.parametrize(
    ("replace", "path", "message"),
    [
        ('type = "test_ball"', "body[0].type", "must be one of"),
        ("radius = 0.3", "body[0].radius", "must be > 0"),
        ('name = "ball"', "body[0].name", "is required"),
        ("radius = 0.3", "body[0].colour", "unknown key"),
    ],
)
def test_body_mistakes_name_the_key(ball_type, replace, path, message):
    bad = {
        "body[0].type": 'type = "rubber"',
        "body[0].radius": "radius = -1",
        "body[0].name": "",
        "body[0].colour": "radius = 0.3\ncolour = 1",
    }[path]
    with pytest.raises(SceneError, match=message) as error:
        load_scene(SCENE.replace(replace, bad))
    assert error.value.path == path


def test_a_duplicate_name_is_an_error(ball_type):
    twice = SCENE + SCENE[SCENE.index("[[body]]") :]
    with pytest.raises(SceneError, match="duplicate name 'ball'"):
        load_scene(twice)
