"""The live viewer's parts: packets, the timeline, parameters, live values, sources."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from motes.color import linear_to_srgb
from motes.render.water import Water
from motes.scene import SceneError, load_scene
from motes.state import Field, ParticleState
from motes.view.packet import (
    FramePacket,
    Points,
    capacity,
    dequantize,
    fits,
    packet_of,
    padded,
    quantization_error,
    quantize,
    size_classes,
)  # fmt: skip
from motes.view.params import parameters, save_scene
from motes.view.sources import LiveSource
from motes.view.timeline import Timeline

#: A small scene: a fountain of particles over a ground, a sphere collider.
SCENE = """\
# a small fountain for the viewer's tests
[scene]
duration = 1.0
fps = 30
seed = 3

[[system]]
name = "spray"
capacity = 5000

  [[system.emitter]]
  shape = { type = "point" }
  rate = { type = "per_second", rate = 3000 }   # births per second
  speed = { uniform = [2.0, 3.0] }
  direction = { type = "cone", axis = [0, 1, 0], angle = 20 }
  lifetime = { uniform = [1.0, 2.0] }
  size = 0.02

  [[system.force]]
  type = "gravity"
  acceleration = [0.0, -9.81, 0.0]

[[collider]]
type = "plane"
point = [0, 0, 0]
normal = [0, 1, 0]
restitution = 0.3
"""


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "spray.toml"
    path.write_text(SCENE)
    return path


def test_quantize_is_within_the_stated_error():
    rng = np.random.default_rng(0)
    for scale, shift in ((1.0, 0.0), (30.0, 1000.0), (0.01, -5.0)):
        positions = shift + scale * rng.standard_normal((5000, 3))
        origin, offsets = quantize(positions)
        assert offsets.dtype == np.float16
        error = np.abs(dequantize(origin, offsets) - positions).max()
        bound = quantization_error(offsets)
        assert error <= bound
        # the bound is tight to a factor 2: half a unit in the last place
        assert bound <= 2 * np.abs(offsets.astype(np.float64)).max() * 2.0**-11 + 1e-7
    # wider than float16 reaches: float32
    origin, offsets = quantize(np.array([[0.0, 0, 0], [2e5, 0, 0]]))
    assert offsets.dtype == np.float32
    assert np.allclose(dequantize(origin, offsets), [[0, 0, 0], [2e5, 0, 0]])
    origin, offsets = quantize(np.zeros((0, 3)))
    assert offsets.shape == (0, 3)


def test_a_cloud_has_room_for_a_drifting_count():
    for n in (1, 64, 65, 1000, 123_457, 1_000_000):
        assert n <= capacity(n) <= max(64, 1.19 * n + 1)
        assert fits(n, capacity(n))
    held = capacity(10_000)
    # a count that drifts by a tenth keeps its cloud; one that doubles gets a new one
    assert all(fits(n, held) for n in range(9_000, held + 1, 97))
    assert not fits(held + 1, held) and not fits(held // 4, held)
    offsets = np.arange(30, dtype=np.float16).reshape(10, 3)
    colors = np.arange(30, dtype=np.uint8).reshape(10, 3)
    grown, grown_colors = padded(offsets, colors, 16)
    assert grown.shape == (16, 3) and np.array_equal(grown[:10], offsets)
    assert np.array_equal(grown[10:], np.repeat(offsets[:1], 6, axis=0))  # on the first
    assert np.array_equal(grown_colors[10:], np.repeat(colors[:1], 6, axis=0))


def test_additive_particles_show_their_hue_and_leave_out_the_dimmest():
    color = np.array([
        [1.0, 0.8, 0.006, 1.0],  # full light: its own colour
        [1.0, 0.4, 0.02, 1 / 3],  # a third of it: its hue at 2/3
        [1.0, 1.0, 1.0, 0.05],  # under a tenth: left out
        [1.0, 0.4, 0.02, 0.01],
    ], np.float32).T  # fmt: skip
    n = color.shape[1]
    state = ParticleState(np.arange(n, dtype=np.int64), np.arange(3.0 * n).reshape(3, n),
                          np.zeros((3, n)), np.full(n, 0.05), {"color": Field(color)})  # fmt: skip
    fire = SimpleNamespace(blend="additive", intensity=1.0)
    shown = packet_of([("system.fire", [(state, fire)], [])], None, index=1, time=0.0)
    points = shown.points["system.fire/0"]
    expected = linear_to_srgb(np.array([[1.0, 0.8, 0.006], [2 / 3, 0.4 * 2 / 3, 0.02 * 2 / 3]]))
    assert np.abs(points.colors - np.round(expected * 255)).max() <= 1  # one 8-bit level
    assert np.allclose(dequantize(points.origin, points.offsets), state.positions[:, :2].T,
                       atol=quantization_error(points.offsets))  # fmt: skip
    smoke = SimpleNamespace(blend="alpha")
    shown = packet_of([("system.smoke", [(state, smoke)], [])], None, index=1, time=0.0)
    assert len(shown.points["system.smoke/0"].offsets) == n  # alpha-blended: all, as is
    assert np.abs(shown.points["system.smoke/0"].colors - srgb8(color[:3].T)).max() <= 1
    assert shown.points["system.smoke/0"].size == pytest.approx(0.1)  # a diameter


def test_a_faint_flame_is_shown_as_its_brightest_would_be_at_full_light():
    """Additive light is judged against the system's brightest particle: a flame of
    thousands of sprites a tenth as bright each shows the same points as a bright one."""
    color = np.array([
        [1.0, 0.8, 0.006, 1.0],
        [1.0, 0.4, 0.02, 1 / 3],
        [1.0, 1.0, 1.0, 0.05],  # under a tenth of the brightest: left out
    ], np.float32).T  # fmt: skip
    n = color.shape[1]

    def shown(alpha_scale):
        faded = color.copy()
        faded[3] *= alpha_scale
        state = ParticleState(np.arange(n, dtype=np.int64), np.arange(3.0 * n).reshape(3, n),
                              np.zeros((3, n)), np.full(n, 0.05),
                              {"color": Field(faded)})  # fmt: skip
        fire = SimpleNamespace(blend="additive", intensity=1.0)
        return packet_of([("system.fire", [(state, fire)], [])], None, index=1,
                         time=0.0).points["system.fire/0"]  # fmt: skip

    bright, faint = shown(1.0), shown(0.08)
    assert len(faint.offsets) == len(bright.offsets) == 2
    assert np.abs(faint.colors.astype(int) - bright.colors).max() <= 1


def test_particles_of_many_sizes_are_sent_in_size_classes():
    """Radii from 1 to 10 cm: a few clouds, each at the size of its class, every
    particle in exactly one, of the class its radius falls in."""
    rng = np.random.default_rng(3)
    n = 5000
    radius = np.exp(rng.uniform(np.log(0.01), np.log(0.1), n))
    positions = rng.uniform(-1, 1, (3, n))
    color = np.ones((4, n), np.float32)
    state = ParticleState(np.arange(n, dtype=np.int64), positions, np.zeros((3, n)), radius,
                          {"color": Field(color)})  # fmt: skip
    shown = packet_of([("system.smoke", [(state, SimpleNamespace(blend="alpha"))], [])], None,
                      index=1, time=0.0).points  # fmt: skip
    edges, sizes = size_classes(radius)
    assert len(sizes) == 4 and list(shown) == ["system.smoke/0"] + [
        f"system.smoke/0s{c}" for c in (1, 2, 3)
    ]
    assert sizes == sorted(sizes) and 0.02 < sizes[0] < sizes[-1] < 0.2
    classes = np.searchsorted(edges, radius.astype(np.float32), side="right")
    sent = []
    for c, points in enumerate(shown.values()):
        assert points.size == pytest.approx(sizes[c])
        decoded = dequantize(points.origin, points.offsets)
        expected = positions[:, classes == c].T  # in the particles' order
        assert np.abs(decoded - expected).max() <= quantization_error(points.offsets)
        sent.append(len(decoded))
    assert sum(sent) == n
    # one size when the radii hardly differ
    assert len(size_classes(np.full(100, 0.05))[1]) == 1
    assert size_classes(np.full(100, 0.05))[1][0] == pytest.approx(0.1)


def test_a_liquid_drawn_as_water_shows_its_particles_in_its_tint():
    positions = np.random.default_rng(2).uniform(-0.2, 0.2, (50, 3))
    water = Water(positions, 0.02, color=(0.3, 0.62, 0.8))
    shown = packet_of([("body.water", [], [water])], None, index=1, time=0.0)
    points = shown.points["body.water/shape0"]
    assert shown.counts["body.water"] == 50 and points.size == pytest.approx(0.032)
    assert np.allclose(dequantize(points.origin, points.offsets), positions,
                       atol=quantization_error(points.offsets))  # fmt: skip
    assert (np.abs(points.colors - srgb8(np.array([0.3, 0.62, 0.8]))) <= 1).all()


def srgb8(linear: np.ndarray) -> np.ndarray:
    return np.round(linear_to_srgb(linear) * 255.0)


def test_colours_are_encoded_within_one_level_and_in_order():
    rng = np.random.default_rng(1)
    n = 50_000  # many blocks: the order across them is kept
    color = rng.uniform(-0.1, 1.1, (4, n)).astype(np.float32)
    positions = rng.standard_normal((3, n))
    state = ParticleState(np.arange(n, dtype=np.int64), positions, np.zeros((3, n)),
                          np.full(n, 0.01), {"color": Field(color)})  # fmt: skip
    for stride in (1, 3):
        parts = [("system.s", [(state, SimpleNamespace(blend="alpha"))], [])]
        points = packet_of(parts, None, index=1, time=0.0, stride=stride).points["system.s/0"]
        assert np.abs(points.colors - srgb8(color[:3, ::stride].T)).max() <= 1
        sent = dequantize(points.origin, points.offsets)
        error = np.abs(sent - positions[:, ::stride].T).max()
        assert error <= quantization_error(points.offsets)


def _packet(index: int, n: int) -> FramePacket:
    points = Points(np.zeros(3), np.zeros((n, 3), np.float16), np.zeros((n, 3), np.uint8), 0.1)
    return FramePacket(index, index / 30, points={"p": points})


def test_timeline_keeps_the_newest_frames_within_its_budget():
    timeline = Timeline(budget=10 * 9 * 100)  # 10 frames of 100 points (9 bytes each)
    for index in range(1, 26):
        timeline.add(_packet(index, 100))
    assert (timeline.first, timeline.last, len(timeline)) == (16, 25, 10)
    assert timeline.nbytes <= timeline.budget
    with pytest.raises(KeyError):
        timeline.get(3)
    assert timeline.get(20).index == 20
    # a frame numbered again (a restart) replaces it and every later one
    timeline.add(_packet(18, 100))
    assert (timeline.first, timeline.last) == (16, 18)
    # one frame bigger than the budget is still kept: the newest always is
    timeline.add(_packet(19, 10_000))
    assert (timeline.first, timeline.last) == (19, 19)
    with pytest.raises(ValueError, match="budget"):
        Timeline(0)


def test_parameters_are_the_files_numbers_keyed_as_set_takes_them():
    found = {p.key: p for p in parameters(SCENE)}
    assert found["scene.duration"].value == 1.0 and not found["scene.duration"].live
    assert found["system.spray.capacity"].integer and not found["system.spray.capacity"].live
    rate = found["system.spray.emitter.0.rate.rate"]
    assert (rate.value, rate.live, rate.group) == (3000, True, "system spray")
    assert found["system.spray.emitter.0.speed.uniform"].value == (2.0, 3.0)
    assert found["system.spray.force.0.acceleration"].value == (0.0, -9.81, 0.0)
    assert not found["collider.0.restitution"].live
    assert "system.spray.name" not in found
    # every key is one load_scene accepts
    for key, p in found.items():
        load_scene(SCENE, overrides={key: p.value})
    # overrides show
    tuned = {p.key: p.value for p in parameters(SCENE, {"scene.fps": 24})}
    assert tuned["scene.fps"] == 24


def test_a_grid_flow_force_acts_at_restart():
    found = {p.key: p for p in parameters(load_text("campfire"))}
    flows = [p for p in found.values() if ".force." in p.key and "response_time" in p.key]
    assert flows and not any(p.live for p in flows)


def load_text(name: str) -> str:
    from motes.scene.scene import builtin_text

    return builtin_text(name)


def test_saving_keeps_comments_and_loads_with_the_values(tmp_path):
    target = tmp_path / "tuned.toml"
    values = {"system.spray.emitter.0.rate.rate": 500, "scene.fps": 24}
    save_scene(SCENE, values, target)
    text = target.read_text()
    assert "# a small fountain" in text and "# births per second" in text
    scene = load_scene(target)
    assert scene.fps == 24
    assert {p.key: p.value for p in parameters(text)}["system.spray.emitter.0.rate.rate"] == 500


def test_a_live_value_acts_from_the_next_step(scene_file):
    source = LiveSource(scene_file)
    source.restart()
    for _ in range(5):
        source.advance()
    spray = source.scene.systems["spray"]
    count, ids = len(spray), set(spray.particle_state().ids.tolist())
    waiting = source.set_values({"system.spray.emitter.0.rate.rate": 0})
    assert waiting == []
    assert source.scene.systems["spray"] is spray  # the same particles, going on
    source.advance()
    # no births: every particle is one of before (some may have died)
    assert set(spray.particle_state().ids.tolist()) <= ids
    assert len(spray) <= count
    # and the gravity made stronger pulls harder from the next step
    source.set_values({"system.spray.force.0.acceleration": [0.0, -30.0, 0.0]})
    before = spray.particle_state().velocities[1].copy()
    source.advance()
    after = spray.particle_state().velocities[1]
    assert np.median(after - before[: len(after)]) < -0.5  # ~ -1 m/s per frame, not -0.33


def live_scene(tmp_path, text: str, frames: int):
    """A :class:`LiveSource` of scene file ``text`` run ``frames`` frames, and the file's
    parameters by key."""
    path = tmp_path / "live.toml"
    path.write_text(text)
    source = LiveSource(path)
    source.restart()
    for _ in range(frames):
        source.advance()
    return source, {p.key: p for p in parameters(text)}


BODIES = """\
[scene]
duration = 1.0
fps = 30

[[body]]
name = "water"
type = "fluid"
spacing = 0.05
viscosity = 0.01
  [[body.wall]]
  type = "tank"
  lower = [0, 0, 0]
  upper = [0.6, 0.6, 0.3]
  [[body.block]]
  lower = [0, 0, 0]
  upper = [0.3, 0.3, 0.3]

[[body]]
name = "birds"
type = "flock"
count = 300
speed = 3.0
max_speed = 4.0
"""


def test_a_liquids_and_a_flocks_live_values_act_on_them_from_the_next_step(tmp_path):
    source, found = live_scene(tmp_path, BODIES, 3)
    assert found["body.water.viscosity"].live and not found["body.water.spacing"].live
    assert found["body.birds.max_speed"].live and not found["body.birds.count"].live
    water, birds = source.scene.bodies["water"], source.scene.bodies["birds"]
    held = water.count()
    values = {"body.water.viscosity": 0.2, "body.water.iterations": 6, "body.birds.max_speed": 1.5}
    assert source.set_values(values) == []
    assert source.scene.bodies["water"] is water and source.scene.bodies["birds"] is birds
    assert (water.fluid.model.viscosity, water.fluid.model.iterations) == (0.2, 6)
    assert water.fluid.model.derived["h"] == 2 * 0.05  # the resolution is kept
    source.advance()
    assert water.count() == held  # the same particles, going on
    speeds = np.linalg.norm(birds.flock.velocity, axis=0)
    assert speeds.max() <= 1.5 * (1 + 1e-5) and speeds.min() > 1.0  # slowed, not reset
    # a value that shapes the body waits for the restart
    assert source.set_values({"body.water.spacing": 0.04}) == ["body.water.spacing"]
    assert water.fluid.model.spacing == 0.05


CLOTH = """\
[scene]
duration = 1.0
fps = 30

[[body]]
name = "cloth"
type = "cloth"
grid = [12, 12]
structural = [200, 0.2]
air_damping = 0.1
pin_rows = [-1]
"""


def test_a_cloths_springs_and_gravity_act_live_over_its_state(tmp_path):
    source, found = live_scene(tmp_path, CLOTH, 5)
    assert found["body.cloth.structural"].live and found["body.cloth.air_damping"].live
    assert not found["body.cloth.grid"].live
    cloth = source.scene.bodies["cloth"].cloth
    before = cloth.position.copy()
    values = {"body.cloth.structural": [800.0, 0.5], "body.cloth.air_damping": 0.4}
    assert source.set_values(values) == []
    assert source.scene.bodies["cloth"].cloth is cloth
    model = cloth.model
    assert (model.structural.stiffness, model.structural.damping) == (800.0, 0.5)
    assert model.air_damping == 0.4 and model.springs.stiffness.max() == 800.0
    np.testing.assert_array_equal(cloth.position, before)  # nothing reset
    source.advance()
    assert not np.array_equal(cloth.position, before)  # it goes on
    assert source.set_values({"body.cloth.grid": [10, 10]}) == ["body.cloth.grid"]
    # while the new mesh waits for the restart, the running cloth keeps its values
    assert source.set_values({"body.cloth.air_damping": 0.2}) == []
    assert cloth.model.air_damping == 0.4 and cloth.n == 144
    source.restart()
    assert source.scene.bodies["cloth"].cloth.model.air_damping == 0.2


HAIR = """\
[scene]
duration = 1.0
fps = 30

[[body]]
name = "hair"
type = "hair"
strands = 30
particles = 6
stretch = [500.0, 0.02]
air_damping = 1.0
"""


def test_hairs_springs_act_live_over_its_strands(tmp_path):
    source, found = live_scene(tmp_path, HAIR, 3)
    assert found["body.hair.stretch"].live and not found["body.hair.strands"].live
    hair = source.scene.bodies["hair"].hair
    springs, position = hair.model.springs, hair.position.copy()
    assert source.set_values({"body.hair.stretch": [900.0, 0.05]}) == []
    assert hair.model.springs is not springs and hair.model.air_damping == 1.0
    np.testing.assert_array_equal(hair.position, position)
    assert source.set_values({"body.hair.strands": 40}) == ["body.hair.strands"]
    assert source.set_values({"body.hair.air_damping": 2.0}) == []
    assert hair.model.air_damping == 1.0  # new strands wait for the restart: so does this


GRID = """\
[scene]
duration = 1.0
fps = 30

[[body]]
name = "smoke"
type = "grid_fluid"
resolution = [16, 24]
cell_size = 0.05
vorticity = 0.5
  [body.buoyancy]
  density_weight = 0.0
  heat_weight = 0.01
  [[body.source]]
  center = [0.4, 0.2, 0.0]
  radius = 0.1
  temperature = 600.0
"""


def test_a_grid_fluids_forces_act_live_over_its_fields(tmp_path):
    source, found = live_scene(tmp_path, GRID, 4)
    assert found["body.smoke.vorticity"].live and found["body.smoke.buoyancy.heat_weight"].live
    assert not found["body.smoke.cell_size"].live
    assert not found["body.smoke.source.0.temperature"].live
    fluid = source.scene.bodies["smoke"].fluid
    density = fluid.density.copy()
    values = {"body.smoke.vorticity": 2.0, "body.smoke.buoyancy.heat_weight": 0.05}
    assert source.set_values(values) == []
    assert source.scene.bodies["smoke"].fluid is fluid
    assert fluid.vorticity == 2.0 and fluid.buoyancy.heat_weight == 0.05
    np.testing.assert_array_equal(fluid.density, density)  # nothing reset
    source.advance()
    assert fluid.time > 4 / 30


WORLDS = """\
[scene]
duration = 1.0
fps = 30

[[body]]
name = "cradle"
type = "pendulums"
count = 3
iterations = 8

[[body]]
name = "sky"
type = "clouds"
resolution = [8, 4, 8]
cell_size = 10.0
base_height = 0.0
top_height = 40.0
scale = 40.0
wind = [6.0, 0.0, 0.0]
  [body.render]
  extinction = 0.1
"""


def test_a_rigid_worlds_settings_and_a_skys_wind_act_live(tmp_path):
    source, found = live_scene(tmp_path, WORLDS, 3)
    assert found["body.cradle.iterations"].live and not found["body.cradle.count"].live
    assert found["body.sky.wind"].live and not found["body.sky.scale"].live
    cradle, sky = source.scene.bodies["cradle"], source.scene.bodies["sky"]
    world, position = cradle.world, cradle.world.position.copy()
    drift = sky.drift.copy()
    values = {
        "body.cradle.gravity": [0.0, -1.0, 0.0],
        "body.cradle.iterations": 20,
        "body.sky.wind": [0.0, 0.0, -3.0],
    }
    assert source.set_values(values) == []
    assert source.scene.bodies["cradle"] is cradle and cradle.world is world
    assert world.iterations == 20 and world.gravity.tolist() == [0.0, -1.0, 0.0]
    np.testing.assert_array_equal(world.position, position)  # nothing reset
    source.advance()
    assert not np.array_equal(world.position, position)  # it goes on
    # the clouds go on from where the old wind took them
    np.testing.assert_allclose(sky.drift, drift + np.array([0.0, 0.0, -3.0]) / 30)
    (volume,) = sky.drawables()
    np.testing.assert_allclose(volume.origin, sky.origin + sky.drift)
    assert source.set_values({"body.cradle.count": 4}) == ["body.cradle.count"]


def test_every_rigid_body_type_has_live_world_settings():
    from typing import get_type_hints

    from motes.scene.bodies import BODY_TYPES, LIVE_KEYS, _load_types
    from motes.scene.body_rigid import RigidScene

    _load_types()
    for kind, builder in BODY_TYPES.items():
        rigid = issubclass(get_type_hints(builder)["return"], RigidScene)
        assert rigid == ("projection" in LIVE_KEYS.get(kind, ())), kind


def test_a_value_out_of_range_changes_nothing(scene_file):
    source = LiveSource(scene_file)
    source.restart()
    source.advance()
    with pytest.raises(SceneError, match=r"rate.*>= 0"):
        source.set_values({"system.spray.emitter.0.rate.rate": -5})
    assert "system.spray.emitter.0.rate.rate" not in source.overrides
    # a restart-only value waits for the restart
    assert source.set_values({"scene.duration": 2.0}) == ["scene.duration"]
    assert source.scene.duration == 1.0
    source.restart()
    assert source.scene.duration == 2.0 and source.available == 0


def test_a_frame_decodes_to_the_positions_simulated(scene_file):
    source = LiveSource(scene_file)
    source.restart()
    for _ in range(8):
        packet = source.advance()
    points = packet.points["system.spray/0"]
    simulated = source.scene.systems["spray"].particle_state().positions.T
    sent = dequantize(points.origin, points.offsets)
    assert sent.shape == simulated.shape
    assert np.abs(sent - simulated).max() <= quantization_error(points.offsets)
    assert points.colors.dtype == np.uint8 and points.colors.shape == simulated.shape
    assert packet.counts["system.spray"] == len(simulated)


def test_objects_are_static_and_a_cloth_is_a_moving_mesh():
    source = LiveSource("cloth_drop")
    source.restart()
    static = source.static()
    assert len(static.meshes) >= 2 and not static.points  # the ground and the sphere
    first = source.advance().meshes["body.cloth/shape0"]
    for _ in range(5):
        packet = source.advance()
    cloth = packet.meshes["body.cloth/shape0"]
    assert cloth.faces.shape == first.faces.shape and cloth.faces.shape[0] > 1000
    assert not np.array_equal(cloth.vertices, first.vertices)  # it falls
    positions = source.scene.bodies["cloth"].particle_state().positions.T
    low, high = positions.min(axis=0) - 0.05, positions.max(axis=0) + 0.05
    assert np.all((cloth.vertices >= low) & (cloth.vertices <= high))


def test_a_stride_thins_big_systems(scene_file):
    source = LiveSource(scene_file)
    source.restart()
    source.max_points = 600
    for _ in range(10):
        packet = source.advance()
    live = packet.counts["system.spray"]
    sent = len(packet.points["system.spray/0"].offsets)
    stride = -(-live // 600)
    assert live > 600 and sent == len(range(0, live, stride)) and sent <= 600
