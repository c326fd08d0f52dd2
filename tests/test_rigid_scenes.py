"""The rigid-body scenes run headless and keep their invariants; their keys are checked."""

import numpy as np
import pytest

from motes.render import geometry
from motes.scene import SceneError, load_scene

SIZE = (96, 54)


def advance(scene, seconds):
    for _ in range(round(seconds * scene.fps)):
        scene.advance()


def test_ragdoll_stairs_never_enters_a_step_and_keeps_its_limits():
    scene = load_scene("ragdoll_stairs")
    body = scene.bodies["ragdoll"]
    world = body.world
    steps = [c for c in world.colliders if type(c).__name__ == "Box"]
    assert len(steps) == 6
    for _ in range(round(2.0 * scene.fps)):
        scene.advance()
        for box in steps:
            local = (world.position - box.center) @ box.rotation
            assert not np.any(np.all(np.abs(local) < box.half_extent, axis=1))
    doll = world.position
    assert np.isfinite(doll).all() and doll[:, 2].mean() > 0.6  # on its way down
    assert scene.render(SIZE).std() > 2
    # drawn with volume: a capsule per limb and trunk part, each end on a joint (or
    # midway between two: the hips' and shoulders' middles)
    capsules = [d for d in body.drawables() if isinstance(d, geometry.Capsule)]
    assert len(capsules) == 13
    joints = world.position
    middles = (joints[:, None] + joints[None, :]).reshape(-1, 3) / 2
    for capsule in capsules:
        for end in (capsule.a, capsule.b):
            assert np.abs(middles - end).max(axis=1).min() < 1e-9
        assert 0.03 < capsule.radius < 0.12


def test_rope_bridge_catches_the_crates():
    scene = load_scene("rope_bridge")
    advance(scene, 2.0)
    world = scene.bodies["bridge"].world
    centre, _ = world.transforms()
    crates = centre[-3:]
    assert np.all(crates[:, 1] > 0.8)  # resting on the bridge (1.5 m up), not the ground
    ropes = scene.bodies["bridge"].lines
    lengths = np.linalg.norm(world.position[ropes[:, 1]] - world.position[ropes[:, 0]], axis=1)
    assert lengths.max() < 0.2  # ropes between neighbouring planks hold (rest ~0.07 m)


def test_pendulums_pass_the_blow_to_the_last_ball():
    scene = load_scene("pendulums")
    body = scene.bodies["cradle"]
    world = body.world
    strings = body.lines
    rest = np.linalg.norm(world.position[strings[:, 1]] - world.position[strings[:, 0]], axis=1)
    balls = [particle for particle, _, _ in body.spheres]
    start = world.position[balls].copy()
    out = np.zeros(len(balls))
    for _ in range(round(1.0 * scene.fps)):  # the strike at 0.5 s, the last ball's swing
        scene.advance()
        out = np.maximum(out, np.linalg.norm(world.position[balls] - start, axis=1))
    now = np.linalg.norm(world.position[strings[:, 1]] - world.position[strings[:, 0]], axis=1)
    np.testing.assert_allclose(now, rest, rtol=1e-3)
    # A real cradle: the last ball swings out as far as the first was pulled back
    # (0.77 m along x from 50°; measured 0.766 m), the middle ones stay nearly still
    # (measured: 4 mm, the push of the position pass through the row).
    assert out[-1] > 0.7
    assert out[1:-1].max() < 0.02


def test_box_tower_stands_until_knocked_over():
    scene = load_scene("box_tower")
    world = scene.bodies["tower"].world
    start, _ = world.transforms()
    advance(scene, 0.3)  # settled (the stack compresses by ~3 cm under its weight)
    settled, _ = world.transforms()
    advance(scene, 0.6)
    before, _ = world.transforms()
    assert np.abs(before[:-1] - settled[:-1]).max() < 0.005  # standing before the throw
    advance(scene, 2.5)
    after, _ = world.transforms()
    assert after[:-1, 1].max() < 0.75 * start[:-1, 1].max()  # the top has come down


def test_swept_wall_stops_the_ball_and_posteriori_wall_lets_it_through():
    scene = load_scene("swept_vs_posteriori")
    world = scene.bodies["shots"].world
    shots = world.count - 2 + np.arange(2)
    furthest = np.full(2, -np.inf)
    for _ in range(round(0.75 * scene.fps)):
        scene.advance()
        furthest = np.maximum(furthest, world.position[shots, 0])
    assert furthest[0] < 0.0  # a priori: never past the 1 cm wall
    assert furthest[1] > 1.0  # a posteriori: through it
    assert scene.render(SIZE).std() > 2


SCENE = """
[scene]
duration = 1
[camera]
position = [0, 1, 4]
target = [0, 0.5, 0]
resolution = [64, 48]
[[body]]
name = "b"
type = "{kind}"
{extra}
"""


@pytest.mark.parametrize(
    ("kind", "extra", "path", "message"),
    [
        ("ragdoll_stairs", "steps = 0", "body[0].steps", "must be >= 1"),
        ("rope_bridge", "span = -1", "body[0].span", "must be > 0"),
        ("pendulums", "colour = 1", "body[0].colour", "unknown key"),
        ("box_tower", "iterations = 0", "body[0].iterations", "must be >= 1"),
        ("swept_vs_posteriori", 'projection = "x"', "body[0].projection", "must be one of"),
    ],
)
def test_rigid_scene_mistakes_name_the_key(kind, extra, path, message):
    with pytest.raises(SceneError, match=message) as error:
        load_scene(SCENE.format(kind=kind, extra=extra))
    assert error.value.path == path


def test_a_shared_collider_a_rigid_world_cannot_use_is_a_scene_error():
    text = SCENE.format(kind="box_tower", extra="") + (
        '[[collider]]\ntype = "plane"\nresponse = "kill"\n'
    )
    with pytest.raises(SceneError, match="response 'bounce' only") as error:
        load_scene(text)
    assert error.value.path == "body[0]"
