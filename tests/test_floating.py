"""Liquids and rigid bodies act on each other: boxes float, sink and displace water."""

from __future__ import annotations

import numpy as np
import pytest

from floating_case import surface, tank_with_box, tilt
from motes.couple.fluid_rigid import FloatingBodies
from motes.fluids import FluidModel, lattice
from motes.fluids.fluid import Fluid
from motes.rigid import World
from motes.rigid.shapes import BodyShape

SIZE = 0.2


def settle(pair, seconds: float, dt: float = 1 / 60) -> None:
    for _ in range(round(seconds / dt)):
        pair.step(dt)


@pytest.mark.slow
def test_a_light_box_floats_held_up_by_its_weight_and_a_dense_one_sinks():
    # Held upright: a cube at half water's density is unstable upright (see below).
    light = tank_with_box(0.5, spacing=0.04, width=0.48, turn=False)
    heavy = tank_with_box(2.0, spacing=0.04, width=0.48)
    for pair in (light, heavy):
        settle(pair, 1.5)
    pushes = []
    for _ in range(30):
        light.step(1 / 60)
        pushes.append(light.force[0])
    weight = 0.5 * 1000 * SIZE**3 * 9.81
    (center,), _ = light.world.transforms()
    level = surface(light.fluid, 0.04, center, 0.2)
    # Floating: the bottom under the surface, the top above, and the liquid's push,
    # over half a second, equal to its weight (each step's push jitters by about half
    # the weight at this coarse resolution, 5 particles across the box; 2 % on the mean).
    assert center[1] - SIZE / 2 < level < center[1] + SIZE / 2
    np.testing.assert_allclose(np.mean(pushes, axis=0), (0, weight, 0), atol=0.02 * weight)
    # Sinking: a box twice as dense as water rests on the floor.
    (bottom,), _ = heavy.world.transforms()
    assert bottom[1] - SIZE / 2 < 0.01


def test_a_liquid_hitting_a_free_box_keeps_the_momentum_of_the_two():
    # No gravity and no tank: whatever the liquid loses, the box gains.
    spacing = 0.04
    model = FluidModel(spacing=spacing, gravity=(0, 0, 0), xsph=0.1)
    blob = lattice((0.0, 0.0, 0.0), (0.24, 0.24, 0.24), spacing)
    water = Fluid(model, blob, velocities=np.tile([[2.0], [0.3], [0.0]], blob.shape[1]))
    world = World(gravity=(0, 0, 0), substeps=2, iterations=4)
    body = world.add_body(BodyShape.box((0.45, 0.12, 0.12), (0.2, 0.3, 0.3), 2.0))
    pair = FloatingBodies(water, world, [(body, (0.2, 0.3, 0.3))])

    def momentum():
        return water.momentum() + (world.mass[:, None] * world.velocity).sum(axis=0)

    before = momentum()
    for _ in range(30):
        pair.step(1 / 120)
    (center,), _ = world.transforms()
    assert center[0] > 0.46  # the box was pushed along
    # Float32 liquid velocities round at ~1e-7 relative per step.
    np.testing.assert_allclose(momentum(), before, atol=1e-4 * np.abs(before).max())


# A 0.36 x 0.16 x 0.36 m plank at half water's density, 4 particles thick: floating
# d = 0.08 m deep, its metacentre is b²/(12 d) = 0.135 m above its centre of buoyancy,
# GM = 0.095 m above its centre of mass, both ways: floating flat is stable.
PLANK = (0.36, 0.16, 0.36)


def _angles(pair, steps: int) -> np.ndarray:
    angles = []
    for _ in range(steps):
        pair.step(1 / 60)
        angles.append(tilt(pair.world))
    return np.array(angles)


def test_a_plank_stays_flat_and_a_tilted_one_rights_itself():
    flat = _angles(tank_with_box(0.5, spacing=0.04, width=0.64, size=PLANK), 40)
    tilted = _angles(tank_with_box(0.5, spacing=0.04, width=0.64, size=PLANK, tilt=25.0), 40)
    kept = tank_with_box(0.5, spacing=0.04, width=0.64, size=PLANK, tilt=25.0, turn=False)
    # The liquid's torque jitters at 4 particles across: the flat plank rocks by about
    # a degree in its first second (measured 1.1; 2.2 at most over 5 s, slow tier).
    assert flat.max() < 3.0
    # Released at 25 degrees, it swings back through upright within half a second
    # (measured: 2.6 degrees at 0.5 s, then a small overshoot that dies out)...
    assert tilted.min() < 5.0
    # ... which the liquid cannot do without its torque.
    np.testing.assert_allclose(_angles(kept, 20), 25.0, atol=0.1)


@pytest.mark.slow
def test_a_floating_plank_settles_flat():
    """Five seconds (under a minute to run): the flat plank rocks by at most 2.2 degrees
    (measured) and the tilted one settles within 2.6 degrees after 2 s."""
    flat = _angles(tank_with_box(0.5, spacing=0.04, width=0.64, size=PLANK), 300)
    tilted = _angles(tank_with_box(0.5, spacing=0.04, width=0.64, size=PLANK, tilt=25.0), 300)
    assert flat.max() < 3.0
    assert tilted[120:].max() < 4.0
    assert tilted[240:].max() < 3.0


@pytest.mark.slow
def test_a_cube_at_half_the_density_of_water_rolls_onto_an_edge():
    """Upright, its metacentre is a/12 below its centre of mass (see the Archimedes
    case); tipped by 5 degrees about one axis it rolls until it floats edge up, turned by
    45 degrees, where the waterline runs along a diagonal plane and the shape under it
    is symmetric (measured: 45.9 degrees at 1.25 s, then between 45 and 47)."""
    pair = tank_with_box(0.5, spacing=0.04, width=0.56, tilt=5.0)
    angles = _angles(pair, 150)
    assert angles[:30].max() < 20.0  # it starts slowly: unstable, but near equilibrium
    np.testing.assert_allclose(angles[90:], 45.0, atol=3.0)


@pytest.mark.slow
@pytest.mark.parametrize("ratio", [0.25, 0.5])
def test_a_floating_box_rests_at_the_archimedes_depth(ratio):
    """The validation (about a minute each): submerged depth = ratio × height, within
    5 % of the height, with the surface read from the liquid's top layer."""
    # Held upright (turn=False): a cube floating at these densities is unstable upright
    # (its metacentre lies below its centre of mass: with draft d = ratio a, GM =
    # d/2 + a²/(12 d) - a/2 = -a/12 at 0.5, -a/24 at 0.25) and would roll onto an edge;
    # the depth is what this case validates.
    pair = tank_with_box(ratio, spacing=0.02, width=0.5, turn=False)
    settle(pair, 3.0)
    (center,), _ = pair.world.transforms()
    level = surface(pair.fluid, 0.02, center, 0.18)
    submerged = level - (center[1] - SIZE / 2)
    assert abs(submerged - ratio * SIZE) < 0.05 * SIZE


@pytest.mark.slow
def test_the_floating_scene_rides_high_low_and_sinks():
    from motes.scene import load_scene

    scene = load_scene("floating")
    for _ in range(60):
        scene.advance()
    floating = scene.bodies["tank"].floating
    centers, _ = floating.world.transforms()
    sizes = [np.asarray(size) for size, _ in floating.looks]
    bottoms = [c[1] - s[1] / 2 for c, s in zip(centers, sizes, strict=True)]
    tops = [c[1] + s[1] / 2 for c, s in zip(centers, sizes, strict=True)]
    level = surface(scene.bodies["tank"].fluid, 0.025, centers[2], 0.2)
    pine, oak, _ = (level - b for b in bottoms)  # depth under the surface [m]
    assert 0 < pine < oak  # the light plank rides higher than the heavier block
    assert pine / 0.1 < oak / 0.12  # ... also as a fraction of its own height
    assert bottoms[2] < 0.01 and tops[2] > level  # the stone stands on the floor
    assert level > 0.3  # the water rose by what the three displace


def test_a_body_thinner_than_two_kernel_supports_is_refused():
    pair = tank_with_box(0.5, spacing=0.04, width=0.48)
    with pytest.raises(ValueError, match=r"size of body 0 must be at least two kernel"):
        FloatingBodies(pair.fluid, pair.world, [(pair.bodies[0], (0.2, 0.1, 0.2))])


def test_a_box_built_rotated_is_refused():
    pair = tank_with_box(0.5, spacing=0.04, width=0.48)
    world = pair.world
    turned = world.add_body(
        BodyShape.box(
            (0.24, 0.6, 0.24), (0.2, 0.2, 0.2), 4.0, rotation=[[0, -1, 0], [1, 0, 0], [0, 0, 1]]
        )
    )
    FloatingBodies(pair.fluid, world, [(turned, (0.2, 0.2, 0.2))])  # a quarter turn: a box
    tilted = world.add_body(
        BodyShape.box(
            (0.24, 0.9, 0.24),
            (0.2, 0.2, 0.2),
            4.0,
            rotation=[[0.8, -0.6, 0], [0.6, 0.8, 0], [0, 0, 1]],
        )
    )
    with pytest.raises(ValueError, match="body 0 is a box built rotated"):
        FloatingBodies(pair.fluid, world, [(tilted, (0.2, 0.2, 0.2))])
