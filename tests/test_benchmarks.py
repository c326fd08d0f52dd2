"""The emitter benchmark: its JSON contract, and that its NumPy baselines compute the same step.

No timing asserts: only that the figures exist and are positive and finite, and that the
baselines the figures are ratios against do the same work as motes.
"""

import numpy as np
import pytest
from benchmarks import emitter

import motes
from benchmark_contract import quick_figures

REQUIRED = ("ballistic_10m_floor_fraction", "fire_1m_ms", "fire_1m_speedup_vs_numpy", "small_1k_us")


def test_quick_run_ends_with_one_json_line_of_positive_finite_figures(capsys):
    figures = quick_figures(emitter, capsys, REQUIRED)
    assert figures["quick"] is True
    assert figures["cpu_count"] >= 1 and figures["numba_threads"] >= 1


def test_ballistic_bytes_count_every_array_the_step_touches():
    # float32: position and velocity 3 x 4 B read and written, age 4 B read and written,
    # lifetime 4 B read, one keep byte written.
    assert sum(emitter.ballistic_bytes(np.float32).values()) == 2 * 12 + 2 * 12 + 2 * 4 + 4 + 1
    assert sum(emitter.ballistic_bytes(np.float64).values()) == 2 * 24 + 2 * 24 + 2 * 8 + 8 + 1


@pytest.mark.parametrize(("octaves", "time_scale"), [(1, 0.0), (3, 0.7)])
def test_numpy_curl_noise_is_the_motes_field(rng, octaves, time_scale):
    noise = motes.CurlNoise(strength=1.5, scale=0.4, seed=3, octaves=octaves, time_scale=time_scale)
    position = rng.uniform(-3.0, 3.0, (3, 20_000)).astype(np.float32)
    expected = np.zeros_like(position)
    noise.accumulate(motes.ParticleStore(1), position, position, 1.3, expected)
    got = np.zeros_like(position)
    emitter.numpy_curl_noise(noise, position, 1.3, got)
    # Same float32 arithmetic in a different order (fastmath may contract or reassociate):
    # a few hundred operations of relative rounding 6e-8 on values of order strength.
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-4)


def test_numpy_fire_steps_like_motes_when_nothing_is_emitted():
    system = emitter.fire_system(3_000)
    baseline = emitter.NumpyFire(system)
    system.emitters = []  # emission is random: compare everything else exactly
    for _ in range(5):
        system.step(emitter.DT)
        baseline.step(emitter.DT, emit=False)
    assert baseline.count == len(system) < 3_000  # some died and were compacted away
    for name in system.store.names:
        ours = system.store[name]
        ours = ours.T if ours.ndim == 2 else ours
        # float32 state after 5 steps of O(1) values; only the noise's rounding differs.
        np.testing.assert_allclose(baseline.arrays[name], ours, rtol=0, atol=1e-5, err_msg=name)


def test_numpy_ballistic_steps_like_motes():
    system = emitter.ballistic_system(5_000, seed=2)
    baseline = emitter.NumpyBallistic(system)
    for _ in range(30):  # long enough for some particles to reach the ground
        system.step(emitter.DT)
        baseline.step(emitter.DT)
    assert np.any(system["position"][:, 1] < 0.5)
    np.testing.assert_allclose(baseline.position, system["position"].T, rtol=0, atol=1e-4)
    np.testing.assert_allclose(baseline.velocity, system["velocity"].T, rtol=0, atol=1e-4)
    np.testing.assert_array_equal(baseline.keep, system.store.keep[: len(system)])


def test_prefilled_fire_holds_its_live_count():
    system = emitter.fire_system(20_000)
    assert len(system) == 20_000
    system.run(90, emitter.DT)  # 1.5 s: longer than the longest lifetime
    # Births balance deaths in the prefilled steady state; the count's fluctuation over
    # a lifetime is a few hundred (Poisson-like, sqrt(20_000) ~ 140), far inside 5%.
    assert abs(len(system) - 20_000) < 1_000
