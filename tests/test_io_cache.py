"""Particle cache: the documented file layout, round trips of every kind, old files, bad
files, interruption."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

import motes as mo
from motes.io.cache import FORMAT, VERSION, CacheWriter, load_cache
from motes.state import CORE, ParticleState
from particle_kinds import DT as STEP
from particle_kinds import KINDS, make_system

DT = 1 / 30
#: The two containers: HDF5 (format version 3) and NumPy's .npz (version 2).
SUFFIXES = (".h5", ".npz")


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
    """Every attribute of the system's state, one row per particle (the file's layout)."""
    state = system.particle_state()
    return {a: np.array(state[a].T) for a in state.names()}


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
@pytest.mark.parametrize("suffix", SUFFIXES)
def test_round_trip(tmp_path, suffix, compress):
    path = tmp_path / f"run{suffix}"
    expected = record(path, 6, compress=compress)
    cache = load_cache(path)
    assert cache.frame_count == len(cache) == 6
    assert cache.names == cache.systems == ("fountain", "puff")
    np.testing.assert_array_equal(cache.times, [t for t, _, _ in expected])
    fields = ("age", "lifetime", "color")
    assert cache.attributes("fountain")[:4] == tuple(CORE)
    assert set(cache.attributes("fountain")) == {*CORE, *fields}
    assert cache.attributes("puff") == (*CORE, "age", "lifetime")
    assert cache.unit("positions", "puff") == "m" and cache.unit("color", "fountain") == "1"
    assert (cache.scene, cache.seed, cache.motes_version) == (None, None, mo.__version__)
    for f, (_, fountain, puff) in enumerate(expected):
        for name, want in (("fountain", fountain), ("puff", puff)):
            got = cache.frame(f, name)
            assert set(got) == set(want)
            for attribute, values in want.items():
                # the store is float32 and so is the cache: copied bit for bit
                np.testing.assert_array_equal(got[attribute], values)
    # the puff bursts at t = 2 DT, in the third step: empty frames are kept, as empty
    np.testing.assert_array_equal(cache.counts("puff"), [0, 0, 30, 30, 30, 30])
    assert cache.frame(0, "puff")["positions"].shape == (0, 3)
    assert cache.frame(-1, "fountain")["ids"].dtype == np.int64


def test_file_layout_is_the_documented_one(tmp_path):
    path = tmp_path / "run.npz"
    expected = record(path, 3)
    with zipfile.ZipFile(path) as archive:
        assert archive.testzip() is None
    with np.load(path, allow_pickle=False) as data:
        assert str(data["format"]) == FORMAT == "motes-cache"
        assert int(data["version"]) == 2 and VERSION == 3
        assert str(data["motes_version"]) == mo.__version__
        assert str(data["scene"]) == "" and int(data["seed"]) == -1
        assert str(data["overrides"]) == "{}"
        assert float(data["fps"]) == 0.0  # not given
        assert data["times"].dtype == np.float64 and data["times"].shape == (3,)
        assert list(data["names"]) == ["fountain", "puff"]
        puff = ("ids", "positions", "velocities", "radius", "age", "lifetime")
        assert list(data["puff/attributes"]) == list(puff)
        assert list(data["puff/units"]) == ["", "m", "m/s", "m", "s", "s"]
        assert len(data["puff/docs"]) == len(puff)
        meta = ("attributes", "units", "docs", "offsets")
        assert sorted(data.files) == sorted(
            ["format", "version", "motes_version", "scene", "seed", "fps", "overrides"]
            + ["times", "names"]
            + [f"puff/{k}" for k in meta + puff]
            + [f"fountain/{k}" for k in meta + tuple(data["fountain/attributes"])]
        )
        offsets = data["fountain/offsets"]
        counts = [len(fountain["positions"]) for _, fountain, _ in expected]
        np.testing.assert_array_equal(offsets, np.concatenate([[0], np.cumsum(counts)]))
        n = offsets[-1]
        for key, shape, dtype in [
            ("positions", (n, 3), np.float32),
            ("velocities", (n, 3), np.float32),
            ("color", (n, 4), np.float32),
            ("radius", (n,), np.float32),
            ("ids", (n,), np.int64),
        ]:
            assert data[f"fountain/{key}"].shape == shape
            assert data[f"fountain/{key}"].dtype == dtype
        # frame 1's rows, read with NumPy alone
        rows = slice(offsets[1], offsets[2])
        np.testing.assert_array_equal(data["fountain/positions"][rows], expected[1][1]["positions"])


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_a_bare_float64_store_is_recorded_in_its_own_dtype(tmp_path, suffix):
    store = mo.ParticleStore(10, ("size",), dtype=np.float64)
    store.spawn(4)
    store["position"][:] = np.arange(12).reshape(4, 3) / 3
    path = tmp_path / f"store{suffix}"
    with CacheWriter(path) as cache:
        cache.add_frame(0.0, {"store": store})
    frame = load_cache(path).frame(0)
    assert frame["positions"].dtype == np.float64
    np.testing.assert_array_equal(frame["positions"], store["position"])
    assert set(frame) == {*CORE, "age", "lifetime"}


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_loaded_arrays_are_read_only(tmp_path, suffix):
    path = tmp_path / f"run{suffix}"
    record(path, 2)
    position = load_cache(path).frame(1, "fountain")["positions"]
    with pytest.raises(ValueError, match="read-only"):
        position[0] = 0.0


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_exception_still_writes_the_frames_so_far(tmp_path, suffix):
    path = tmp_path / f"run{suffix}"
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
    assert [p.name for p in tmp_path.iterdir()] == [f"run{suffix}"]  # no temporary file left


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_no_frames_keeps_an_earlier_file(tmp_path, suffix):
    path = tmp_path / f"run{suffix}"
    record(path, 2)
    before = path.read_bytes()
    with pytest.raises(KeyboardInterrupt), CacheWriter(path):
        raise KeyboardInterrupt
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == [f"run{suffix}"]


# -- bad input ---------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_frame_selection_errors(tmp_path, suffix):
    path = tmp_path / f"run{suffix}"
    record(path, 2)
    cache = load_cache(path)
    with pytest.raises(ValueError, match="name the one you want"):
        cache.frame(0)
    with pytest.raises(KeyError, match="no entry 'smoke'"):
        cache.frame(0, "smoke")
    with pytest.raises(IndexError, match="frame 2 out of range"):
        cache.frame(2, "puff")
    with pytest.raises(KeyError, match="'color' was not recorded"):
        cache.array("color", "puff")


def test_add_frame_errors(tmp_path):
    fountain, puff = make_systems()
    cache = CacheWriter(tmp_path / "run.npz")
    cache.add_frame(0.0, {"fountain": fountain})
    with pytest.raises(ValueError, match="same names"):
        cache.add_frame(0.1, {"fountain": fountain, "puff": puff})
    with pytest.raises(ValueError, match="without '/'"):
        cache.add_frame(0.1, {"a/b": fountain})
    with pytest.raises(TypeError, match=r"items\['fountain'\]: expected a ParticleState"):
        cache.add_frame(0.1, {"fountain": np.zeros((3, 3))})
    with pytest.raises(ValueError, match="time must be finite"):
        cache.add_frame(float("nan"), {"fountain": fountain})
    cache.close()
    with pytest.raises(ValueError, match="closed"):
        cache.add_frame(0.2, {"fountain": fountain})
    with pytest.raises(ValueError, match=r"must end in \.h5, \.hdf5 or \.npz"):
        CacheWriter(tmp_path / "run.npy")


def test_not_a_cache(tmp_path):
    text = tmp_path / "notes.npz"
    text.write_text("not an archive")
    with pytest.raises(ValueError, match=r"not a motes cache: not an HDF5 or NumPy .npz"):
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
    rewrite(good, newer, version=np.array(4))
    with pytest.raises(ValueError, match="format version 4, newer than this motes reads"):
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
    no_object = tmp_path / "overrides.npz"
    rewrite(good, no_object, overrides=np.array("[1, 2]"))
    with pytest.raises(ValueError, match=r"damaged.*'overrides' is not a JSON object"):
        load_cache(no_object)
    older = tmp_path / "older.npz"
    rewrite(good, older, overrides=None)
    assert load_cache(older).overrides == {}


# -- every kind --------------------------------------------------------------------------


# The liquid's and the flock's steps compile for most of a minute each on a cold cache;
# their round trips run in the slow tier (the other kinds check the same contract).
COMPILE_HEAVY = {"fluid", "flock"}


@pytest.mark.parametrize(
    "kind", [pytest.param(k, marks=pytest.mark.slow) if k in COMPILE_HEAVY else k for k in KINDS]
)
@pytest.mark.parametrize("suffix", SUFFIXES)
def test_round_trip_of_every_kind_equals_the_live_state(tmp_path, kind, suffix):
    make = KINDS[kind][0]
    thing = make()
    path = tmp_path / f"{kind}{suffix}"
    live = []
    with CacheWriter(path, scene="test", seed=7) as cache:
        for _ in range(3):
            thing.step(STEP)
            state = thing.particle_state()
            cache.add_frame(thing.time, {kind: thing})
            live.append({a: np.array(state[a]) for a in state.names()})
            units = {a: state.unit(a) for a in state.names()}
    loaded = load_cache(path)
    assert (loaded.scene, loaded.seed, loaded.names) == ("test", 7, (kind,))
    assert loaded.attributes() == tuple(live[0])
    for f, want in enumerate(live):
        got = loaded.state(f)
        assert got.names() == tuple(want)
        for attribute, values in want.items():
            assert got[attribute].dtype == values.dtype  # the kind's own precision
            np.testing.assert_array_equal(got[attribute], values)
            assert got.unit(attribute) == units[attribute]
        np.testing.assert_array_equal(loaded.frame(f)["positions"], want["positions"].T)


def test_a_later_frame_must_have_every_recorded_attribute(tmp_path):
    system = make_system()
    system.step(STEP)
    cache = CacheWriter(tmp_path / "run.npz")
    cache.add_frame(0.0, {"a": system})
    with pytest.raises(ValueError, match="'a' has no attribute 'color'"):
        cache.add_frame(0.1, {"a": mo.ParticleStore(5)})


def test_format_version_1_files_are_read_under_the_new_names(tmp_path):
    path = tmp_path / "old.npz"
    position = np.arange(9, dtype=np.float32).reshape(3, 3)
    np.savez(
        path,
        format=np.array("motes-cache"),
        version=np.array(1),
        times=np.array([0.5]),
        systems=np.array(["rain"]),
        **{
            "rain/attributes": np.array(["position", "velocity", "id"]),
            "rain/offsets": np.array([0, 3]),
            "rain/position": position,
            "rain/velocity": -position,
            "rain/id": np.array([4, 5, 6]),
        },
    )
    cache = load_cache(path)
    assert cache.version == 1 and cache.names == ("rain",)
    assert cache.attributes() == ("positions", "velocities", "ids")
    assert (cache.scene, cache.seed, cache.motes_version) == (None, None, None)
    state = cache.state(0)
    np.testing.assert_array_equal(state.positions, position.T)
    np.testing.assert_array_equal(state.ids, [4, 5, 6])
    np.testing.assert_array_equal(state.radius, np.float32(0.05))  # the size default
    assert state.unit("velocities") == "m/s"


# -- the HDF5 container: streamed, compressed, optionally lossy --------------------------


def test_hdf5_layout_mirrors_the_npz_keys_and_is_compressed(tmp_path):
    h5py = pytest.importorskip("h5py")
    record(tmp_path / "run.npz", 4, scene="fire", seed=3, fps=30.0)
    record(tmp_path / "run.h5", 4, scene="fire", seed=3, fps=30.0)
    with np.load(tmp_path / "run.npz") as npz, h5py.File(tmp_path / "run.h5") as h5:
        datasets = set()
        h5.visititems(lambda k, v: datasets.add(k) if isinstance(v, h5py.Dataset) else None)
        assert datasets == set(npz.files) | {"significant_digits"}
        assert h5["format"].asstr()[()] == "motes-cache" and int(h5["version"][()]) == 3
        assert h5["scene"].asstr()[()] == "fire" and int(h5["seed"][()]) == 3
        assert int(h5["significant_digits"][()]) == -1
        for key in set(npz.files) - {"version"}:
            if npz[key].dtype.kind == "U":
                assert list(np.atleast_1d(h5[key].asstr()[()])) == list(np.atleast_1d(npz[key]))
            else:
                np.testing.assert_array_equal(h5[key][()], npz[key])
                assert h5[key].dtype == npz[key].dtype
        positions = h5["fountain/positions"]
        assert positions.chunks is not None and positions.maxshape == (None, 3)
        assert positions.compression == "gzip" and positions.shuffle


def test_significant_digits_bound_the_relative_error_and_shrink_the_file(tmp_path):
    exact = tmp_path / "exact.h5"
    lossy = tmp_path / "lossy.h5"
    record(exact, 12)
    record(lossy, 12, significant_digits=3)
    with load_cache(exact) as want, load_cache(lossy) as got:
        assert (want.significant_digits, got.significant_digits) == (None, 3)
        assert got.lossy and not want.lossy
        for f in range(12):
            a, b = want.frame(f, "fountain"), got.frame(f, "fountain")
            np.testing.assert_array_equal(a["ids"], b["ids"])  # integers kept exactly
            for key in ("positions", "velocities", "color", "radius", "age"):
                error = np.abs(b[key].astype(np.float64) - a[key])
                assert np.all(error <= 0.5e-3 * np.abs(a[key].astype(np.float64)))
    assert lossy.stat().st_size < exact.stat().st_size
    with pytest.raises(ValueError, match=r"needs an \.h5 cache"):
        CacheWriter(tmp_path / "run.npz", significant_digits=3)
    with pytest.raises(ValueError, match=r"significant_digits must be in \[1, 15\]"):
        CacheWriter(lossy, significant_digits=16)


def test_round_significant_matches_a_frexp_reference():
    from motes.io.cache_h5 import round_significant

    rng = np.random.default_rng(4)
    values = (rng.standard_normal(20_000) * 10.0 ** rng.integers(-6, 6, 20_000)).astype(np.float32)
    values[:4] = [0.0, -0.0, 1.5, 2.5]
    for digits in (1, 3, 5):
        bits = int(np.ceil(digits * np.log2(10))) + 1  # significant bits with the leading one
        mantissa, exponent = np.frexp(values.astype(np.float64))
        want = np.ldexp(np.rint(mantissa * 2.0**bits), exponent - bits)  # ties to even
        np.testing.assert_array_equal(round_significant(values, digits), want.astype(np.float32))
    special = np.array([np.nan, np.inf, -np.inf], np.float32)
    np.testing.assert_array_equal(round_significant(special, 2), special)
    assert round_significant(values, 8) is values  # float32 holds no more than 7 digits


def peak_memory_of_a_run(path, frames: int, store) -> int:
    """Peak bytes NumPy and Python allocated while ``frames`` frames were cached."""
    import tracemalloc

    with CacheWriter(path) as cache:
        cache.add_frame(0.0, {"store": store})  # the first frame sets up the file
        tracemalloc.start()
        for k in range(1, frames):
            store["position"][:, 0] = k
            cache.add_frame(k * DT, {"store": store})
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return peak


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_memory_stays_flat_however_many_frames(tmp_path, suffix):
    from motes.io import cache_h5

    store = mo.ParticleStore(50_000, ("color",))
    store.spawn(50_000)
    state = store.particle_state()
    frame_bytes = sum(state[a].nbytes for a in state.names())  # 3 MB
    peak = peak_memory_of_a_run(tmp_path / f"long{suffix}", 90, store)
    # What a writer may hold whatever the frame count: a frame's copy for the sink; for
    # .h5 also the chunks being encoded (each with its shuffled and deflated bytes) and
    # the partly filled chunk of each of the 5 attributes.
    held = 2 * frame_bytes
    if suffix == ".h5":
        held += (2 * cache_h5.IN_FLIGHT + 2 * cache_h5.ENCODERS + 5) * cache_h5.CHUNK_BYTES
    assert peak < held < 90 * frame_bytes / 6
    with load_cache(tmp_path / f"long{suffix}") as loaded:
        assert loaded.frame_count == 90
        np.testing.assert_array_equal(loaded.frame(89, "store")["positions"][:, 0], 89)


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_a_write_that_fails_midway_keeps_the_whole_frames(tmp_path, suffix, monkeypatch):
    from motes.io import cache_h5, cache_npz

    path = tmp_path / f"run{suffix}"
    fountain, puff = make_systems()
    sink = cache_h5.H5Sink if suffix == ".h5" else cache_npz.NpzSink
    add = sink.add

    class HalfWritten(dict):
        """A frame's record whose second entry cannot be written (the disk is full)."""

        def items(self):
            yield from list(super().items())[:1]
            raise OSError("No space left on device")

    def fail_at_frame_3(self, time, record):
        add(self, time, HalfWritten(record) if cache.frame_count == 3 else record)

    monkeypatch.setattr(sink, "add", fail_at_frame_3)
    with CacheWriter(path) as cache:
        for k in range(5):
            fountain.step(DT)
            puff.step(DT)
            if k < 3:
                cache.add_frame(fountain.time, {"fountain": fountain, "puff": puff})
            elif k == 3:
                with pytest.raises(OSError, match="No space"):
                    cache.add_frame(fountain.time, {"fountain": fountain, "puff": puff})
            else:
                with pytest.raises(ValueError, match="failed at frame 3"):
                    cache.add_frame(fountain.time, {"fountain": fountain, "puff": puff})
    with load_cache(path) as loaded:
        assert loaded.frame_count == 3
        assert len(loaded.array("positions", "fountain")) == loaded.offsets("fountain")[-1]
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_surfaces_of_every_frame_come_back(tmp_path, suffix):
    from motes.io.entry import Entry

    rng = np.random.default_rng(5)
    state = ParticleState(np.arange(4), rng.random((3, 4)), np.zeros((3, 4)), np.ones(4))
    meshes = []
    for vertices in (5, 0, 12, 3):  # a frame with an empty surface among them
        faces = rng.integers(0, max(vertices, 1), (2 * vertices, 3))
        meshes.append((rng.random((vertices, 3)).astype(np.float32), np.array(faces, np.int64)))
    path = tmp_path / f"run{suffix}"
    with CacheWriter(path) as cache:
        for k, mesh in enumerate(meshes):
            cache.add_frame(k * DT, {"liquid": Entry(state, surface=mesh)})
        cache.add_frame(4 * DT, {"liquid": Entry(state)})  # no surface: an empty one
    with load_cache(path) as loaded:
        for k, (vertices, faces) in enumerate(meshes):
            got = loaded.entry(k).surface
            assert_equal = np.testing.assert_array_equal
            assert_equal(got[0], vertices)
            assert_equal(got[1], np.asarray(faces).reshape(-1, 3))
        assert loaded.entry(4).surface[0].shape == (0, 3)


def test_damage_found_when_an_h5_frame_is_read_names_the_file_and_entry(tmp_path):
    from motes.io.cache import DamagedCacheError

    path = tmp_path / "run.h5"
    store = mo.ParticleStore(20_000)
    store.spawn(20_000)
    store["position"][:] = np.random.default_rng(0).random((20_000, 3))
    with CacheWriter(path) as cache:
        for k in range(6):
            cache.add_frame(k * DT, {"store": store})
    size = path.stat().st_size
    with open(path, "r+b") as stream:  # zeros over the middle of the compressed chunks
        stream.seek(size // 2)
        stream.write(bytes(size // 8))
    damaged = r"run\.h5 is a damaged motes cache: store/"
    # the index is intact: the damage shows when a frame is read
    with load_cache(path) as loaded, pytest.raises(DamagedCacheError, match=damaged):
        for f in range(6):
            loaded.frame(f, "store")
