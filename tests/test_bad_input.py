"""Bad input gets a clear error naming the parameter and the allowed range."""

import numpy as np
import pytest

import motes as mo


@pytest.mark.parametrize(
    ("build", "error", "match"),
    [
        (lambda: mo.ParticleSystem(0), ValueError, "capacity must be >= 1"),
        (lambda: mo.ParticleSystem(-3), ValueError, "capacity"),
        (lambda: mo.ParticleSystem(10, seed=-1), ValueError, "seed"),
        (lambda: mo.ParticleSystem(10, verlet_damping=1.0), ValueError, "verlet_damping"),
        (lambda: mo.Emitter(lifetime=-1.0), ValueError, "lifetime must be > 0"),
        (lambda: mo.Emitter(lifetime=mo.Uniform(-1, 2)), ValueError, "lifetime must be > 0"),
        (lambda: mo.Emitter(mass=0.0), ValueError, "mass must be > 0"),
        (lambda: mo.Emitter(position=(0, np.nan, 0)), ValueError, "position must be finite"),
        (lambda: mo.Emitter(position=(0, 1)), ValueError, r"position must have shape \(3,\)"),
        (lambda: mo.Emitter(rate=5), TypeError, "rate must be a Rate"),
        (lambda: mo.PerFrame(10, 20), ValueError, "variance must be <= mean"),
        (lambda: mo.PerFrame(-1), ValueError, "mean must be >= 0"),
        (lambda: mo.PerSecond(float("inf")), ValueError, "rate must be finite"),
        (lambda: mo.Burst(10, every=0), ValueError, "every must be > 0"),
        (lambda: mo.Gravity((0, np.inf, 0)), ValueError, "acceleration must be finite"),
        (lambda: mo.Gravity([[0, 1, 0]]), ValueError, "acceleration must have shape"),
        (lambda: mo.Drag(-0.1), ValueError, "coefficient must be >= 0"),
        (lambda: mo.Cone(angle=200), ValueError, "angle must be <= 180"),
        (lambda: mo.Cone(axis=(0, 0, 0)), ValueError, "axis must have non-zero length"),
        (lambda: mo.colliders.Plane(normal=(0, 0, 0)), ValueError, "normal"),
        (lambda: mo.colliders.Plane(restitution=1.5), ValueError, "restitution must be <= 1"),
        (lambda: mo.colliders.Sphere(radius=0), ValueError, "radius must be > 0"),
        (lambda: mo.colliders.Box(size=(1, -1, 1)), ValueError, "size must be > 0"),
        (lambda: mo.colliders.Box(rotation=np.ones((3, 3))), ValueError, "rotation"),
        (lambda: mo.colliders.Plane(response="explode"), ValueError, "response must be one of"),
        (lambda: mo.ColorOverLife([(0.5, "#zzzzzz")]), ValueError, "colour"),
        (lambda: mo.ColorOverLife([(1.5, "#ffffff")]), ValueError, "key time must be <= 1"),
        (lambda: mo.Path([1, 0], [[0, 0, 0], [1, 1, 1]]), ValueError, "strictly increasing"),
        (lambda: mo.Camera((0, 0, 0), (0, 0, 0)), ValueError, "target must differ"),
    ],
)
def test_constructor_errors_name_the_parameter(build, error, match):
    with pytest.raises(error, match=match):
        build()


def test_time_step_must_be_positive():
    system = mo.ParticleSystem(10)
    for dt in (0.0, -0.1, float("nan")):
        with pytest.raises(ValueError, match="dt must be"):
            system.step(dt)


def test_unknown_attribute_is_named():
    system = mo.ParticleSystem(10)
    with pytest.raises(KeyError, match="unknown attribute 'temperature'"):
        mo.ParticleStore(10, ("temperature",))
    with pytest.raises(KeyError, match="'color' is not allocated"):
        system["color"]


def test_wrong_array_shape_is_named():
    system = mo.ParticleSystem(10)
    system.store.spawn(3)
    with pytest.raises(ValueError, match="broadcast"):
        system["position"] = np.zeros((3, 2))


def test_callback_force_returning_nan_or_wrong_shape():
    system = mo.ParticleSystem(10)
    system.store.spawn(2)
    system.add(mo.CallbackForce(lambda p, v, t: np.full_like(p, np.nan)))
    with pytest.raises(ValueError, match="NaN"):
        system.step(0.1)
    other = mo.ParticleSystem(10)
    other.store.spawn(2)
    other.add(mo.CallbackForce(lambda p, v, t: np.zeros(3)))
    with pytest.raises(ValueError, match=r"shape \(2, 3\)"):
        other.step(0.1)


def test_user_distribution_with_bad_output():
    system = mo.ParticleSystem(10)
    system.add(mo.Emitter(rate=mo.Burst(3), size=mo.Function(lambda rng, n: np.full(n, np.inf))))
    with pytest.raises(ValueError, match="Function distribution must return"):
        system.step(0.1)


def test_adding_something_unknown():
    with pytest.raises(TypeError, match="cannot add"):
        mo.ParticleSystem(10).add(42)
