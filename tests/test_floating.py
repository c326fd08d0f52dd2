"""Liquids and rigid bodies act on each other: boxes float, sink and displace water."""

from __future__ import annotations

import numpy as np
import pytest

from floating_case import surface, tank_with_box
from motes.couple.fluid_rigid import FloatingBodies
from motes.fluids import FluidModel, lattice
from motes.fluids.fluid import Fluid
from motes.rigid import World
from motes.rigid.shapes import BodyShape

SIZE = 0.2


def settle(pair, seconds: float, dt: float = 1 / 60) -> None:
    for _ in range(round(seconds / dt)):
        pair.step(dt)


def test_a_light_box_floats_held_up_by_its_weight_and_a_dense_one_sinks():
    light = tank_with_box(0.5, spacing=0.04, width=0.48)
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


@pytest.mark.slow
@pytest.mark.parametrize("ratio", [0.25, 0.5])
def test_a_floating_box_rests_at_the_archimedes_depth(ratio):
    """The validation (about a minute each): submerged depth = ratio × height, within
    5 % of the height, with the surface read from the liquid's top layer."""
    pair = tank_with_box(ratio, spacing=0.02, width=0.5)
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
