"""Same seed → bit-identical state; different seeds differ; neither the thread count nor
whether kernels were just compiled or loaded from Numba's disk cache matters."""

import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest
from numpy.testing import assert_array_equal

import motes
from motes._jit import SERIAL_BELOW, ordered_sum
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


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("count", [0, 1, 7, 8, 19, 64, 203])
def test_ordered_sum_adds_in_its_documented_order(count, dtype):
    """Eight running sums (value v into sum v mod 8), added pairwise, then the rest in
    order: the same bits as that order spelled out in NumPy, in the input's dtype (a sum
    promoted to float64 would round differently)."""
    values = np.random.default_rng(count).standard_normal(count + 5).astype(dtype)
    whole = count // 8 * 8
    lanes = [dtype(0)] * 8
    for v in range(whole):
        lanes[v % 8] = dtype(lanes[v % 8] + values[v])
    expected = dtype((lanes[0] + lanes[1]) + (lanes[2] + lanes[3])) + dtype(
        (lanes[4] + lanes[5]) + (lanes[6] + lanes[7])
    )
    for v in range(whole, count):
        expected = dtype(expected + values[v])
    got = numba.njit(lambda a, n: ordered_sum(a, n))(values, count)
    assert got == expected


# -- freshly compiled against loaded from Numba's disk cache -------------------------------
#: Few kernels (emission, the fused step, curl noise), so a cold compile takes seconds, and
#: enough particles (14,400 by the last frame) that two threads share the work.
#: Curl noise is there because its kernel is the one whose cached copy rounded differently
#: when fast-math let LLVM reassociate (docs/architecture.md, "Threads and determinism");
#: the swept sphere because its step kernel once missed the cache in every process.
SMALL_SCENE = """\
[scene]
duration = 0.8
fps = 30
seed = 3

[[system]]
name = "plume"
capacity = 30000

  [[system.emitter]]
  shape = { type = "disc", radius = 0.3 }
  rate = { type = "per_second", rate = 18000 }
  speed = { uniform = [0.2, 0.6] }
  lifetime = { uniform = [1.0, 2.0] }

  [[system.force]]
  type = "gravity"
  acceleration = [0.0, 1.5, 0.0]

  [[system.force]]
  type = "curl_noise"
  strength = 1.3
  scale = 0.3
  time_scale = 1.0

  [[system.collider]]
  type = "sphere"
  center = [0.0, 0.6, 0.0]
  radius = 0.15
  detection = "priori"
"""


def run_in_subprocess(args, *, cache: Path, threads: int) -> str:
    """``python -m motes run ARGS`` in a fresh interpreter that compiles into, or loads from,
    ``cache`` and runs ``threads`` Numba threads; returns Numba's cache log (stdout)."""
    source = str(Path(motes.__file__).resolve().parents[1])
    path = os.pathsep.join(p for p in (source, os.environ.get("PYTHONPATH")) if p)
    env = dict(
        os.environ,
        NUMBA_CACHE_DIR=str(cache),
        NUMBA_NUM_THREADS=str(threads),
        NUMBA_DEBUG_CACHE="1",
        PYTHONPATH=path,
    )
    result = subprocess.run(
        [sys.executable, "-m", "motes", "run", *map(str, args), "--quiet"],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return result.stdout


def differing_arrays(a: Path, b: Path) -> list[str]:
    with np.load(a) as x, np.load(b) as y:
        return [k for k in x.files if k not in y.files or not np.array_equal(x[k], y[k])]


def assert_same_runs(outputs: dict[str, Path]) -> None:
    """Every output file has the same bytes as the first."""
    (first, reference), *others = outputs.items()
    for name, path in others:
        if path.read_bytes() != reference.read_bytes():
            detail = differing_arrays(reference, path) if path.suffix == ".npz" else "pixels"
            raise AssertionError(f"{name} differs from {first}: {detail}")


def test_cold_and_cached_kernels_on_one_or_two_threads_give_identical_exports(tmp_path):
    """A fresh compile and a load from the disk cache run the same arithmetic.

    A cached kernel's callees exist twice in a cold process (compiled on their own, and
    linked into the kernel and optimised again); fast-math flags that let LLVM reassociate
    or contract made the two copies round differently (5 of 31 frames of the fire).
    """
    scene = tmp_path / "plume.toml"
    scene.write_text(SMALL_SCENE)
    cache = tmp_path / "numba-cache"
    runs = {"cold, 2 threads": 2, "cached, 2 threads": 2, "cached, 1 thread": 1}
    outputs = {}
    for name, threads in runs.items():
        outputs[name] = tmp_path / f"{len(outputs)}.npz"
        log = run_in_subprocess(
            [scene, "--no-render", "--export", outputs[name]], cache=cache, threads=threads
        )
        if name.startswith("cached"):  # every kernel loaded: none compiled and saved again
            assert "data saved" not in log, [x for x in log.splitlines() if "data saved" in x]
    with np.load(outputs["cold, 2 threads"]) as export:
        last_frame = np.diff(export["plume/offsets"])[-1]
    assert last_frame > SERIAL_BELOW  # so two threads did share the work
    assert_same_runs(outputs)


@pytest.mark.slow
def test_cold_and_cached_renders_of_the_fire_are_identical_on_one_or_two_threads(tmp_path):
    """The built-in fire rendered too (sprite, binning and tone-mapping kernels): its last
    frame's PNG and its export, compiled afresh on one and on two threads (two empty
    caches), then from the first cache on two and on one."""
    runs = [
        ("cold, 1 thread", "cache-a", 1),
        ("cold, 2 threads", "cache-b", 2),
        ("cached, 2 threads", "cache-a", 2),
        ("cached, 1 thread", "cache-a", 1),
    ]
    images, exports = {}, {}
    for number, (name, cache, threads) in enumerate(runs):
        images[name] = tmp_path / f"{number}.png"
        exports[name] = tmp_path / f"{number}.npz"
        run_in_subprocess(
            ["fire", "-o", images[name], "--export", exports[name], "--frames", "31",
             "--resolution", "320x180"],
            cache=tmp_path / cache,
            threads=threads,
        )  # fmt: skip
    assert_same_runs(exports)
    assert_same_runs(images)
