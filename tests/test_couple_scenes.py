"""Kinds acting on each other in scene files: ``[[system.contact]]`` with a body."""

import numpy as np
import pytest

from motes.scene import SceneError, load_scene
from motes.scene.scene import BUILTIN_DIR


def advance(scene, seconds):
    for _ in range(round(seconds * scene.fps)):
        scene.advance()


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
