"""Same seed → bit-identical state; different seeds differ; thread count does not matter."""

import numba
import numpy as np
from numpy.testing import assert_array_equal

from motes._jit import SERIAL_BELOW
from motes.demo import build_fire


def fire_state(seed, steps=1000, threads=None, rate=60):
    previous = numba.get_num_threads()
    if threads is not None:
        numba.set_num_threads(threads)
    try:
        fire = build_fire(capacity=40_000, rate=rate, seed=seed)
        for _ in range(steps):
            fire.step(1 / 60)
        return {name: fire.store[name].copy() for name in fire.store.names}
    finally:
        numba.set_num_threads(previous)


def test_same_seed_gives_identical_state_after_1000_steps():
    a = fire_state(11)
    b = fire_state(11)
    assert a.keys() == b.keys()
    for name in a:
        assert_array_equal(a[name], b[name], err_msg=name)


def test_different_seeds_differ():
    a = fire_state(11, steps=50)
    b = fire_state(12, steps=50)
    assert a["position"].shape != b["position"].shape or not np.array_equal(
        a["position"], b["position"]
    )


def test_result_does_not_depend_on_thread_count():
    if numba.config.NUMBA_NUM_THREADS < 2:
        return
    # ~18,000 live particles: above SERIAL_BELOW, so two threads really run in parallel.
    one = fire_state(5, steps=120, threads=1, rate=300)
    two = fire_state(5, steps=120, threads=2, rate=300)
    assert one["id"].shape[0] > SERIAL_BELOW
    for name in one:
        assert_array_equal(one[name], two[name], err_msg=name)
