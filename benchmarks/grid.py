"""Grid fluids: one smoke step at 512² and at 128³, the same 2D step against a NumPy and
SciPy version of it at 128², and a 128³ volume drawn with shadows at 1280 × 720.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.grid           # full sizes, about 20 s
    PYTHONPATH=src python -m benchmarks.grid --quick   # shrunk sizes, seconds

The smoke (:func:`smoke`): a square (cubic) domain 4 m wide, open at the top; a hot,
dense ball of gas at the bottom pulled upward (a :class:`motes.GridSource`), buoyancy,
vorticity confinement, MacCormack advection, the pressure solved to the default tolerance
(1e-4 of the divergence before projection). Each grid is stepped at 30 steps per second
until the plume is developed (60 steps: it has risen through most of the domain), then
single steps are timed: the best of several (the headline figure; the median beside it).
The pressure solve is warm-started from the step before, as in any run. Figures:

- ``grid_2d_512_ms``, ``grid_3d_128_ms``: one step; ``*_advection_ms``, ``*_forces_ms``,
  ``*_pressure_ms``: its stages (the stage methods of the fluid timed one by one; the
  rest of the step is sources, walls and Python); ``pressure_iterations_*``: the
  conjugate-gradient iterations of the timed steps' solves (the most);
- ``grid_128_ms`` against ``grid_128_numpy_ms``, the same step at 128² written plainly
  in NumPy and SciPy (:mod:`benchmarks.grid_numpy`, ``map_coordinates`` and a pressure
  matrix factorised once by ``splu``), both from the same developed state:
  ``grid_speedup_vs_numpy``. ``tests/test_benchmark_grid.py`` checks that both compute
  the same step;
- ``volume_128_render_ms``, ``volume_128_light_ms``: :mod:`benchmarks.volume_case`.

Grids below 65,536 cells step on one thread (``SERIAL_BELOW`` in
``motes/gridfluid/fluid.py``): the 128² step runs on one core. The cores other
processes kept busy are reported: on a shared machine they inflate the timings.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass

import motes as mo

from ._common import benchmark_main, machine, table
from .grid_numpy import NumpySmoke
from .volume_case import plume_volume, scene_camera, scene_lights, volume_render_figures

DT = 1.0 / 30.0
#: Stages of a step, timed by wrapping these methods of one fluid.
STAGES = {"advection": "_advect", "forces": "_add_forces", "pressure": "project"}


def smoke(n: int, dimensions: int) -> mo.GridFluid:
    """The benchmark's smoke: ``n`` cells a side (a square or a cube 4 m wide), open at
    the top, a hot ball of gas at the bottom pulled upward at 1 m/s."""
    h = 4.0 / n
    depth = 0.5 * h if dimensions == 2 else 2.0
    fluid = mo.GridFluid(
        (n,) * dimensions, h, vorticity=0.5, walls={"+y": "open"},
        buoyancy=mo.Buoyancy(density_weight=0.05, heat_weight=0.01),
    )  # fmt: skip
    fluid.add(mo.GridSource((2.0, 0.6, depth), 0.5, density=3.0, temperature=600.0,
                            velocity=(0.0, 1.0, 0.0), pull=5.0))  # fmt: skip
    return fluid


def developed(fluid: mo.GridFluid, steps: int) -> mo.GridFluid:
    """``fluid`` after ``steps`` steps of :data:`DT`."""
    for _ in range(steps):
        fluid.step(DT)
    return fluid


@dataclass(frozen=True)
class Sizes:
    """Grids, steps to develop the plume, and steps timed."""

    flat: int
    deep: int
    twin: int
    settle: int
    repeat: int
    deep_repeat: int
    volume: tuple | None  # (n, width, height) of a smaller volume case; None: the full one

    @staticmethod
    def full() -> Sizes:
        return Sizes(512, 128, 128, 60, 15, 5, None)

    @staticmethod
    def quick() -> Sizes:
        return Sizes(64, 24, 32, 10, 3, 2, (32, 320, 180))


def time_steps(fluid: mo.GridFluid, repeat: int) -> dict:
    """Wall times [ms] of ``repeat`` steps after one untimed step: the best and median
    step, the median of each stage (the step's stage methods wrapped for the run), and
    the most pressure iterations of the timed steps."""
    fluid.step(DT)
    spent = {name: 0.0 for name in STAGES}
    for name, method in STAGES.items():
        original = getattr(fluid, method)

        def timed(*args, _original=original, _name=name):
            start = time.perf_counter()
            try:
                return _original(*args)
            finally:
                spent[_name] += time.perf_counter() - start

        setattr(fluid, method, timed)
    steps, stages, iterations = [], {name: [] for name in STAGES}, 0
    try:
        for _ in range(repeat):
            for name in spent:
                spent[name] = 0.0
            start = time.perf_counter()
            fluid.step(DT)
            steps.append(time.perf_counter() - start)
            for name, seconds in spent.items():
                stages[name].append(seconds)
            iterations = max(iterations, fluid.last_solve.iterations)
    finally:
        for method in STAGES.values():
            delattr(fluid, method)
    out = {"ms": 1e3 * min(steps), "median_ms": 1e3 * statistics.median(steps)}
    out |= {f"{name}_ms": 1e3 * statistics.median(t) for name, t in stages.items()}
    out["iterations"] = iterations
    return out


def twin_steps(n: int, settle: int, repeat: int) -> dict:
    """The 2D step of motes and of its NumPy twin, both from the same developed state."""
    fluid = developed(smoke(n, 2), settle)
    twin = NumpySmoke(fluid)
    ours = time_steps(fluid, repeat)
    twin.step(DT)
    times = []
    for _ in range(max(3, repeat // 3)):
        start = time.perf_counter()
        twin.step(DT)
        times.append(time.perf_counter() - start)
    return {"motes": ours, "numpy_ms": 1e3 * min(times)}


def small_volume_figures(n: int, width: int, height: int) -> dict:
    """:func:`benchmarks.volume_case.volume_render_figures` on a smaller plume and frame,
    one timed frame (``--quick``)."""
    from motes.render.renderer import Renderer
    from motes.render.shadow_pass import prepare
    from motes.render.volume import light_volume

    volume, camera, lights = plume_volume(n), scene_camera(width, height), scene_lights()
    renderer = Renderer(camera, background=(0.02, 0.02, 0.03), lights=lights)
    renderer.render_hdr([], [volume])
    start = time.perf_counter()
    light_volume(volume, prepare(lights, [], camera))
    light = time.perf_counter() - start
    start = time.perf_counter()
    renderer.render_hdr([], [volume])
    frame = time.perf_counter() - start
    return {"volume_128_render_ms": 1e3 * frame, "volume_128_light_ms": 1e3 * light}


def _stage_rows(step: dict) -> list[tuple[str, str]]:
    rest = step["median_ms"] - sum(step[f"{name}_ms"] for name in STAGES)
    rows = [(f"  {name}", f"{step[f'{name}_ms']:9.2f} ms (median)") for name in STAGES]
    return [*rows, ("  the rest: sources, walls, Python", f"{max(rest, 0.0):9.2f} ms (median)")]


def run(sizes: Sizes, *, quick: bool) -> dict:
    """Measure, print the tables and return the figures."""
    info = machine()
    rows = [
        ("machine", f"{info['usable_cores']} usable cores, {info['numba_threads']} Numba "
                    f"threads, {info['processor']}"),
        ("other load", f"{info['background_busy_cores']:.2f} cores busy with other processes"),
        ("timings", "best of N steps after the plume developed (median in brackets)"),
    ]  # fmt: skip
    print(table(rows, title="motes grid-fluid benchmark" + (" (--quick sizes)" if quick else "")))
    figures: dict = {
        "quick": quick,
        "sizes": {"flat": sizes.flat, "deep": sizes.deep, "twin": sizes.twin},
        "dt": DT,
        "steps_before_timing": sizes.settle,
    }
    for key, n, dims, repeat in (
        ("2d_512", sizes.flat, 2, sizes.repeat),
        ("3d_128", sizes.deep, 3, sizes.deep_repeat),
    ):
        step = time_steps(developed(smoke(n, dims), sizes.settle), repeat)
        figures |= {f"grid_{key}_{name}": value for name, value in step.items()}
        figures[f"pressure_iterations_{key}"] = figures.pop(f"grid_{key}_iterations")
        shape = " x ".join([str(n)] * dims)
        target = "16" if dims == 2 else "250"
        rows = [
            ("grid", f"{shape} cells, {DT * 1e3:.1f} ms steps"),
            ("step", f"{step['ms']:9.2f} ms (median {step['median_ms']:.2f}; target <= "
                     f"{target} ms at full size)"),
            *_stage_rows(step),
            ("pressure iterations", f"{step['iterations']:9d} (the most of the timed steps)"),
        ]  # fmt: skip
        print()
        print(table(rows, title=f"{dims}D smoke"))

    twin = twin_steps(sizes.twin, sizes.settle, sizes.repeat)
    ours = twin["motes"]["ms"]
    figures |= {
        "grid_128_ms": ours,
        "grid_128_numpy_ms": twin["numpy_ms"],
        "grid_speedup_vs_numpy": twin["numpy_ms"] / ours,
    }
    rows = [
        ("grid", f"{sizes.twin} x {sizes.twin} (one thread: below SERIAL_BELOW)"),
        ("motes", f"{ours:9.2f} ms per step"),
        ("NumPy + SciPy", f"{twin['numpy_ms']:9.2f} ms per step"),
        ("", "(map_coordinates, fancy-index clamps, splu factorised once)"),
        ("speed-up", f"{twin['numpy_ms'] / ours:9.1f}x (target >= 20)"),
    ]
    print()
    print(table(rows, title="2D smoke against NumPy and SciPy"))

    volume = small_volume_figures(*sizes.volume) if sizes.volume else volume_render_figures()
    figures |= volume
    rows = [
        ("frame", f"{volume['volume_128_render_ms']:9.1f} ms"),
        ("light volume", f"{volume['volume_128_light_ms']:9.1f} ms"),
    ]
    print()
    print(table(rows, title="Volume: a 128³ plume drawn at 1280 x 720" if not sizes.volume
                else f"Volume (--quick: {sizes.volume[0]}³ at {sizes.volume[1]} x "
                     f"{sizes.volume[2]})"))  # fmt: skip
    return figures | info


def main(argv: list[str] | None = None) -> dict:
    return benchmark_main(
        argv, prog="python -m benchmarks.grid", doc=__doc__,
        quick_help="64², 24³, a 32² twin, a 32³ volume at 320 x 180",
        run=lambda quick: run(Sizes.quick() if quick else Sizes.full(), quick=quick),
    )  # fmt: skip


if __name__ == "__main__":
    main()
