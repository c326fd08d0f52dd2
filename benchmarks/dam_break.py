"""Dam break against Martin & Moyce (1952): the surge front of a collapsing column.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.dam_break           # 20 particles across, ~5 s
    PYTHONPATH=src python -m benchmarks.dam_break --quick   # 10 across, seconds

A water column of width a = 0.05715 m and height 2a (the experiment's) stands at the
back wall of a tank 6a long, held by a gate (a wall at x = a) while it settles for
0.1 s. The gate is removed at t = 0 and the front position z is recorded: the water's
leading edge along the floor, where the kernel-smoothed volume fraction falls to the
level a resting block has at its own edge (:func:`surge_front`; the furthest particle
is reported too, but it is a drop thrown ahead of the surge more often than not). The
flow is two-dimensional: a slab four particles thick between frictionless walls in z (a
thin 3D slab, the same solver as every 3D scene: the z walls stand for the symmetry
planes of a wide channel). The floor is no-slip (the particles touching it lose their
tangential velocity each step); the end walls slip. docs/fluids.md ("The dam break,
examined") has the figures at 10 to 40 particles across and what they show.

It prints the table of Z = z/a against T = t sqrt(2g/a) beside the experiment (linear
interpolation of the simulated front at the experiment's times), then one line of JSON:
``max_rel_dev`` (largest |Z_sim - Z_exp| / Z_exp from T = 0.8 on), ``mean_rel_dev``
(over all points), ``mean_density_error`` (the solver's mean relative compression
``mean(max(ρ/ρ₀ - 1, 0))``, averaged over the steps after the gate opens), and the same
deviations of the furthest particle plus half a spacing (``*_furthest``).
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from motes.fluids import Fluid, FluidModel, Plane, lattice
from motes.fluids.sph import POLY6

from ._common import benchmark_main, machine, table

DATA = Path(__file__).parent / "data" / "martin_moyce_1952_surge_front.csv"
A = 0.05715  # column width [m]
G = 9.81
SETTLE = 0.1  # [s] with the gate closed
T_FROM = 0.8  # deviations are judged from here on (the experiment's early times are
# slowed by the release of the column, which the simulation does not model)


def experiment() -> tuple[np.ndarray, np.ndarray]:
    """Martin & Moyce's (T, Z) pairs."""
    data = np.loadtxt(DATA, delimiter=",", comments="#", skiprows=4)
    return data[:, 0], data[:, 1]


def volume_fraction(positions, samples, h: float, delta0: float) -> np.ndarray:
    """Kernel-smoothed volume fraction ``c = Σ_j W_poly6(x - x_j) / δ₀`` [-] at ``samples``
    (3, m), the particles (3, n) mirrored in the floor y = 0 (a wall the water lies on
    holds no water, so its image stands for the fluid's continuation, not the solver's
    wall share, which counts the wall as water wherever it is)."""
    # scipy's serial tree rather than the parallel grid: a measurement between steps of a
    # few thousand points, where thread start-up on a busy machine would dominate.
    band = positions[:, positions[1] < samples[1].max() + h]  # the rest cannot reach
    near = band[:, band[1] < h]
    mirrored = np.concatenate([band, near * np.array([[1], [-1], [1]], np.float32)], 1)
    pairs = cKDTree(samples.T.astype(np.float64)).sparse_distance_matrix(
        cKDTree(mirrored.T.astype(np.float64)), h, output_type="coo_matrix"
    )
    w = POLY6 / h**9 * np.maximum(h * h - pairs.data**2, 0.0) ** 3
    return np.bincount(pairs.row, weights=w, minlength=samples.shape[1]) / delta0


def surge_front(positions, spacing: float, h: float, delta0: float, level: float, mid: float):
    """The water's leading edge along the floor [m]: the largest x at which the volume
    fraction :func:`volume_fraction`, on the slab's mid-plane z = ``mid`` at heights
    within a kernel radius of the floor, is at least ``level`` (linear interpolation
    between samples an eighth of a spacing apart). One particle alone reaches 0.19 of
    rest, so a lone drop thrown ahead does not count; a layer of water does."""
    xs = np.arange(0.0, positions[0].max() + h, spacing / 8)
    ys = np.arange(1, 5) * spacing / 2
    grid_x, grid_y = np.meshgrid(xs, ys, indexing="ij")
    samples = np.stack([grid_x.ravel(), grid_y.ravel(), np.full(grid_x.size, mid)])
    c = volume_fraction(positions, samples.astype(np.float32), h, delta0).reshape(grid_x.shape)
    front = 0.0
    for column in c.T:  # one height at a time
        inside = np.flatnonzero(column >= level)
        if inside.size == 0:
            continue
        k = inside[-1]
        x = xs[k]
        if k + 1 < xs.size:  # the crossing between sample k (>= level) and k + 1 (<)
            x += (column[k] - level) / (column[k] - column[k + 1]) * (xs[k + 1] - xs[k])
        front = max(front, x)
    return front


def edge_level(spacing: float, h: float, delta0: float, layers: int) -> float:
    """The volume fraction at the edge of a resting block (the lattice ``lattice`` makes,
    its edge half a spacing beyond its last particles): the level :func:`surge_front`
    looks for, so that the front of the column at rest reads exactly its width. It is
    0.49 at ``h`` = 2 spacings rather than the continuum's 1/2 (the kernel sum over the
    lattice's planes)."""
    block = lattice((0, 0, 0), (A, 2 * A, layers * spacing), spacing)
    at = np.array([[A], [A], [layers * spacing / 2]], np.float32)
    return float(volume_fraction(block, at, h, delta0)[0])


def run(resolution: int = 20, *, quick: bool = False, iterations: int = 4) -> dict:
    """Simulate the collapse with ``resolution`` particles across the column."""
    s = A / resolution
    layers = 4
    walls = (
        # Water does not slip on the floor: the layer touching it loses its tangential
        # velocity each step ("scale" friction of 1).
        Plane((0, 1, 0), (0, 0, 0), friction=1.0),
        Plane((1, 0, 0), (0, 0, 0)),
        Plane((-1, 0, 0), (6 * A, 0, 0)),
        Plane((0, 0, 1), (0, 0, 0)),
        Plane((0, 0, -1), (0, 0, layers * s)),
    )
    gate = Plane((-1, 0, 0), (A, 0, 0))
    # Steps of 0.3 spacings at the largest speed sqrt(2 g 2a) of the collapse.
    dt = 0.3 * s / np.sqrt(4 * G * A)
    model = FluidModel(
        spacing=s, iterations=iterations, boundaries=(*walls, gate), xsph=0.1, max_dt=dt
    )
    water = Fluid(model, lattice((0, 0, 0), (A, 2 * A, layers * s), s))
    for _ in range(round(SETTLE / dt)):
        water.step(dt)
    water.model = dataclasses.replace(model, boundaries=walls, xsph=0.01)
    water.time = 0.0
    t_exp, z_exp = experiment()
    scale = np.sqrt(2 * G / A)
    h, delta0 = model.derived["h"], model.derived["delta0"]
    level = edge_level(s, h, delta0, layers)

    def fronts():
        edge = surge_front(water.positions, s, h, delta0, level, layers * s / 2)
        return edge / A, (water.positions[0].max() + s / 2) / A

    times, edges, errors, seconds = [0.0], [fronts()], [], 0.0
    while times[-1] < t_exp[-1] + 0.05:
        start = time.perf_counter()
        water.step(dt)
        seconds += time.perf_counter() - start
        times.append(water.time * scale)
        edges.append(fronts())
        errors.append(water.density_error)
    edges = np.array(edges)
    z_sim = np.interp(t_exp, times, edges[:, 0])
    rel = np.abs(z_sim - z_exp) / z_exp
    furthest = np.abs(np.interp(t_exp, times, edges[:, 1]) - z_exp) / z_exp
    late = t_exp >= T_FROM
    return {
        "max_rel_dev": float(rel[late].max()),
        "mean_rel_dev": float(rel.mean()),
        "max_rel_dev_all": float(rel.max()),
        "max_rel_dev_furthest": float(furthest[late].max()),
        "mean_rel_dev_furthest": float(furthest.mean()),
        "front_at_release": float(edges[0, 0]),
        "mean_density_error": float(np.mean(errors)),
        "max_density_error": float(np.max(errors)),
        "particles": len(water),
        "resolution": resolution,
        "iterations": iterations,
        "dt_s": float(dt),
        "steps": len(errors),
        "simulation_seconds": seconds,
        "quick": quick,
        "table": {"T": t_exp.tolist(), "Z_exp": z_exp.tolist(), "Z_sim": z_sim.tolist()},
    }


def measure(quick: bool) -> dict:
    result = run(10 if quick else 20, quick=quick)
    tab = result.pop("table")
    rows = [
        (f"T = {t:4.2f}", f"Z exp {ze:4.2f}  sim {zs:4.2f}  ({(zs - ze) / ze:+.1%})")
        for t, ze, zs in zip(tab["T"], tab["Z_exp"], tab["Z_sim"], strict=True)
    ]
    print(
        table(rows, title=f"Dam break, {result['particles']} particles (a/{result['resolution']})")
    )
    print(
        f"  max |dev| from T = {T_FROM}: {result['max_rel_dev']:.1%}, "
        f"mean {result['mean_rel_dev']:.1%}; "
        f"mean density error {result['mean_density_error']:.3%}"
    )
    result.update(machine())
    return result


def main(argv=None) -> dict:
    return benchmark_main(
        argv, prog="python -m benchmarks.dam_break", doc=__doc__,
        quick_help="10 particles across the column", run=measure,
    )  # fmt: skip


if __name__ == "__main__":
    main()
