"""Particle hierarchies: child systems spawned by parent events (fireworks)."""

import sys
from pathlib import Path

import numpy as np
from numpy.testing import assert_allclose, assert_array_equal

import motes as mo

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
from fireworks import build_fireworks


def test_fireworks_child_counts_match_parent_deaths():
    rockets, trails, sparks = build_fireworks(seed=3)
    deaths = []
    rockets.on("death", lambda e: deaths.append(len(e)))
    spark_births, trail_births = [], []
    sparks.on("birth", lambda e: spark_births.append(len(e)))
    trails.on("birth", lambda e: trail_births.append(len(e)))
    live_after = []
    for _ in range(150):
        rockets.step(1 / 60)
        live_after.append(len(rockets))
    assert sum(deaths) >= 3
    # 200 sparks per dead rocket, born in the parent's step, none dropped.
    assert sum(spark_births) == 200 * sum(deaths)
    assert sparks.store.dropped == 0
    # One trail particle per live rocket per step (the "step" event follows each step).
    assert trail_births == [k for k in live_after if k > 0]
    assert trails.store.dropped == 0


def test_children_inherit_position_colour_and_velocity_fraction():
    parent = mo.ParticleSystem(10, seed=1, dtype=np.float64)
    parent.add(
        mo.Emitter(
            mo.shapes.Point(),
            mo.Burst(2),
            position=(1, 2, 3),
            speed=0.0,
            lifetime=0.05,
            color="#ff0000",
        )
    )
    child = mo.ParticleSystem(100, seed=parent.child_seed(), dtype=np.float64)
    parent.add(
        mo.SpawnOnEvent(
            child,
            mo.Emitter(speed=0.0, inherit_velocity=0.5, color="#00ff00"),
            on="death",
            count=5,
            inherit=("color",),
        )
    )
    parent.step(0.01)
    parent["velocity"] = [[2.0, 0, 0], [0, 4.0, 0]]
    for _ in range(5):
        parent.step(0.01)
    assert len(parent) == 0
    assert len(child) == 10
    assert_allclose(child["color"], np.tile([1.0, 0, 0, 1], (10, 1)))
    # Children move at half the parent velocity, from the parent's death position.
    assert_allclose(np.sort(child["velocity"][:, 0]), [0] * 5 + [1.0] * 5)


def test_child_streams_are_independent_of_parent_draws():
    def sparks_after(extra_parent_emitter):
        parent = mo.ParticleSystem(100, seed=4)
        parent.add(mo.Emitter(rate=mo.Burst(1), lifetime=0.02, speed=0.0))
        if extra_parent_emitter:
            parent.add(mo.Emitter(rate=mo.PerFrame(5, 5), lifetime=10.0))
        child = mo.ParticleSystem(100, seed=parent.child_seed())
        parent.add(
            mo.SpawnOnEvent(
                child, mo.Emitter(speed=mo.Uniform(1, 2), direction=mo.Isotropic()), count=10
            )
        )
        parent.run(5, 0.01)
        return child["velocity"].copy()

    assert_array_equal(sparks_after(False), sparks_after(True))
