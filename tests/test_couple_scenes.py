"""Kinds acting on each other in scene files: ``[[system.contact]]`` with a body."""

from pathlib import Path

import numpy as np
import pytest

from motes.scene import SceneError, load_scene
from motes.scene.scene import BUILTIN_DIR


def advance(scene, seconds):
    for _ in range(round(seconds * scene.fps)):
        scene.advance()


@pytest.mark.slow
def test_rain_presses_the_flag_back_and_splashes_off_the_cloth():
    text = (BUILTIN_DIR / "rain_on_flag.toml").read_text()
    start = text.index("  [[system.contact]]")
    dry = text[:start] + text[text.index("  [[system.child]]") :]
    wet_scene, dry_scene = load_scene(text), load_scene(dry)
    for scene in (wet_scene, dry_scene):
        advance(scene, 1.5)
    wet = wet_scene.bodies["flag"].cloth.position
    unwet = dry_scene.bodies["flag"].cloth.position
    # The drops fall along (0, -1, -0.7): the flag is pushed down and back (-z); the
    # same gusts without the contact leave it where the wind puts it.
    assert wet[2].mean() < unwet[2].mean() - 0.02
    splashes = wet_scene.systems["splashes"]["position"]
    assert (splashes[:, 1] > 1.6).sum() > 20  # bursts off the cloth, not the ground
    assert (dry_scene.systems["splashes"]["position"][:, 1] > 1.6).sum() == 0
    drops = wet_scene.systems["drops"]["position"]
    cloth_x = wet[0].min(), wet[0].max()
    behind = (drops[:, 0] > cloth_x[0] + 0.2) & (drops[:, 0] < cloth_x[1] - 0.2)
    behind &= (drops[:, 1] > wet[1].min() + 0.2) & (drops[:, 1] < wet[1].max() - 0.2)
    behind &= drops[:, 2] < wet[2].min() - 0.05
    # Drops behind the flag came round it, not through it: far fewer than in front.
    assert behind.sum() < 0.2 * (drops[:, 2] > wet[2].max() + 0.05).sum()


SCENE = """
[[system]]
name = "drops"
  [[system.contact]]
  {contact}
[[body]]
name = "sheet"
type = "cloth"
grid = [4, 4]
[[body]]
name = "strands"
type = "hair"
"""


@pytest.mark.parametrize(
    ("contact", "path", "message"),
    [
        ('body = "nope"', "system[0].contact[0].body", "must be one of 'sheet', 'strands'"),
        ('body = "strands"', "system[0].contact[0]", "cannot collide with body 'strands'"),
        ('body = "sheet"\nresponse = "stick"', "system[0].contact[0].response", "one of"),
        ('body = "sheet"\nrestitution = 1.5', "system[0].contact[0].restitution", "<= 1"),
        ('body = "sheet"\nthickness = 0', "system[0].contact[0].thickness", "> 0"),
        ('body = "sheet"\nbounce = 1', "system[0].contact[0].bounce", "unknown key"),
    ],
)
def test_contact_mistakes_name_the_key(contact, path, message):
    with pytest.raises(SceneError, match=message) as error:
        load_scene(SCENE.format(contact=contact))
    assert error.value.path == path


def test_a_contact_needs_a_body():
    with pytest.raises(SceneError, match="no \\[\\[body\\]\\]"):
        load_scene('[[system]]\nname = "a"\n  [[system.contact]]\n  body = "flag"\n')


def test_the_contact_reaches_the_system_with_its_options():
    scene = load_scene(SCENE.format(contact='body = "sheet"\nfriction = 0.3\nparticle_mass = 0.1'))
    (contact,) = scene.systems["drops"].contacts
    assert contact.cloth is scene.bodies["sheet"].cloth
    assert (contact.friction, contact.particle_mass, contact.response) == (0.3, 0.1, "bounce")
    assert np.isfinite(contact.thickness)


STREAM = """
[scene]
fps = 30
substeps = 2

[[collider]]
type = "plane"
friction = 0.6
restitution = 0.0

[[system]]
name = "stream"
shared_colliders = false

  [[system.emitter]]
  position = [-1.0, {height}, 0.0]
  rate = {{ type = "per_second", rate = 60 }}
  speed = 20
  direction = {{ type = "cone", axis = [1, 0, 0], angle = 0 }}
  lifetime = 2.0
{contact}
[[body]]
name = "crates"
type = "rigid"
  [[body.box]]
  name = "tall"
  center = [0.0, 0.5, 0.0]
  size = [0.3, 1.0, 0.3]
  mass = 2.0
  [[body.rope]]
  start = [2.0, 2.0, 0.0]
  end = [2.0, 1.0, 0.0]
  segments = 4
"""

KNOCK = """
  [[system.contact]]
  body = "crates"
  response = "kill"
  particle_mass = 0.005
"""


def _tilt(scene) -> float:
    rotation = scene.bodies["crates"].world.transforms()[1][0]
    return float(np.degrees(np.arccos(np.clip(rotation[1, 1], -1.0, 1.0))))


@pytest.mark.slow
def test_a_stream_of_debris_knocks_a_box_of_a_rigid_body_over():
    # 60 pieces a second of 5 g at 20 m/s, 0.9 m up: a 6 N push against the 2 kg box's
    # tipping limit of 3.3 N there (tests/test_couple_rigid.py has the same case).
    knocked = load_scene(STREAM.format(height=0.9, contact=KNOCK))
    missed = load_scene(STREAM.format(height=0.9, contact=""))
    (contact,) = knocked.systems["stream"].contacts
    assert contact.world is knocked.bodies["crates"].world
    assert (contact.response, contact.particle_mass) == ("kill", 0.005)
    for scene in (knocked, missed):
        advance(scene, 1.5)
    assert _tilt(knocked) > 45.0
    assert _tilt(missed) < 1.0
    # The pieces that struck the box died on it (until it fell out of the stream's way);
    # without the contact every piece flies on.
    assert len(missed.systems["stream"]) == 90
    assert len(knocked.systems["stream"]) < 60


def test_a_contact_with_a_rigid_world_without_boxes_or_balls_is_refused():
    ropes = STREAM.format(height=0.9, contact=KNOCK)
    ropes = ropes[: ropes.index("  [[body.box]]")] + ropes[ropes.index("  [[body.rope]]") :]
    with pytest.raises(SceneError, match=r"system 'stream'.*'crates'.*no boxes or balls"):
        load_scene(ropes)


@pytest.mark.slow
def test_the_debris_example_knocks_its_tower_over():
    path = Path(__file__).resolve().parents[1] / "examples" / "scenes" / "debris.toml"
    text = path.read_text()
    start = text.index("  [[system.contact]]")
    blasted = load_scene(text)
    untouched = load_scene(text[:start] + text[text.index("  [[system.modifier]]") :])
    for scene in (blasted, untouched):
        advance(scene, 1.5)  # the blast goes off at 0.5 s
    top = [scene.bodies["tower"].world.transforms()[0][-1] for scene in (blasted, untouched)]
    # The top crate starts 2.22 m up: the blast brings it down and pushes it away from
    # the blast (+x); without the contact the debris flies through and the tower stands.
    assert top[0][1] < 1.6 and top[0][0] > 1.3
    np.testing.assert_allclose(top[1], (1.0, 2.22, 0.0), atol=0.01)
