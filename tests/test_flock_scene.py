"""Flocks in scene files: building, linking predators and prey, drawing, key errors."""

import numpy as np
import pytest

from motes.scene import SceneError, load_scene

SCENE = """
[scene]
fps = 30
seed = 2

[camera]
position = [0, 3, 30]
target = [0, 3, 0]
resolution = [160, 90]

[render]
background = ["#203050", "#e0a070"]

[[collider]]
type = "sphere"
center = [0, 3, 0]
radius = 2.0

[[body]]
name = "school"
type = "flock"
count = 1500
center = [-6, 3, 0]
extent = [6, 3, 4]
speed = 2.0
direction = [1, 0, 0]
max_speed = 4.0
min_speed = 1.0
draw = "{draw}"
color = "#101018"
haze_color = "#6d6680"
haze_distance = 50.0
separation = {{ radius = 0.5, weight = 6.0 }}
  [[body.seek]]
  target = [15, 3, 0]
  weight = 1.0
  [[body.evade]]
  flock = "{prey_of}"
  radius = 5.0
  weight = 6.0

[[body]]
name = "shark"
type = "flock"
count = 1
center = [-20, 3, 0]
extent = [0, 0, 0]
speed = 4.0
direction = [1, 0, 0]
radius = 0.3
max_speed = 6.0
  [[body.pursue]]
  flock = "school"
  radius = 40.0
  weight = 2.0
"""


def scene(draw="birds", prey_of="shark"):
    return load_scene(SCENE.format(draw=draw, prey_of=prey_of))


@pytest.mark.parametrize("draw", ["birds", pytest.param("sprites", marks=pytest.mark.slow)])
def test_a_school_flees_its_shark_avoids_the_rock_and_draws(draw):
    s = scene(draw)
    school = s.bodies["school"].flock
    assert len(school.interactions) == 1 and school.avoidance is not None
    for _ in range(30):
        s.advance()
    assert s.counts()["school"] == 1500 and s.counts()["shark"] == 1
    d = np.linalg.norm(school.position - np.array([[0.0], [3.0], [0.0]]), axis=0)
    assert d.min() >= 2.0 + school.radius - 1e-5  # never inside the rock
    image = s.render()
    sky = s.render().astype(float)
    assert image.shape == (90, 160, 3) and sky.std() > 2
    # The flock darkens the sky where it is: the darkest pixels are far below the sky's.
    assert image.min() < 0.5 * np.median(image)


def test_a_flock_name_that_is_no_flock_is_an_error_naming_the_key():
    with pytest.raises(SceneError, match=r"body\[0\]\.evade\[0\]\.flock.*'shark'"):
        scene(prey_of="whale")
    with pytest.raises(SceneError, match=r"body\[0\]\.evade\[0\]\.flock.*another flock"):
        scene(prey_of="school")


@pytest.mark.parametrize(
    ("old", "new", "where"),
    [
        ("weight = 6.0 }", "weight = 6.0, fov = 400 }", r"body\[0\]\.separation\.fov.*<= 360"),
        ("count = 1500", "count = -1", r"body\[0\]\.count"),
        ("min_speed = 1.0", "min_speed = 9.0", r"min_speed must be <= max_speed"),
        ('draw = "birds"', 'draw = "whales"', r"body\[0\]\.draw.*'fish'"),
        ("  [[body.seek]]\n  target", "  [[body.seek]]\n  goal", r"body\[0\]\.seek\[0\]"),
    ],
)
def test_bad_keys_name_their_path_and_range(old, new, where):
    text = SCENE.format(draw="birds", prey_of="shark")
    assert old in text
    with pytest.raises(SceneError, match=where):
        load_scene(text.replace(old, new, 1))


@pytest.mark.parametrize(("direction", "angle"), [("[1, 0, 0]", 0.0), ("[0, 1, 0]", np.pi / 2)])
def test_sprites_turn_to_the_heading_the_camera_sees(direction, angle):
    s = load_scene(f"""
[camera]
position = [0, 0, 10]
target = [0, 0, 0]
resolution = [200, 120]
[[body]]
name = "b"
type = "flock"
count = 3
extent = [6, 0, 0]
speed = 1.0
direction = {direction}
draw = "sprites"
size = 2.0
separation = {{ weight = 0.0 }}
alignment = {{ weight = 0.0 }}
cohesion = {{ weight = 0.0 }}
""")
    s.advance()
    ((state, style),) = s.bodies["b"].particles()
    assert style.texture is not None and style.texture.shape == (32, 32, 4)
    # Counter-clockwise on screen from +x; no rule turns them, and a camera looking along
    # -z with +y up keeps x and y directions on screen (float32 rounding only).
    np.testing.assert_allclose(state["rotation"], angle, atol=1e-5)
    assert s.render().std() > 1


def test_a_trail_draws_each_boids_last_positions():
    text = SCENE.format(draw="birds", prey_of="shark").replace(
        "radius = 0.3\nmax_speed = 6.0",
        "radius = 0.3\nmax_speed = 6.0\ntrail = 20\ntrail_width = 2.0",
    )
    s = load_scene(text)
    shark = s.bodies["shark"]
    assert shark.drawables()[1:] == []  # nothing recorded yet
    for _ in range(30):
        s.advance()
    _, lines = shark.drawables()
    assert lines.segments.shape == (19, 2)  # the last 20 positions of the one shark
    np.testing.assert_allclose(lines.points[-1], shark.flock.position[:, 0], rtol=0, atol=1e-6)
    steps = np.linalg.norm(np.diff(lines.points, axis=0), axis=1)
    assert np.all(steps <= 6.0 / 30 + 1e-6)  # one step of at most max_speed · dt apart
    with pytest.raises(SceneError, match=r"body\[0\]\.trail: trail × count must be at most"):
        load_scene(SCENE.format(draw="birds", prey_of="shark").replace(
            "count = 1500", "count = 1500\ntrail = 2000"))  # fmt: skip
