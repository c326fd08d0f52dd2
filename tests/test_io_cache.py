"""Particle cache: the documented file layout, round trips, bad files, interruption."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

import motes as mo
from motes.io.cache import FORMAT, VERSION, CacheWriter, load_cache

DT = 1 / 30


def make_systems():
    """A coloured, sized fountain; a plain puff (core attributes only); a bare store."""
    fountain = mo.ParticleSystem(2_000, seed=1)
    fountain.add(
        mo.Emitter(
            mo.shapes.Disc(0.1),
            mo.PerFrame(mean=20, variance=5),
            speed=mo.Uniform(2, 3),
            direction=mo.Cone((0, 1, 0), 15),
            lifetime=0.2,
            color=mo.Gradient([(0, "#ff8000"), (1, "#ffffff")]),
            size=mo.Uniform(0.01, 0.03),
        ),
        mo.Gravity(),
    )
    puff = mo.ParticleSystem(500, seed=2)
    puff.add(mo.Emitter(rate=mo.Burst(30, at=2 * DT), direction=mo.Isotropic(), speed=1.0))
    return fountain, puff


def snapshot(system) -> dict[str, np.ndarray]:
    store = system.store
    names = ("position", "velocity", "color", "size", "id")
    return {a: np.array(store[a]) for a in names if store.has(a)}


def record(path, frames: int, **kwargs):
    """Run both systems for ``frames`` frames into a cache; return what was recorded."""
    fountain, puff = make_systems()
    expected = []
    with CacheWriter(path, **kwargs) as cache:
        for _ in range(frames):
            fountain.step(DT)
            puff.step(DT)
            cache.add_frame(fountain.time, {"fountain": fountain, "puff": puff})
            expected.append((fountain.time, snapshot(fountain), snapshot(puff)))
    return expected


@pytest.mark.parametrize("compress", [False, True])
def test_round_trip(tmp_path, compress):
    path = tmp_path / "run.npz"
    expected = record(path, 6, compress=compress)
    cache = load_cache(path)
    assert cache.frame_count == len(cache) == 6
    assert cache.systems == ("fountain", "puff")
    np.testing.assert_array_equal(cache.times, [t for t, _, _ in expected])
    assert cache.attributes("fountain") == ("position", "velocity", "color", "size", "id")
    assert cache.attributes("puff") == ("position", "velocity", "id")
    for f, (_, fountain, puff) in enumerate(expected):
        for name, want in (("fountain", fountain), ("puff", puff)):
            got = cache.frame(f, name)
            assert set(got) == set(want)
            for attribute, values in want.items():
                # the store is float32 and so is the cache: copied bit for bit
                np.testing.assert_array_equal(got[attribute], values)
    # the puff bursts at t = 2 DT, in the third step: empty frames are kept, as empty
    np.testing.assert_array_equal(cache.counts("puff"), [0, 0, 30, 30, 30, 30])
    assert cache.frame(0, "puff")["position"].shape == (0, 3)
    assert cache.frame(-1, "fountain")["id"].dtype == np.int64


def test_file_layout_is_the_documented_one(tmp_path):
    path = tmp_path / "run.npz"
    expected = record(path, 3)
    with zipfile.ZipFile(path) as archive:
        assert archive.testzip() is None
    with np.load(path, allow_pickle=False) as data:
        assert str(data["format"]) == FORMAT == "motes-cache"
        assert int(data["version"]) == VERSION == 1
        assert data["times"].dtype == np.float64 and data["times"].shape == (3,)
        assert list(data["systems"]) == ["fountain", "puff"]
        assert sorted(data.files) == sorted(
            ["format", "version", "times", "systems"]
            + [f"fountain/{k}" for k in ("attributes", "offsets", "position", "velocity")]
            + [f"fountain/{k}" for k in ("color", "size", "id")]
            + [f"puff/{k}" for k in ("attributes", "offsets", "position", "velocity", "id")]
        )
        offsets = data["fountain/offsets"]
        counts = [len(fountain["position"]) for _, fountain, _ in expected]
        np.testing.assert_array_equal(offsets, np.concatenate([[0], np.cumsum(counts)]))
        n = offsets[-1]
        for key, shape, dtype in [
            ("position", (n, 3), np.float32),
            ("velocity", (n, 3), np.float32),
            ("color", (n, 4), np.float32),
            ("size", (n,), np.float32),
            ("id", (n,), np.int64),
        ]:
            assert data[f"fountain/{key}"].shape == shape
            assert data[f"fountain/{key}"].dtype == dtype
        # frame 1's rows, read with NumPy alone
        rows = slice(offsets[1], offsets[2])
        np.testing.assert_array_equal(data["fountain/position"][rows], expected[1][1]["position"])


def test_a_bare_store_and_float64_systems_are_recorded_as_float32(tmp_path):
    store = mo.ParticleStore(10, ("size",), dtype=np.float64)
    store.spawn(4)
    store["position"][:] = np.arange(12).reshape(4, 3) / 3
    path = tmp_path / "store.npz"
    with CacheWriter(path) as cache:
        cache.add_frame(0.0, {"store": store})
    frame = load_cache(path).frame(0)
    assert frame["position"].dtype == np.float32
    np.testing.assert_array_equal(frame["position"], store["position"].astype(np.float32))
    assert set(frame) == {"position", "velocity", "size", "id"}


def test_loaded_arrays_are_read_only(tmp_path):
    path = tmp_path / "run.npz"
    record(path, 2)
    position = load_cache(path).frame(1, "fountain")["position"]
    with pytest.raises(ValueError, match="read-only"):
        position[0] = 0.0


def test_exception_still_writes_the_frames_so_far(tmp_path):
    path = tmp_path / "run.npz"
    fountain, puff = make_systems()
    with pytest.raises(RuntimeError, match="simulation failed"), CacheWriter(path) as cache:
        for k in range(5):
            fountain.step(DT)
            puff.step(DT)
            cache.add_frame(fountain.time, {"fountain": fountain, "puff": puff})
            if k == 2:
                raise RuntimeError("simulation failed")
    loaded = load_cache(path)
    assert loaded.frame_count == 3
    assert [p.name for p in tmp_path.iterdir()] == ["run.npz"]  # no temporary file left


def test_no_frames_keeps_an_earlier_file(tmp_path):
    path = tmp_path / "run.npz"
    record(path, 2)
    before = path.read_bytes()
    with pytest.raises(KeyboardInterrupt), CacheWriter(path):
        raise KeyboardInterrupt
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["run.npz"]


# -- bad input ---------------------------------------------------------------------------


def test_frame_selection_errors(tmp_path):
    path = tmp_path / "run.npz"
    record(path, 2)
    cache = load_cache(path)
    with pytest.raises(ValueError, match="name the one you want"):
        cache.frame(0)
    with pytest.raises(KeyError, match="no system 'smoke'"):
        cache.frame(0, "smoke")
    with pytest.raises(IndexError, match="frame 2 out of range"):
        cache.frame(2, "puff")
    with pytest.raises(KeyError, match="'color' was not recorded"):
        cache.array("color", "puff")


def test_add_frame_errors(tmp_path):
    fountain, puff = make_systems()
    cache = CacheWriter(tmp_path / "run.npz")
    cache.add_frame(0.0, {"fountain": fountain})
    with pytest.raises(ValueError, match="same systems"):
        cache.add_frame(0.1, {"fountain": fountain, "puff": puff})
    with pytest.raises(ValueError, match="without '/'"):
        cache.add_frame(0.1, {"a/b": fountain})
    with pytest.raises(TypeError, match="ParticleSystem or ParticleStore"):
        cache.add_frame(0.1, {"fountain": np.zeros((3, 3))})
    with pytest.raises(ValueError, match="time must be finite"):
        cache.add_frame(float("nan"), {"fountain": fountain})
    cache.close()
    with pytest.raises(ValueError, match="closed"):
        cache.add_frame(0.2, {"fountain": fountain})
    with pytest.raises(ValueError, match=r"must end in \.npz"):
        CacheWriter(tmp_path / "run.npy")


def test_not_a_cache(tmp_path):
    text = tmp_path / "notes.npz"
    text.write_text("not an archive")
    with pytest.raises(ValueError, match=r"not a motes cache: not a NumPy .npz"):
        load_cache(text)
    empty = tmp_path / "empty.npz"
    empty.write_bytes(b"")
    with pytest.raises(ValueError, match="not a motes cache"):
        load_cache(empty)
    array = tmp_path / "array.npy"
    np.save(array, np.zeros(3))
    with pytest.raises(ValueError, match="single NumPy array"):
        load_cache(array)
    other = tmp_path / "other.npz"
    np.savez(other, positions=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="no 'format' entry"):
        load_cache(other)
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, format=np.array("other-cache"))
    with pytest.raises(ValueError, match="format is not 'motes-cache'"):
        load_cache(foreign)
    with pytest.raises(FileNotFoundError):
        load_cache(tmp_path / "missing.npz")


def rewrite(source, target, **changes):
    with np.load(source, allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files}
    arrays.update(changes)
    for key in [k for k, v in changes.items() if v is None]:
        del arrays[key]
    np.savez(target, **arrays)


def test_newer_version_and_damaged_files(tmp_path):
    good = tmp_path / "run.npz"
    record(good, 2)
    newer = tmp_path / "newer.npz"
    rewrite(good, newer, version=np.array(2))
    with pytest.raises(ValueError, match="format version 2, newer than this motes reads"):
        load_cache(newer)
    missing = tmp_path / "missing.npz"
    rewrite(good, missing, **{"puff/offsets": None})
    with pytest.raises(ValueError, match=r"damaged.*'puff/offsets' is missing"):
        load_cache(missing)
    short = tmp_path / "short.npz"
    rewrite(good, short, **{"fountain/color": np.zeros((1, 4), np.float32)})
    with pytest.raises(ValueError, match=r"damaged.*fountain/color has shape"):
        load_cache(short)
    offsets = tmp_path / "offsets.npz"
    rewrite(good, offsets, **{"puff/offsets": np.array([0, 5], np.int64)})
    with pytest.raises(ValueError, match=r"damaged.*bad puff/offsets"):
        load_cache(offsets)
