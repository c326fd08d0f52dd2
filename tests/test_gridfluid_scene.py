"""Grid fluids in scene files: the ``grid_fluid`` body, drawn as a volume; systems riding
its flow (``grid_flow``) and feeding it (``particle_source``); bad references."""

from __future__ import annotations

import numpy as np
import pytest

from motes.render.volume import Volume
from motes.scene import SceneError, load_scene

SCENE = """
[scene]
duration = 1.0
fps = 20
seed = 3

[camera]
position = [0.0, 0.8, 3.0]
target = [0.0, 0.8, 0.0]
resolution = [96, 64]

[[collider]]
type = "sphere"
center = [0.0, 1.0, 0.0]
radius = 0.2

[[system]]
name = "embers"
capacity = 500

  [[system.emitter]]
  shape = { type = "disc", radius = 0.2 }
  position = [0.0, 0.2, 0.0]
  rate = { type = "per_second", rate = 200 }
  speed = 0.0
  lifetime = 5.0
  size = 0.01

  [[system.force]]
  type = "grid_flow"
  body = "air"
  response_time = 0.05

[[body]]
name = "air"
type = "grid_fluid"
resolution = [16, 24, 16]
cell_size = 0.1
origin = [-0.8, 0.0, -0.8]
vorticity = 1.0
walls = { "+y" = "open" }

  [body.buoyancy]
  heat_weight = 0.01

  [[body.source]]
  center = [0.0, 0.25, 0.0]
  radius = 0.3
  density = 3.0
  temperature = 800.0

  [[body.particle_source]]
  system = "embers"
  density = 0.5
  temperature = 600.0

  [body.render]
  extinction = 8.0
  emission = 0.5
  edge_fade = 2
"""


def test_a_grid_fluid_body_rises_carries_particles_and_draws_a_volume():
    scene = load_scene(SCENE)
    body = scene.bodies["air"]
    assert body.fluid.solid.any()  # the shared sphere collider is an obstacle
    for _ in range(15):
        scene.advance()
    fluid = body.fluid
    assert fluid.v.max() > 0.3  # hot gas rises [m/s]
    assert np.all(fluid.density[fluid.solid == 1] == 0.0)
    embers = scene.systems["embers"]
    # emitted at rest, they take the rising flow's velocity
    assert embers["velocity"][:, 1].mean() > 0.1
    drawn = body.drawables()
    assert len(drawn) == 1 and isinstance(drawn[0], Volume)
    assert drawn[0].shape == (16, 24, 16)
    plain = load_scene(SCENE.replace("  [body.render]", "  [body.render]\n  visible = false"))
    for _ in range(15):
        plain.advance()
    image, without = scene.render(), plain.render()
    assert np.abs(image.astype(int) - without.astype(int)).mean() > 1.0  # the smoke shows


def test_particles_heat_the_grid_where_they_are():
    hot = load_scene(SCENE.replace("temperature = 800.0", "temperature = 300.0"))
    cold = load_scene(
        SCENE.replace("temperature = 800.0", "temperature = 300.0").replace(
            "temperature = 600.0", "temperature = 300.0"
        )
    )
    for scene in (hot, cold):
        for _ in range(5):
            scene.advance()
    t_hot = hot.bodies["air"].fluid.temperature.max()
    t_cold = cold.bodies["air"].fluid.temperature.max()
    assert t_hot > t_cold + 50.0  # [K]


@pytest.mark.parametrize(
    ("change", "where"),
    [
        (('body = "air"', 'body = "nowhere"'), "system[0].force[0].body"),
        (('system = "embers"', 'system = "smoke"'), "body[0].particle_source[0].system"),
        (("cell_size = 0.1", "cell_size = -0.1"), "body[0].cell_size"),
        (('"+y" = "open"', '"+y" = "leaky"'), "body[0].walls.'+y'"),
        (("resolution = [16, 24, 16]", "resolution = [16]"), "body[0].resolution"),
    ],
)
def test_bad_grid_fluid_keys_are_named(change, where):
    with pytest.raises(SceneError) as caught:
        load_scene(SCENE.replace(*change))
    assert where in str(caught.value)


def test_grid_flow_needs_a_grid_fluid_body():
    text = SCENE.split("[[body]]")[0] + ('[[body]]\nname = "air"\ntype = "fluid"\nspacing = 0.05\n')
    with pytest.raises(SceneError, match="grid_fluid"):
        load_scene(text)


CLOUDS = """
[scene]
duration = 1.0
fps = 10

[camera]
position = [0.0, 20.0, 0.0]
target = [0.0, 400.0, -2000.0]
far = 10000.0
resolution = [64, 40]

[[body]]
name = "sky"
type = "clouds"
resolution = [48, 12, 32]
cell_size = 50.0
origin = [-1200.0, 300.0, -2000.0]
base_height = 350.0
top_height = 800.0
scale = 600.0
coverage = 0.6
wind = [20.0, 0.0, 0.0]

  [body.render]
  extinction = 0.2
"""


def test_a_clouds_body_draws_procedural_clouds_drifting_with_the_wind():
    scene = load_scene(CLOUDS)
    sky = scene.bodies["sky"]
    assert sky.density.shape == (32, 12, 48) and sky.density.max() > 0.0
    first = sky.drawables()[0]
    for _ in range(5):
        scene.advance()
    moved = sky.drawables()[0]
    # 0.5 s of a 20 m/s wind along x
    np.testing.assert_allclose(moved.origin - first.origin, [10.0, 0.0, 0.0], atol=1e-9)
    assert scene.render().std() > 2  # clouds against the sky, not one flat colour
    with pytest.raises(SceneError, match="coverage"):
        load_scene(CLOUDS.replace("coverage = 0.6", "coverage = 1.6"))
