"""Rigid-world benchmarks: 100 ragdolls in real time, and a 100k-particle stick lattice.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.ragdoll           # full sizes, about a minute
    PYTHONPATH=src python -m benchmarks.ragdoll --quick   # shrunk sizes, seconds

It prints a table, then one line of JSON with the figures:

- **ragdolls**: 100 ragdolls (15 particles and 31 constraints each: 1,500 particles,
  3,100 constraints) thrown onto a ground plane, stepped by :class:`motes.rigid.World`
  at h = 1/60 s with 10 relaxation iterations (constraints, ground contacts and the
  torsos' body contacts relaxed together). The figure is milliseconds per step; real
  time at 60 Hz is 16.7 ms. The same world on one thread is reported beside it.
- **lattice**: 100,000 particles in a square lattice joined by about 400,000 sticks
  (edges and both diagonals of every cell, rest lengths stretched 5 % away), relaxed by
  :meth:`motes.constrain.ConstraintSet.sweep`, against :func:`numpy_sweep`, the same
  colour-by-colour Gauss–Seidel sweep vectorised per colour in NumPy (it produces the
  same positions to round-off). The figure is constraint projections per second and its
  ratio to NumPy's. Each colour is a parallel loop that waits for its slowest thread: on
  a machine whose cores are busy with other work the parallel sweep can take ten times
  its best time, so the one-thread sweep is reported beside it, and
  ``lattice_100k_speedup_vs_numpy`` is NumPy's time over the faster of the two (the
  all-thread ratio is ``lattice_100k_parallel_speedup_vs_numpy``).

Timings are the best of several calls after warm-up calls, with the median beside it;
the cores other processes kept busy are reported too (a shared machine inflates them).
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass

import numba
import numpy as np

import motes.rigid as mr
from motes.collide import Plane
from motes.constrain import ConstraintBuilder

from ._common import Timing, benchmark_main, machine, table, time_calls

RAGDOLL_KEY = "ragdolls_100"
LATTICE_KEY = "lattice_100k"


@dataclass(frozen=True)
class Sizes:
    ragdolls: int
    lattice_side: int
    repeat: int

    @staticmethod
    def full() -> Sizes:
        return Sizes(100, 317, 20)

    @staticmethod
    def quick() -> Sizes:
        return Sizes(10, 60, 3)


def ragdoll_world(count: int, *, seed: int = 0) -> mr.World:
    """``count`` ragdolls on a grid 2 m apart, thrown with random velocities, on a plane."""
    rng = np.random.default_rng(seed)
    world = mr.World(iterations=10)
    world.add_collider(Plane((0, 1, 0), 0.0, friction=0.6))
    side = int(np.ceil(np.sqrt(count)))
    for k in range(count):
        doll = mr.add_ragdoll(world, (2.0 * (k % side), 0.3, 2.0 * (k // side)))
        world.set_velocity(doll.indices, rng.uniform((-1, 0, -1), (1, 3, 1)))
    return world


def lattice(side: int, *, seed: int = 0):
    """A ``side²`` square lattice with sticks on edges and diagonals, positions
    perturbed so every stick is 5 % off its rest length. Returns the constraint set,
    positions (3, n) and inverse masses."""
    idx = np.arange(side * side).reshape(side, side)
    pairs = np.concatenate(
        [
            np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()],
            np.c_[idx[:-1].ravel(), idx[1:].ravel()],
            np.c_[idx[:-1, :-1].ravel(), idx[1:, 1:].ravel()],
            np.c_[idx[:-1, 1:].ravel(), idx[1:, :-1].ravel()],
        ]
    )
    grid = np.stack(np.meshgrid(np.arange(side), np.arange(side), indexing="ij"), -1)
    rest_pos = np.c_[grid.reshape(-1, 2) * 0.01, np.zeros(side * side)]
    rest = np.linalg.norm(rest_pos[pairs[:, 1]] - rest_pos[pairs[:, 0]], axis=1)
    builder = ConstraintBuilder()
    builder.add_sticks(pairs, rest)
    constraints = builder.build(side * side)
    rng = np.random.default_rng(seed)
    position = np.ascontiguousarray((rest_pos * 1.05 + rng.normal(0, 1e-4, rest_pos.shape)).T)
    inv_mass = np.ones(side * side)
    return constraints, position, inv_mass


def numpy_sweep(constraints, position, inv_mass) -> None:
    """One Gauss–Seidel sweep of rigid sticks, one vectorised NumPy pass per colour.

    Within a colour no particle appears twice, so the fancy-index updates are exact;
    the projection is the kernel's (``α = 0``, ``k = 1``, exact square root).
    """
    for c in range(constraints.color_count):
        s = slice(constraints.color_start[c], constraints.color_start[c + 1])
        i, j = constraints.ends[s, 0], constraints.ends[s, 1]
        d = position[:, j] - position[:, i]
        length = np.sqrt((d * d).sum(axis=0))
        wi, wj = inv_mass[i], inv_mass[j]
        target = np.clip(length, constraints.lo[s], constraints.hi[s])
        scale = -(length - target) / ((wi + wj) * np.where(length > 0, length, 1.0))
        position[:, i] -= wi * scale * d
        position[:, j] += wj * scale * d


def bench_ragdolls(sizes: Sizes) -> dict:
    world = ragdoll_world(sizes.ragdolls)
    for _ in range(30):  # let them land: contacts are what costs
        world.step(1 / 60)
    timing = time_calls(lambda: world.step(1 / 60), repeat=sizes.repeat * 5, warmup=2)
    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        one = time_calls(lambda: world.step(1 / 60), repeat=sizes.repeat * 5, warmup=2)
    finally:
        numba.set_num_threads(previous)
    return {
        "timing": timing,
        "one_thread": one,
        "particles": world.count,
        "constraints": len(world.constraints),
    }


def bench_lattice(sizes: Sizes) -> dict:
    constraints, position, inv_mass = lattice(sizes.lattice_side)
    ours = position.copy()
    theirs = position.copy()
    timing = time_calls(
        lambda: constraints.sweep(ours, inv_mass, 1 / 60), repeat=sizes.repeat, warmup=2
    )
    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        one = time_calls(
            lambda: constraints.sweep(ours, inv_mass, 1 / 60), repeat=sizes.repeat, warmup=1
        )
    finally:
        numba.set_num_threads(previous)
    base = time_calls(
        lambda: numpy_sweep(constraints, theirs, inv_mass),
        repeat=max(2, sizes.repeat // 4),
        warmup=1,
    )
    m = len(constraints)
    return {
        "timing": timing,
        "one_thread": one,
        "numpy": base,
        "particles": constraints.particle_count,
        "constraints": m,
        "colors": constraints.color_count,
        "per_s": m / timing.best,
        "numpy_per_s": m / base.best,
    }


def _ms(timing: Timing) -> str:
    return f"{1e3 * timing.best:9.2f} ms (median {1e3 * timing.median:.2f})"


def run(sizes: Sizes, *, quick: bool, out=print) -> dict:
    info = machine()
    threads = info["numba_threads"]
    figures: dict = {
        "date": datetime.date.today().isoformat(),
        "quick": quick,
        "sizes": {"ragdolls": sizes.ragdolls, "lattice_side": sizes.lattice_side},
        "cpu_count": info["cpu_count"],
        "numba_threads": threads,
        "background_busy_cores": info["background_busy_cores"],
    }
    rows = [
        (
            "machine",
            f"{info['usable_cores']} usable cores, {threads} Numba threads, {info['processor']}",
        ),
        ("other load", f"{info['background_busy_cores']:.2f} cores busy at the start"),
        ("versions", f"Python {info['python']}, NumPy {info['numpy']}, Numba {info['numba']}"),
    ]
    out(table(rows, title="motes rigid benchmark" + (" (--quick sizes)" if quick else "")))

    r = bench_ragdolls(sizes)
    figures |= {
        f"{RAGDOLL_KEY}_ms": 1e3 * r["timing"].best,
        f"{RAGDOLL_KEY}_median_ms": 1e3 * r["timing"].median,
        f"{RAGDOLL_KEY}_1thread_ms": 1e3 * r["one_thread"].best,
        f"{RAGDOLL_KEY}_particles": r["particles"],
        f"{RAGDOLL_KEY}_constraints": r["constraints"],
        f"{RAGDOLL_KEY}_realtime_factor": (1 / 60) / r["timing"].best,
    }
    out()
    out(
        table(
            [
                (
                    "ragdolls",
                    f"{sizes.ragdolls} ({r['particles']} particles, "
                    f"{r['constraints']} constraints), 10 iterations, h = 1/60 s",
                ),
                ("step", _ms(r["timing"])),
                ("step, 1 thread", _ms(r["one_thread"])),
                ("real time at 60 Hz", f"{(1 / 60) / r['timing'].best:9.1f}x faster than needed"),
            ],
            title="1. Ragdolls",
        )
    )

    lat = bench_lattice(sizes)
    figures |= {
        f"{LATTICE_KEY}_sweep_ms": 1e3 * lat["timing"].best,
        f"{LATTICE_KEY}_numpy_sweep_ms": 1e3 * lat["numpy"].best,
        f"{LATTICE_KEY}_1thread_sweep_ms": 1e3 * lat["one_thread"].best,
        f"{LATTICE_KEY}_1thread_speedup_vs_numpy": lat["numpy"].best / lat["one_thread"].best,
        f"{LATTICE_KEY}_projections_per_s": lat["per_s"],
        f"{LATTICE_KEY}_numpy_projections_per_s": lat["numpy_per_s"],
        f"{LATTICE_KEY}_parallel_speedup_vs_numpy": lat["per_s"] / lat["numpy_per_s"],
        f"{LATTICE_KEY}_speedup_vs_numpy": lat["numpy"].best
        / min(lat["timing"].best, lat["one_thread"].best),
        f"{LATTICE_KEY}_particles": lat["particles"],
        f"{LATTICE_KEY}_constraints": lat["constraints"],
        f"{LATTICE_KEY}_colors": lat["colors"],
    }
    out()
    out(
        table(
            [
                (
                    "lattice",
                    f"{lat['particles']} particles, {lat['constraints']} sticks, "
                    f"{lat['colors']} colours",
                ),
                ("motes sweep", _ms(lat["timing"])),
                ("motes sweep, 1 thread", _ms(lat["one_thread"])),
                ("NumPy sweep", _ms(lat["numpy"])),
                ("projections/s", f"{lat['per_s']:.3g} (NumPy {lat['numpy_per_s']:.3g})"),
                ("speed-up, all threads", f"{lat['per_s'] / lat['numpy_per_s']:9.1f}x"),
                ("speed-up, 1 thread", f"{lat['numpy'].best / lat['one_thread'].best:9.1f}x"),
            ],
            title="2. Stick lattice, one relaxation sweep",
        )
    )
    return figures


def main(argv: list[str] | None = None) -> dict:
    return benchmark_main(
        argv,
        prog="python -m benchmarks.ragdoll",
        doc=__doc__,
        quick_help="10 ragdolls, a 3,600-particle lattice",
        run=lambda quick: run(Sizes.quick() if quick else Sizes.full(), quick=quick),
    )


if __name__ == "__main__":
    main()
