"""Grid fluids: one smoke step at 512² and at 128³ (pressure solved to tolerance), the
same 2D step against a NumPy and SciPy version of it at 128², and a 128³ volume drawn
with shadows at 1280x720.

Run ``python -m benchmarks.grid`` (``--quick``: smaller grids). The smoke: a hot,
dense ball at the bottom of the domain, buoyancy, vorticity confinement, an open top,
MacCormack advection; timed after it has developed (the pressure solve is warm-started
from the step before, as in a run).
"""

from __future__ import annotations

import motes as mo
from benchmarks._common import benchmark_main, machine, table, time_calls
from benchmarks.grid_numpy import NumpySmoke
from benchmarks.volume_case import volume_render_figures

DT = 1.0 / 30.0


def smoke(n: int, dimensions: int) -> mo.GridFluid:
    """The benchmark's smoke: ``n`` cells a side, 1.5 n tall (2D or 3D), 4 m wide."""
    h = 4.0 / n
    shape = (n, int(1.5 * n)) if dimensions == 2 else (n, int(1.5 * n), n)
    depth = 0.5 * h if dimensions == 2 else 2.0
    fluid = mo.GridFluid(
        shape, h, vorticity=0.5, walls={"+y": "open"},
        buoyancy=mo.Buoyancy(density_weight=0.05, heat_weight=0.01),
    )  # fmt: skip
    fluid.add(mo.GridSource((2.0, 0.6, depth), 0.5, density=3.0, temperature=600.0,
                            velocity=(0.0, 1.0, 0.0), pull=5.0))  # fmt: skip
    return fluid


def developed(fluid: mo.GridFluid, steps: int) -> mo.GridFluid:
    for _ in range(steps):
        fluid.step(DT)
    return fluid


def time_step(fluid: mo.GridFluid, repeat: int) -> float:
    return time_calls(lambda: fluid.step(DT), repeat=repeat, warmup=1).best


def run(quick: bool) -> dict:
    n2, n3, nbase = (128, 48, 64) if quick else (512, 128, 128)
    repeat = 3 if quick else 5
    settle = 10 if quick else 30
    flat = developed(smoke(n2, 2), settle)
    flat_s = time_step(flat, repeat)
    deep = developed(smoke(n3, 3), 5 if quick else 12)
    deep_s = time_step(deep, 2 if quick else 3)
    iterations = deep.last_solve.iterations
    base = developed(smoke(nbase, 2), settle)
    base_s = time_step(base, repeat)
    twin = NumpySmoke(developed(smoke(nbase, 2), settle))
    numpy_s = time_calls(lambda: twin.step(DT), repeat=2 if quick else 3, warmup=1).best
    volume = volume_render_figures(2 if quick else 4) if not quick else {}
    figures = {
        "quick": quick,
        f"grid_2d_{n2}_ms": flat_s * 1e3,
        f"grid_3d_{n3}_ms": deep_s * 1e3,
        f"pressure_iterations_3d_{n3}": iterations,
        f"grid_2d_{nbase}_ms": base_s * 1e3,
        f"grid_numpy_2d_{nbase}_ms": numpy_s * 1e3,
        "grid_speedup_vs_numpy": numpy_s / base_s,
        **volume,
        **machine(),
    }
    rows = [
        (
            f"2D smoke, {n2} x {int(1.5 * n2)}",
            f"{flat_s * 1e3:9.1f} ms per step (target <= 16 at 512)",
        ),
        (
            f"3D smoke, {n3} x {int(1.5 * n3)} x {n3}",
            f"{deep_s * 1e3:9.1f} ms per step (target <= 250 at 128)",
        ),
        ("  pressure iterations", f"{iterations:9d}"),
        (f"2D smoke, {nbase}², motes", f"{base_s * 1e3:9.2f} ms per step"),
        (f"2D smoke, {nbase}², NumPy + SciPy", f"{numpy_s * 1e3:9.1f} ms per step"),
        ("speed-up", f"{numpy_s / base_s:9.1f}x (target >= 20)"),
    ]
    if volume:
        rows.append(("128³ volume, shadows, 1280x720",
                     f"{volume['volume_128_render_ms']:9.1f} ms (target <= 250)"))  # fmt: skip
    print(table(rows, title="Grid fluids: one step, and a volume drawn"))
    return figures


def main(argv: list[str] | None = None) -> dict:
    return benchmark_main(
        argv, prog="python -m benchmarks.grid", doc=__doc__,
        quick_help="128² and 48³ grids, no volume", run=run,
    )  # fmt: skip


if __name__ == "__main__":
    main()
