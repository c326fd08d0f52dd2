"""The fluid scenes run headless and keep their invariants; fluid body tables are checked."""

import numpy as np
import pytest

from motes.render import geometry
from motes.render.water import Water
from motes.scene import SceneError, load_scene

SIZE = (96, 54)


def run(name, seconds):
    scene = load_scene(name)
    for _ in range(round(seconds * scene.fps)):
        scene.advance()
    body = next(iter(scene.bodies.values()))
    image = scene.render(SIZE)
    assert image.std() > 2
    fluid = body.fluid
    assert np.isfinite(fluid.positions).all() and np.isfinite(fluid.velocities).all()
    return scene, body, fluid


def test_dam_break_surges_and_stays_in_its_tank():
    _scene, body, water = run("dam_break", 0.5)
    p, s = water.positions, water.model.spacing
    assert len(water) == 16 * 24 * 12
    assert (p[0] >= s / 2 - 1e-6).all() and (p[0] <= 1.6 - s / 2 + 1e-6).all()
    assert (p[1] >= s / 2 - 1e-6).all() and (p[2] <= 0.3 - s / 2 + 1e-6).all()
    assert p[0].max() > 1.0  # the front left the column (0.4 m) behind
    assert any(isinstance(d, Water) for d in body.drawables())


def test_honey_piles_on_the_plate_and_sticks():
    _scene, _body, honey = run("honey", 1.5)
    p = honey.positions
    assert len(honey) > 300
    on_plate = (np.abs(p[0]) < 0.15) & (np.abs(p[2]) < 0.15) & (p[1] < 0.15)
    assert on_plate.sum() > 100
    assert (p[1] > 0.11 - 1e-4)[on_plate].all()  # none sank into the plate (top at 0.11)


def test_two_liquids_stay_apart_while_the_tank_shakes():
    _scene, body, liquids = run("two_liquids", 1.5)
    y, phase = liquids.positions[1], liquids.state.phase
    assert y[phase == 1].mean() > y[phase == 0].mean() + 0.05  # oil floats on water
    tank = body.shakes[0].tank
    p = liquids.positions
    assert (p >= tank.lower[:, None] - 1e-4).all()
    assert tank.lower[0] != 0.0  # it moved
    meshes = [d for d in body.drawables() if isinstance(d, geometry.Mesh)]
    assert len(meshes) == 2  # one surface per liquid


def test_fountain_jet_rises_to_its_ballistic_height_with_spray():
    _scene, body, water = run("fountain", 1.0)
    assert len(water) > 16 * 4 * 16 * 2  # the nozzle added particles
    # Launched at 3.2 m/s from 0.12 m: at most 0.12 + v²/2g = 0.64 m, plus a spacing for
    # the pushes of the density solve.
    assert water.positions[1].max() < 0.64 + 0.05
    assert water.positions[1].max() > 0.4
    sprites = body.particles()
    assert sprites and 0 < len(sprites[0][0]) < len(water)


SCENE = """
[scene]
fps = 30
duration = 1
[camera]
position = [0, 1, 3]
target = [0, 0.2, 0]
resolution = [64, 48]
[[body]]
name = "water"
type = "fluid"
spacing = 0.05
  [[body.block]]
  lower = [0, 0, 0]
  upper = [0.2, 0.2, 0.2]
  [[body.wall]]
  type = "tank"
  lower = [0, 0, 0]
  upper = [0.5, 0.5, 0.5]
"""


def test_a_fluid_body_from_text_draws_particles_when_asked():
    scene = load_scene(SCENE + '  [body.render]\n  mode = "particles"\n')
    scene.advance()
    ((state, _style),) = scene.bodies["water"].particles()
    assert state.count == 64 and state.positions.shape == (3, 64)
    assert state["color"].shape == (4, 64) and state.unit("color") == "1"
    assert scene.counts() == {"water": 64}


def test_a_fluid_body_draws_as_clear_water_with_foam():
    water_look = (
        '  [body.render]\n  mode = "water"\n  clarity = 0.1\n  foam_kinetic = [0.0, 0.01]\n'
    )
    scene = load_scene(SCENE + water_look)
    body = scene.bodies["water"]
    for _ in range(6):
        scene.advance()
    (water,) = [d for d in body.drawables() if isinstance(d, Water)]
    assert water.positions.shape == (64, 3) and water.volume == pytest.approx(0.05**3)
    assert water.clarity == 0.1 and water.radius == pytest.approx(0.05)
    # the falling block's rim is a crest moving out along its normal: froth, white
    ((froth, style),) = body.particles()
    assert 0 < froth.count < 64 and style.lit
    assert (froth["color"][:3] == 1).all() and (froth["color"][3] > 0).all()
    image = scene.render((64, 48))
    plain = load_scene(SCENE).render((64, 48))  # the metaball surface at the start
    assert image.std() > 2 and not np.array_equal(image, plain)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('mode = "glass"', "must be one of 'particles', 'surface', 'water'"),
        ("foam_kinetic = [2.0, 1.0]", "must be [low, high] with low < high"),
        ("clarity = 0", "must be > 0"),
    ],
)
def test_water_look_mistakes_name_the_key(text, message):
    with pytest.raises(SceneError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_scene(SCENE + "  [body.render]\n  " + text + "\n")


def test_a_water_tint_without_a_channel_is_named():
    phase = "  [[body.phase]]\n  color = [0.0, 0.5, 1.0]\n"
    with pytest.raises(SceneError, match=r"each channel in \(0, 1\]") as error:
        load_scene(SCENE + phase + '  [body.render]\n  mode = "water"\n')
    assert error.value.path == "body[0].phase[0].color"


@pytest.mark.parametrize(
    ("replace", "path", "message"),
    [
        ("spacing = 0.05", "body[0].spacing", "must be > 0"),
        ('type = "tank"', "body[0].wall[0].type", "must be one of"),
        ("upper = [0.5, 0.5, 0.5]", "body[0].wall[0]", "upper must exceed lower"),
        ("lower = [0, 0, 0]\n  upper = [0.2", "body[0].block[0].colour", "unknown key"),
    ],
)
def test_fluid_table_mistakes_name_the_key(replace, path, message):
    bad = {
        "body[0].spacing": "spacing = -1",
        "body[0].wall[0].type": 'type = "bucket"',
        "body[0].wall[0]": "upper = [0.5, -0.5, 0.5]",
        "body[0].block[0].colour": "colour = 1\n  lower = [0, 0, 0]\n  upper = [0.2",
    }[path]
    with pytest.raises(SceneError, match=message) as error:
        load_scene(SCENE.replace(replace, bad, 1))
    assert error.value.path == path
