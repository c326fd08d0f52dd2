"""Every built-in scene runs headless for a few frames and keeps its invariants."""

import numpy as np
import pytest

from motes.scene import builtin_scenes, load_scene

SIZE = (96, 54)


def advance(scene, seconds):
    for _ in range(round(seconds * scene.fps)):
        scene.advance()


def check_common(scene):
    for name, system in scene.systems.items():
        n = len(system)
        assert n <= system.store.capacity, name
        assert np.isfinite(system["position"]).all(), name
        assert np.isfinite(system["velocity"]).all(), name
    image = scene.render(SIZE)
    assert image.shape == (SIZE[1], SIZE[0], 3)
    assert image.std() > 2, "the image is empty (one flat colour)"
    return image


# The costliest scenes to compile and run (30-100 s each from an empty kernel cache);
# each keeps a scene test of its own in the default run or the slow tier.
# rain, waterfall and fish_school keep tests of their own (test_rain_*, test_waterfall_*,
# test_flock_scene); planets' placements and light are tested in test_nbody and
# test_scene_files; grains' collisions in test_particle_collisions; smoke and snow load
# in test_scene_files (their lighting: test_shadows; snow: test_snow_settles_*); the grid
# fluid scenes' body, flow and sources are tested on a small grid in test_gridfluid_scene.
SLOW_SCENES = {
    "floating", "rain_on_flag", "explosion", "box_tower", "galaxies", "rain", "fish_school",
    "waterfall", "planets", "grains", "smoke", "snow", "smoke_plume", "campfire", "clouds",
}  # fmt: skip


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(name, marks=pytest.mark.slow) if name in SLOW_SCENES else name
        for name in sorted(builtin_scenes())
    ],
)
def test_builtin_scene_runs_and_renders(name):
    scene = load_scene(name)
    advance(scene, 1.0)
    check_common(scene)
    assert sum(scene.counts().values()) > 0


def test_fire_reaches_a_steady_population():
    scene = load_scene("fire")
    advance(scene, 2.0)
    count = len(scene.systems["flame"])
    # 14,000 births/s living 0.5–1.2 s (mean 0.85 s): about 11,900 when steady.
    assert 10_000 < count < 14_000
    assert 0 < len(scene.systems["embers"]) < 200  # 40 births/s living 1–2.5 s
    colors = scene.systems["flame"]["color"]
    assert (colors[:, 0] >= colors[:, 2]).all()  # white-yellow to red: never bluer than red


def test_fireworks_rockets_burst_into_sparks_with_their_colours():
    scene = load_scene("fireworks")
    advance(scene, 2.5)
    sparks = scene.systems["sparks"]
    assert len(sparks) >= 200 and len(scene.systems["trails"]) > 0
    hue = sparks["color"][:, :3] / sparks["color"][:, :3].max(axis=1, keepdims=True)
    assert np.unique(hue.round(2), axis=0).shape[0] >= 2  # more than one rocket colour


@pytest.mark.slow
def test_rain_collisions_spawn_splashes_above_the_ground():
    scene = load_scene("rain")
    advance(scene, 1.5)
    splashes = scene.systems["splashes"]
    assert len(splashes) > 100
    assert (splashes["position"][:, 1] >= -1e-3).all()
    assert (scene.systems["drops"]["position"][:, 1] >= -1e-3).all()


@pytest.mark.slow
def test_explosion_debris_stays_on_the_ground_and_slows_down():
    scene = load_scene("explosion")
    advance(scene, 4.0)
    debris = scene.systems["debris"]
    assert len(debris) == 500  # one burst of 500, living 5-6.5 s: all still there
    blast = scene.bodies["blast"].fluid
    rows = blast.density.sum(axis=(0, 2))
    assert np.argmax(rows) * blast.cell_size > 1.5  # the smoke has risen off the ground [m]
    assert (debris["position"][:, 1] >= -1e-3).all()  # never below the ground
    speed = np.linalg.norm(debris["velocity"], axis=1)
    assert np.median(speed) < 1.0  # friction and restitution have taken the energy


@pytest.mark.slow
def test_snow_settles_on_the_sphere_and_the_ground():
    scene = load_scene("snow")
    advance(scene, 5.5)  # flakes fall at about g / drag = 1.2 m/s from 4.5 m
    flakes = scene.systems["flakes"]
    position = flakes["position"]
    resting = np.linalg.norm(flakes["velocity"], axis=1) == 0
    on_sphere = np.abs(np.linalg.norm(position - [0, 0.9, 0], axis=1) - 0.9) < 1e-2
    on_ground = np.abs(position[:, 1]) < 1e-3
    assert (resting & on_sphere).sum() > 50
    assert (resting & on_ground).sum() > 500
    assert (position[:, 1] >= -1e-3).all()


@pytest.mark.slow
def test_waterfall_spray_rises_from_the_pool():
    scene = load_scene("waterfall")
    advance(scene, 2.0)
    spray = scene.systems["spray"]
    assert len(spray) > 100
    assert (spray["velocity"][:, 1] > 0).any()
    assert (scene.systems["water"]["position"][:, 0] > 0).all()  # falls in front of the ledge


def test_level_of_detail_spends_particles_by_screen_area(capsys):
    scene = load_scene("lod")
    advance(scene, 1.5)
    near, far = len(scene.systems["near"]), len(scene.systems["far"])
    print(f"level of detail: near {near} particles, far {far}")
    fractions = [
        scene.camera.screen_fraction(s.emitters[0].position_at(0), 0.9)
        for s in (scene.systems["near"], scene.systems["far"])
    ]
    # Births scale with the covered screen area, so counts keep its ratio (±25 %: the
    # two fires' lifetimes are drawn independently).
    assert near / far == pytest.approx(fractions[0] / fractions[1], rel=0.25)
    assert "near" in capsys.readouterr().out
