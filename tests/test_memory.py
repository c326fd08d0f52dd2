"""Sizes that would not fit in memory are refused before allocating, naming the
parameter, the estimate and the limit. ``MOTES_MEMORY_LIMIT`` sets the limit, so no test
depends on the machine's memory."""

from __future__ import annotations

import numpy as np
import pytest

import motes as mo
from motes import _memory
from motes.cli import main
from motes.fluids import Fluid, FluidModel, Tank, lattice
from motes.particles import ParticleStore
from motes.scene import SceneError, load_scene

GB = 10**9


@pytest.fixture
def limit(monkeypatch):
    """Set MOTES_MEMORY_LIMIT [bytes] for the test."""

    def set_limit(count: int) -> None:
        monkeypatch.setenv(_memory.LIMIT_VARIABLE, str(count))

    return set_limit


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert err.startswith("motes: error: ") and err.count("\n") == 1, err
    return err


@pytest.mark.parametrize(
    ("count", "text"),
    [(0, "0 B"), (999, "999 B"), (1000, "1.0 kB"), (15_230_000_000, "15.2 GB"),
     (41 * 10**12, "41.0 TB"), (3 * 10**18, "3000.0 PB")],
)  # fmt: skip
def test_sizes_read_in_decimal_units(count, text):
    assert _memory.format_bytes(count) == text


def test_the_limit_comes_from_the_environment_or_the_system(limit, monkeypatch):
    limit(12345)
    assert _memory.available() == (12345, "that MOTES_MEMORY_LIMIT allows")
    limit("lots")
    with pytest.raises(ValueError, match="MOTES_MEMORY_LIMIT must be a whole number of bytes"):
        _memory.available()
    monkeypatch.delenv(_memory.LIMIT_VARIABLE)
    found = _memory.available()
    assert found is None or found[0] > 0


def test_the_error_is_a_memory_error_and_a_value_error():
    assert issubclass(mo.InsufficientMemoryError, MemoryError)
    assert issubclass(mo.InsufficientMemoryError, ValueError)


def test_a_system_of_a_trillion_particles_is_refused(limit):
    limit(16 * GB)
    with pytest.raises(mo.InsufficientMemoryError) as error:
        mo.ParticleSystem(capacity=10**12)
    assert str(error.value) == (
        "capacity = 1000000000000 would need about 41.0 TB of memory (41 B per particle for "
        "5 attributes and the kill mask), more than the 16.0 GB that MOTES_MEMORY_LIMIT allows"
    )


def test_a_store_checks_what_it_holds_and_what_is_added(limit):
    limit(50 * 10**6)
    with pytest.raises(mo.InsufficientMemoryError, match=r"^capacity = 2000000 .* 82\.0 MB"):
        ParticleStore(2_000_000)
    store = ParticleStore(1_000_000)  # 41 MB
    with pytest.raises(mo.InsufficientMemoryError, match=r"57\.0 MB"):
        store.require("color")  # 16 B more per particle
    assert not store.has("color")  # nothing was allocated
    store.require("size")  # 45 MB: fits
    assert store.has("size")


def test_a_cloth_grid_is_refused_before_its_topology_is_built(limit):
    limit(8 * GB)
    with pytest.raises(mo.InsufficientMemoryError) as error:
        mo.Cloth.grid(100_000, 100_000)
    assert str(error.value).startswith(
        "nx × ny = 100000 × 100000 vertices would need about 20.5 TB of memory "
        "(about 2048 B per vertex)"
    )
    limit(1000)
    with pytest.raises(mo.InsufficientMemoryError, match=r"^vertices \(6\) would need"):
        mo.Cloth([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1], [1, 0, 1]], [[0, 1, 2]])


def test_hair_is_refused_before_its_strands_are_grown(limit):
    limit(GB)
    with pytest.raises(mo.InsufficientMemoryError) as error:
        mo.Hair(mo.Head(), strands=100_000, particles=100)
    assert str(error.value).startswith(
        "strands × particles = 100000 × 100 would need about 20.5 GB of memory "
        "(about 2048 B per particle), more than the 1.0 GB"
    )


def test_a_liquid_with_too_many_particles_is_refused(limit):
    limit(GB)
    with pytest.raises(mo.InsufficientMemoryError, match=r"^spacing = 0\.0001 \(1000000000000 "):
        lattice((0, 0, 0), (1, 1, 1), 1e-4)
    model = FluidModel(spacing=0.05, boundaries=(Tank((0, 0, 0), (1, 1, 1)),))
    limit(100_000)
    with pytest.raises(mo.InsufficientMemoryError, match=r"^positions \(1000 particles\)"):
        Fluid(model, np.zeros((3, 1000)))


def test_a_renderer_of_absurd_resolution_is_refused(limit):
    limit(GB)
    camera = mo.Camera((0, 1, 4), (0, 1, 0), resolution=(16384, 16384))
    with pytest.raises(mo.InsufficientMemoryError, match=r"^resolution = 16384x16384 .* 6\.4 GB"):
        mo.Renderer(camera)


CLOTH = """
[[body]]
name = "sail"
type = "cloth"
grid = [10000, 10000]
"""

LIQUID = """
[[body]]
name = "pool"
type = "fluid"
spacing = 0.05
max_particles = {limit}
  [[body.block]]
  lower = [0, 0, 0]
  upper = [{size}, {size}, {size}]
  [[body.source]]
  position = [0, 1, 0]
  velocity = [0, -1, 0]
  radius = 0.05
"""


@pytest.mark.parametrize(
    ("text", "path", "start"),
    [
        (CLOTH, "body[0]", "nx × ny = 10000 × 10000 vertices"),
        (LIQUID.format(limit=10**8, size=20), "body[0].block[0]", "spacing = 0.05 ("),
        (LIQUID.format(limit=10**8, size=0.1), "body[0].max_particles", "max_particles = "),
    ],
    ids=["cloth_grid", "liquid_block", "liquid_sources"],
)
def test_scene_bodies_name_the_key(limit, text, path, start):
    limit(GB)
    with pytest.raises(SceneError) as error:
        load_scene(text)
    assert error.value.path == path
    assert error.value.message.startswith(start)
    assert "that MOTES_MEMORY_LIMIT allows" in error.value.message


SCENE = """
[scene]
name = "big"
[camera]
resolution = [32, 18]
[[system]]
name = "dust"
capacity = 1000
  [[system.emitter]]
  rate = { type = "burst", count = 5 }
"""


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--set", "system.dust.capacity=100000000"],
         "motes: error: system[0].capacity: capacity = 100000000 would need about 4.1 GB"),
        (["--resolution", "16384x16384"],
         "motes: error: resolution = 16384x16384 would need about 6.4 GB"),
    ],
)  # fmt: skip
def test_motes_run_refuses_before_simulating(limit, tmp_path, capsys, args, message):
    limit(GB)
    source = tmp_path / "big.toml"
    source.write_text(SCENE)
    out = tmp_path / "big.mp4"
    assert main(["run", str(source), "-o", str(out), "-q", *args]) == 2
    assert one_error_line(capsys).startswith(message)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.toml"]  # no output begun
