"""The particle store: layout, spawning, overflow, compaction, ids and memory."""

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from motes import Attribute, ParticleStore


def test_layout_is_rows_per_component_with_transposed_views():
    store = ParticleStore(10, ("color",))
    assert store.raw("position").shape == (3, 10)
    assert store.raw("position").flags.c_contiguous
    assert store.raw("color").shape == (4, 10)
    assert store.raw("age").shape == (10,)
    store.spawn(4)
    view = store["position"]
    assert view.shape == (4, 3)
    view[:] = np.arange(12).reshape(4, 3)
    assert_array_equal(store.raw("position")[:, :4], np.arange(12).reshape(4, 3).T)


def test_spawn_fills_defaults_and_fresh_ids():
    store = ParticleStore(10, ("color", "size"))
    first = store.spawn(3)
    second = store.spawn(2)
    assert (first, second) == (slice(0, 3), slice(3, 5))
    assert_array_equal(store["id"], [0, 1, 2, 3, 4])
    assert_array_equal(store["color"], np.ones((5, 4)))
    assert np.all(np.isinf(store["lifetime"]))
    assert_array_equal(store["age"], np.zeros(5))


def test_overflow_drops_and_counts():
    store = ParticleStore(5)
    made = store.spawn(3)
    more = store.spawn(4)
    assert made.stop - made.start == 3
    assert more.stop - more.start == 2
    assert store.count == 5
    assert store.dropped == 2
    assert store.spawn(1) == slice(5, 5)
    assert store.dropped == 3


def test_compaction_is_stable_and_moves_every_attribute():
    store = ParticleStore(8, ("color", Attribute("temperature", default=300.0)))
    store.spawn(8)
    store["position"] = np.arange(24.0).reshape(8, 3)
    store["color"] = np.arange(32.0).reshape(8, 4)
    store["temperature"] = np.arange(8.0)
    keep = np.array([1, 0, 1, 1, 0, 0, 1, 1], dtype=bool)
    new_index = store.compact(keep)
    assert store.count == 5
    assert_array_equal(store["id"], [0, 2, 3, 6, 7])
    assert_array_equal(store["position"], np.arange(24.0).reshape(8, 3)[keep])
    assert_array_equal(store["color"], np.arange(32.0).reshape(8, 4)[keep])
    assert_array_equal(store["temperature"], np.arange(8.0)[keep])
    assert_array_equal(new_index, [0, -1, 1, 2, -1, -1, 3, 4])


def test_ids_are_never_reused():
    store = ParticleStore(4)
    store.spawn(4)
    store.kill([0, 1, 2, 3])
    store.spawn(2)
    assert_array_equal(store["id"], [4, 5])


def test_compact_without_deaths_returns_none():
    store = ParticleStore(4)
    store.spawn(3)
    assert store.compact() is None
    assert store.count == 3


def test_user_attribute_registered_late_gets_default_for_live_particles():
    store = ParticleStore(4)
    store.spawn(2)
    store.require(Attribute("charge", default=-1.0, doc="[C]"))
    assert_array_equal(store["charge"], [-1.0, -1.0])
    assert "charge" in store.describe()


def test_bytes_per_particle_is_measured_from_the_arrays():
    store = ParticleStore(1000)
    # position 12 + velocity 12 + age 4 + lifetime 4 + id 8 + keep mask 1
    assert store.bytes_per_particle == 41
    assert store.nbytes == 41 * 1000
    full = ParticleStore(1000, ("mass", "inv_mass", "color", "size", "rotation"))
    assert full.bytes_per_particle == 41 + 4 + 4 + 16 + 4 + 4


def test_a_million_particles_is_comfortable():
    store = ParticleStore(1_000_000, ("mass", "inv_mass", "color", "size", "rotation"))
    store.spawn(1_000_000)
    assert store.nbytes < 80 * 1_000_000  # 73 B per particle with every built-in attribute
    keep = np.ones(1_000_000, dtype=bool)
    keep[::3] = False
    store.compact(keep)
    assert store.count == 666_666
    assert store["id"][1] == 2


def test_float64_store():
    store = ParticleStore(3, dtype=np.float64)
    assert store.raw("position").dtype == np.float64
    with pytest.raises(ValueError, match="dtype"):
        ParticleStore(3, dtype=np.int32)


@pytest.mark.parametrize("capacity", [0, -5])
def test_capacity_must_be_positive(capacity):
    with pytest.raises(ValueError, match="capacity must be >= 1"):
        ParticleStore(capacity)


def test_unknown_attribute_is_named():
    store = ParticleStore(3)
    with pytest.raises(KeyError, match="temperature"):
        store.require("temperature")
    with pytest.raises(KeyError, match="color"):
        store["color"]


def test_conflicting_declaration():
    store = ParticleStore(3, (Attribute("heat", default=1.0),))
    with pytest.raises(ValueError, match="heat"):
        store.require(Attribute("heat", default=2.0))


def test_swap_compaction_moves_few_and_keeps_attributes_together():
    store = ParticleStore(10, ("color",), compaction="swap")
    store.spawn(10)
    store["position"] = np.arange(30.0).reshape(10, 3)
    store["color"] = np.arange(40.0).reshape(10, 4)
    keep = np.array([1, 0, 1, 1, 0, 1, 1, 1, 0, 1], dtype=bool)
    new_index = store.compact(keep)
    # Holes 1 and 4 are filled by the last survivors 9 and 7; 8 (dead) is dropped.
    assert_array_equal(store["id"], [0, 9, 2, 3, 7, 5, 6])
    assert_array_equal(new_index, [0, -1, 2, 3, -1, 5, 6, 4, -1, 1])
    ids = store["id"]
    assert_array_equal(store["position"], np.arange(30.0).reshape(10, 3)[ids])
    assert_array_equal(store["color"], np.arange(40.0).reshape(10, 4)[ids])


# 40,000 with about half dead moves rows in parallel (holes >= SERIAL_BELOW).
@pytest.mark.parametrize(("seed", "n"), [(s, 5000) for s in range(4)] + [(4, 40_000)])
def test_swap_and_stable_compaction_keep_the_same_particles(seed, n):
    rng = np.random.default_rng(seed)
    keep = rng.random(n) < max(rng.random(), 0.3)
    stores = {}
    for mode in ("stable", "swap"):
        store = ParticleStore(n, ("size",), compaction=mode)
        store.spawn(n)
        store["size"] = np.arange(float(n))
        index = store.compact(keep.copy())
        stores[mode] = (store, index)
        # Without the index, the same particles in the same order.
        plain = ParticleStore(n, ("size",), compaction=mode)
        plain.spawn(n)
        plain["size"] = np.arange(float(n))
        assert plain.compact(keep.copy(), index=False) is None
        assert_array_equal(plain["id"], store["id"])
    stable, swap = stores["stable"][0], stores["swap"][0]
    assert stable.count == swap.count == keep.sum()
    assert_array_equal(np.sort(swap["id"]), stable["id"])
    assert_array_equal(swap["size"], swap["id"].astype(float))
    index = stores["swap"][1]
    assert_array_equal(swap["id"][index[keep]], np.flatnonzero(keep))


def test_unknown_compaction_is_named():
    with pytest.raises(ValueError, match="compaction must be one of"):
        ParticleStore(3, compaction="shuffle")
