"""Life cycle: ageing, lifetime, extinction policies, over-life curves and events."""

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import motes as mo
import naive


def filled(n=1000, *, attributes=(), seed=0, dtype=np.float64):
    system = mo.ParticleSystem(n, seed=seed, dtype=dtype, attributes=attributes)
    system.store.spawn(n)
    return system


def test_particles_die_after_their_lifetime_and_survivors_keep_order():
    system = filled(6)
    system["lifetime"] = [0.05, 1.0, 0.15, 1.0, 0.35, 1.0]
    seen = []
    system.on("death", lambda e: seen.append(e.ids.tolist()))
    for _ in range(3):
        system.step(0.1)
    assert seen == [[0], [2]]
    assert_array_equal(system["id"], [1, 3, 4, 5])
    assert_allclose(system["age"], 0.3)


def test_color_and_size_over_life_follow_their_curves():
    system = filled(500, attributes=("color", "size", "birth_size"))
    rng = np.random.default_rng(0)
    system["lifetime"] = rng.uniform(1, 2, 500)
    system["age"] = rng.uniform(0, 0.9, 500)
    system["birth_size"] = 0.1
    keys = [(0.0, "#ffffff"), (0.3, "#ff8000"), (1.0, "#00000000")]
    color = mo.ColorOverLife(keys)
    size = mo.SizeOverLife([(0, 1), (0.5, 3), (1, 0)])
    system.add(color, size)
    system.step(0.01)
    t = system["age"] / system["lifetime"]
    assert_allclose(
        system["color"], naive.curve(t, color.curve.times, color.curve.values), atol=1e-12
    )
    want = 0.1 * naive.curve(t, size.curve.times, size.curve.values)[:, 0]
    assert_allclose(system["size"], want, atol=1e-12)


def test_speed_over_life_keeps_direction():
    system = mo.ParticleSystem(100, dtype=np.float64)
    system.add(
        mo.Emitter(
            mo.shapes.Point(), mo.Burst(100), speed=2.0, lifetime=1.0, direction=mo.Isotropic()
        ),
        mo.SpeedOverLife([(0, 1), (1, 0)]),
    )
    system.step(0.25)
    speed = np.linalg.norm(system["velocity"], axis=1)
    assert_allclose(speed, 2.0 * 0.75, rtol=1e-12)


def test_intensity_alpha_and_distance_extinction():
    system = filled(4, attributes=("color",))
    system["color"] = [[1, 1, 1, 1], [0.01, 0.01, 0.01, 1], [1, 1, 1, 0.02], [1, 1, 1, 1]]
    system["position"] = [[0, 0, 0], [0, 0, 0], [0, 0, 0], [5, 0, 0]]
    system.add(mo.IntensityBelow(0.05), mo.DistanceFrom((0, 0, 0), 3.0))
    system.step(0.01)
    assert_array_equal(system["id"], [0])
    alpha = filled(2, attributes=("color",))
    alpha["color"] = [[0, 0, 0, 0.5], [1, 1, 1, 0.01]]
    alpha.add(mo.AlphaBelow(0.1))
    alpha.step(0.01)
    assert_array_equal(alpha["id"], [0])


def test_kill_volume_collider_and_collision_events():
    system = filled(3)
    system["position"] = [[0, 0, 0], [2, 0, 0], [0, -1, 0]]
    system.add(
        mo.colliders.Sphere((2, 0, 0), 0.5, response="kill"),
        mo.colliders.Plane((0, 1, 0), -0.5, restitution=1.0),
    )
    hits, deaths = [], []
    system.on("collision", hits.append)
    system.on("death", deaths.append)
    system.step(0.01)
    assert_array_equal(hits[0].ids, [1, 2])
    assert_array_equal(hits[0].collider, [0, 1])
    assert_array_equal(deaths[0].ids, [1])
    assert_allclose(hits[0].position[1], [0, -0.5, 0])  # pushed out onto the plane


def test_bounce_restitution_and_scale_friction():
    system = filled(1)
    system["position"] = [[0, 0.01, 0]]
    system["velocity"] = [[2.0, -3.0, 0.0]]
    system.add(mo.colliders.Plane((0, 1, 0), 0.0, restitution=0.5, friction=0.25))
    system.step(0.01)
    assert_allclose(system["velocity"][0], [1.5, 1.5, 0], rtol=1e-12)
    assert system["position"][0, 1] == pytest.approx(0.0)


@pytest.mark.slow
def test_depth_friction_stops_slow_sliding_and_slows_fast_sliding():
    system = filled(2)
    system["position"] = [[0, 0.0, 0], [0, 0.0, 0]]
    system["velocity"] = [[0.5, -1.0, 0.0], [50.0, -1.0, 0.0]]
    system.add(mo.colliders.Plane(restitution=0.0, friction=1.0, friction_model="depth"))
    system.step(0.1)
    # Penetration 0.1 m after the move; tangential speed drops by mu · depth / dt = 1 m/s.
    assert_allclose(system["velocity"][:, 0], [0.0, 49.0], rtol=1e-12)


def test_stick_response_stops_particles():
    system = filled(1)
    system["velocity"] = [[1.0, -1.0, 0.0]]
    system.add(mo.colliders.Plane(response="stick"))
    system.step(0.1)
    assert_array_equal(system["velocity"], [[0, 0, 0]])


@pytest.mark.slow
def test_particles_stay_inside_a_tank():
    system = mo.ParticleSystem(2000, seed=2)
    system.add(
        mo.Emitter(
            mo.shapes.Sphere(0.2),
            mo.Burst(2000),
            speed=mo.Uniform(5, 20),
            direction=mo.Isotropic(),
            lifetime=100.0,
        ),
        mo.Gravity(),
        mo.colliders.Box((0, 0, 0), (2, 1, 2), inside=True, restitution=0.9),
    )
    for _ in range(300):
        system.step(1 / 120)
        assert np.all(np.abs(system["position"]) <= np.array([1, 0.5, 1]) + 1e-5)
    assert len(system) == 2000


def test_birth_and_step_events():
    system = mo.ParticleSystem(100, seed=1)
    system.add(mo.Emitter(rate=mo.PerFrame(3)))
    born, stepped = [], []
    system.on("birth", lambda e: born.append(len(e)))
    system.on("step", lambda e: stepped.append(len(e)))
    system.run(4, 0.01)
    assert born == [3, 3, 3, 3]
    assert stepped == [3, 6, 9, 12]


def test_changing_a_collider_between_steps_takes_effect():
    system = filled(1)
    system["position"] = [[0, 0, 0]]
    plane = mo.colliders.Plane((0, 1, 0), -1.0)
    gravity = mo.Gravity((0, 0, 0))
    system.add(plane, gravity)
    system.step(0.01)
    assert system["position"][0, 1] == pytest.approx(0.0)
    plane.offset = 0.5  # raise the floor: the particle is pushed up on the next step
    system.step(0.01)
    assert system["position"][0, 1] == pytest.approx(0.5)
    gravity.acceleration = np.array([0.0, 0.0, -10.0])
    system.step(0.01)
    assert system["velocity"][0, 2] == pytest.approx(-0.1)
    with pytest.raises(ValueError, match="read-only"):
        plane.normal[1] = 2.0


def test_remove_and_nbytes():
    system = mo.ParticleSystem(100, seed=1)
    emitter = mo.Emitter(rate=mo.PerFrame(5))
    noise = mo.CurlNoise(1.0, 1.0)
    system.add(emitter, noise, mo.Gravity())
    system.step(0.01)
    assert system.nbytes == system.store.nbytes + 3 * 100 * 4  # the force buffer
    system.remove(emitter)
    system.step(0.01)
    assert len(system) == 5
    with pytest.raises(ValueError, match="not part of this system"):
        system.remove(emitter)
