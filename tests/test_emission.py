"""Emission: Reeves rate models, directions, initial attributes and moving emitters."""

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy import stats

import motes as mo

N_FRAMES = 10_000


def counts(rate, frames=N_FRAMES, dt=1 / 60, seed=3):
    rng = np.random.default_rng(seed)
    return np.array([rate.count(rng, f, f * dt, dt) for f in range(frames)])


def test_per_frame_counts_have_reeves_mean_and_variance():
    mean, variance = 50, 10
    n = counts(mo.PerFrame(mean, variance))
    # N = mean + U(-1, 1)·variance, then stochastic rounding: Var = variance²/3 + 1/6
    # (the rounding's Bernoulli variance p(1-p), averaged over a uniform fraction p).
    expected_var = variance**2 / 3 + 1 / 6
    assert abs(n.mean() - mean) < 3 * np.sqrt(expected_var / N_FRAMES)
    # Standard error of a sample variance of a uniform law: variance² · sqrt(4/45 / N).
    assert abs(n.var() - expected_var) < 3 * variance**2 * np.sqrt(4 / 45 / N_FRAMES)
    assert n.min() >= mean - variance and n.max() <= mean + variance


def test_per_frame_ramp_moves_the_mean_linearly():
    rate = mo.PerFrame(10, 2, delta_mean=0.5, start_frame=100)
    n = counts(rate, frames=2100)
    assert n[:100].sum() == 0
    # mean_f = 10 + 0.5 (f - 100); average it over windows of 100 frames.
    for start in (100, 1000, 2000):
        window = n[start : start + 100]
        expected = 10 + 0.5 * (np.arange(start, start + 100) - 100)
        assert abs(window.mean() - expected.mean()) < 3 * np.sqrt((4 / 3 + 1 / 6) / 100)


def test_decreasing_ramp_clamps_at_zero():
    n = counts(mo.PerFrame(5, 1, delta_mean=-1), frames=30)
    assert n.min() == 0
    assert_array_equal(n[10:], 0)


def test_per_second_carries_fractions_across_steps():
    for dt in (1 / 60, 1 / 7, 0.013):
        n = counts(mo.PerSecond(100.5), frames=round(10 / dt), dt=dt)
        elapsed = dt * round(10 / dt)
        assert abs(n.sum() - 100.5 * elapsed) <= 1


def test_burst_once_and_repeating():
    once = counts(mo.Burst(40, at=0.5), frames=120)
    assert once.sum() == 40
    assert once[int(0.5 * 60)] == 40  # the step whose interval contains t = 0.5 s
    repeating = counts(mo.Burst(7, at=0.25, every=0.5, repeat=3), frames=240)
    assert repeating.sum() == 21
    assert np.count_nonzero(repeating) == 3


def test_screen_scaled_rate_follows_screen_coverage():
    near = mo.Camera((0, 0, 3), (0, 0, 0), fov=60, resolution=(400, 400))
    far = mo.Camera((0, 0, 30), (0, 0, 0), fov=60, resolution=(400, 400))
    behind = mo.Camera((0, 0, 3), (0, 0, 10), fov=60, resolution=(400, 400))
    shape = mo.shapes.Sphere(0.5)
    totals = {}
    for name, cam in (("near", near), ("far", far), ("behind", behind)):
        emitter = mo.Emitter(shape, mo.ScreenScaled(mo.PerFrame(1000), cam))
        rng = np.random.default_rng(0)
        totals[name] = sum(emitter.rate.count(rng, f, 0.0, 1 / 60, emitter) for f in range(100))
    fraction = near.screen_fraction((0, 0, 0), 0.5)
    # Projected disc radius f·r/d with f = 1/tan(30°): π r'² / (2·2) of the image.
    assert fraction == pytest.approx(np.pi * (0.5 / np.tan(np.pi / 6) / 3) ** 2 / 4)
    assert abs(totals["near"] - 100_000 * fraction) < 4 * np.sqrt(100)  # rounding noise
    assert totals["far"] < totals["near"] / 50
    assert totals["behind"] == 0


def test_cone_directions_are_uniform_in_solid_angle():
    cone = mo.Cone(axis=(1, 1, 0), angle=40)
    rng = np.random.default_rng(1)
    d = cone.sample(rng, np.zeros((100_000, 3)), np.zeros((100_000, 3)))
    assert_allclose(np.linalg.norm(d, axis=1), 1, atol=1e-12)
    cos_t = d @ (np.array([1, 1, 0]) / np.sqrt(2))
    assert cos_t.min() >= np.cos(np.radians(40)) - 1e-12
    # cos θ uniform on [cos 40°, 1]: a correct sampler fails this at most 0.1 % of seeds.
    observed, _ = np.histogram(cos_t, bins=20, range=(np.cos(np.radians(40)), 1))
    assert stats.chisquare(observed).pvalue > 1e-3


def test_emitter_initial_attributes_and_offsets():
    system = mo.ParticleSystem(10_000, seed=5)
    system.add(
        mo.Emitter(
            mo.shapes.Sphere(0.5),
            mo.Burst(5000),
            position=(1, 2, 3),
            speed=mo.Uniform(1, 2),
            direction=mo.Radial(),
            lifetime=mo.Normal(2.0, 0.1, low=1.5),
            color=mo.Gradient([(0, "#ff0000"), (1, "#0000ff")]),
            size=0.1,
            mass=mo.Uniform(1, 3),
            rotation=mo.Function(lambda rng, n: rng.uniform(0, np.pi, n)),
        )
    )
    system.step(1e-6)
    assert len(system) == 5000
    offset = system["position"] - [1, 2, 3]
    assert np.linalg.norm(offset, axis=1).max() <= 0.5 + 1e-3
    speed = np.linalg.norm(system["velocity"], axis=1)
    assert speed.min() >= 1 - 1e-3 and speed.max() <= 2 + 1e-3
    # Radial: velocity points away from the emitter centre.
    cos = np.sum(offset * system["velocity"], axis=1) / (np.linalg.norm(offset, axis=1) * speed)
    assert cos.min() > 0.999
    assert system["lifetime"].min() >= 1.5
    color = system["color"]
    assert_allclose(color[:, 0] + color[:, 2], 1, atol=1e-6)  # on the red-blue gradient
    assert_array_equal(color[:, 1], 0)
    assert_allclose(system["inv_mass"], 1 / system["mass"], rtol=1e-6)
    assert system["rotation"].min() >= 0 and system["rotation"].max() <= np.pi


def test_moving_emitter_follows_its_path_and_lends_its_velocity():
    path = mo.Path([0, 1], [[0, 0, 0], [2, 0, 0]])  # 2 m/s along x
    system = mo.ParticleSystem(1000, seed=1)
    system.add(
        mo.Emitter(
            mo.shapes.Point(), mo.PerFrame(1), position=path, speed=0.0, inherit_velocity=0.5
        )
    )
    dt = 0.1
    for _ in range(5):
        system.step(dt)
    # Particle k was born at t = k·dt at x = 2 k dt with velocity 0.5 × 2 m/s.
    assert_allclose(system["velocity"][:, 0], 1.0, rtol=1e-5)
    born_x = 2 * dt * np.arange(5)
    travelled = 1.0 * dt * np.arange(5, 0, -1)
    assert_allclose(system["position"][:, 0], born_x + travelled, rtol=1e-5, atol=1e-6)


def test_emitted_shapes_use_the_system_rng_only():
    def build():
        s = mo.ParticleSystem(1000, seed=9)
        s.add(mo.Emitter(mo.shapes.Box((1, 2, 3)), mo.PerFrame(40, 20), speed=mo.Uniform(0, 1)))
        s.run(10, 0.01)
        return s["position"].copy()

    np.random.seed(0)  # noqa: NPY002 (the legacy global RNG must not matter)
    first = build()
    np.random.seed(1)  # noqa: NPY002
    assert_array_equal(first, build())


def test_per_second_stops_at_its_stop_time():
    """100/s with stop = 2.5 s: 250 births whatever the step, none after the stop, and
    the step that straddles the stop counts only the time before it."""
    for dt in (1 / 60, 1 / 7):
        n = counts(mo.PerSecond(100.0, stop=2.5), frames=round(5 / dt), dt=dt)
        assert n.sum() in (249, 250)
        assert n[int(np.ceil(2.5 / dt)) :].sum() == 0
    with pytest.raises(ValueError, match="stop"):
        mo.PerSecond(10.0, stop=-1.0)
