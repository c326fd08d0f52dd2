"""Cloth benchmark: implicit Euler (Baraff & Witkin 1998) against explicit steps.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.cloth           # full sizes, 1-2 min on 2 cores
    PYTHONPATH=src python -m benchmarks.cloth --quick   # shrunk sizes, seconds

The cloth is the one of the stability test (tests/test_cloth_validation.py): a square
metre of 0.2 kg/m² cloth, structural/shear/bending springs 200/50/5 N/m, held by its top
corners, falling from rest. Figures, all measured in the same run:

- **implicit**: milliseconds per step of the 64×64 and 128×128 cloths at h = 1/60 s
  (mean over a run of steps from rest, best of several runs), their ratio (the particle
  count grows 4×; target <= 4.5), and simulated seconds per wall-clock second (target
  >= 3), with the multigrid preconditioner (the default) and, as the baseline measured
  in the same run, block Jacobi;
- **explicit**: the largest step at which explicit Euler (and, beside it, symplectic
  semi-implicit Euler) stays stable over a fixed simulated time, found by bisection on
  log h, the cost of its step, and simulated seconds per wall-clock second;
- **speed-up**: implicit simulated-seconds-per-wall-second over explicit Euler's (the
  target is >= 5×), and over semi-implicit Euler's;
- **hair**: milliseconds per step of 2,000 strands of 10 particles on a turning head at
  h = 1/60 s (the ``hair`` scene's strands, twice as many), with both preconditioners.

"Stable" means: after the simulated time, every value is finite, no particle moves faster
than 20 m/s and no structural spring is stretched past 100 %. Longer windows can only
lower the explicit limit (slowly growing modes show later), so the explicit figures are
generous to the explicit schemes.
"""

from __future__ import annotations

import datetime
import math
import statistics
import time
from dataclasses import dataclass

import numpy as np

from motes.cloth import Cloth, Keyframes
from motes.hair import Hair, Head
from motes.integrate.implicit import ImplicitEuler

from ._common import benchmark_main, machine, table

H = 1 / 60


@dataclass(frozen=True)
class Sizes:
    small: int  #: grid side of the headline cloth (64)
    large: int  #: grid side of the scaling cloth (128)
    steps: int  #: implicit steps per timed run
    runs: int  #: timed runs (best is reported)
    window: float  #: simulated seconds an explicit run must survive
    bisections: int
    explicit_steps: int  #: explicit steps timed for the cost per step
    strands: int  #: hair strands

    @classmethod
    def full(cls) -> Sizes:
        return cls(64, 128, 60, 3, 0.25, 7, 300, 2000)

    @classmethod
    def quick(cls) -> Sizes:
        return cls(16, 32, 10, 1, 0.1, 3, 30, 200)


def cloth(side: int, scheme: str = "implicit_euler", preconditioner: str = "multigrid") -> Cloth:
    """The benchmark cloth: ``side`` × ``side`` particles on 1 m², top corners pinned,
    solved to the cloth's default tolerance with ``preconditioner``."""
    solver = ImplicitEuler(tolerance=1e-2, preconditioner=preconditioner)
    c = Cloth.grid(
        side, side, size=(1.0, 1.0), origin=(-0.5, 1.0, 0.0), scheme=scheme, solver=solver
    )
    c.pin(c.grid_index(0, [0, -1]))
    return c


def time_implicit(side: int, sizes: Sizes, preconditioner: str = "multigrid") -> dict:
    """Mean wall time per implicit step over runs of ``sizes.steps`` steps from rest."""
    warm = cloth(side, preconditioner=preconditioner)
    warm.step(H)  # loads the compiled kernels
    means, iterations = [], []
    for _ in range(sizes.runs):
        c = cloth(side, preconditioner=preconditioner)
        start = time.perf_counter()
        for _ in range(sizes.steps):
            c.step(H)
            iterations.append(c.last_report.iterations)
        means.append((time.perf_counter() - start) / sizes.steps)
    return {
        "ms": 1e3 * min(means),
        "median_ms": 1e3 * statistics.median(means),
        "iterations": float(np.mean(iterations)),
    }


def stable(side: int, scheme: str, h: float, window: float) -> bool:
    """Whether ``scheme`` survives ``window`` simulated seconds at step ``h``."""
    c = cloth(side, scheme)
    steps = max(1, round(window / h))
    with np.errstate(all="ignore"):
        for k in range(steps):
            c.step(h)
            if k % 200 == 0 and (c.diverged or np.abs(c.velocity).max() > 20.0):
                return False
        speed = np.linalg.norm(c.velocity, axis=0).max()
        return not c.diverged and speed <= 20.0 and c.stretch().max() <= 1.0


def largest_stable_step(side: int, scheme: str, sizes: Sizes) -> float:
    """Bisection on log h between a stable 1e-5 s and an unstable 1/30 s."""
    low, high = 1e-5, 1 / 30
    if not stable(side, scheme, low, sizes.window):
        raise RuntimeError(f"{scheme} is unstable even at h = {low} s")
    for _ in range(sizes.bisections):
        mid = math.sqrt(low * high)
        if stable(side, scheme, mid, sizes.window):
            low = mid
        else:
            high = mid
    return low


def time_explicit(side: int, scheme: str, h: float, sizes: Sizes) -> float:
    """Wall seconds per explicit step at ``h``."""
    c = cloth(side, scheme)
    c.step(h)
    start = time.perf_counter()
    for _ in range(sizes.explicit_steps):
        c.step(h)
    return (time.perf_counter() - start) / sizes.explicit_steps


def time_hair(sizes: Sizes, preconditioner: str = "multigrid") -> dict:
    """Mean wall time per step of ``sizes.strands`` strands on a turning, nodding head."""
    turn = Keyframes([0.0, 0.5, 1.0], [[0, 0, 0], [60, 0, 0], [0, 25, 0]])
    means, iterations = [], []
    for _ in range(sizes.runs + 1):  # the first run loads the kernels
        hair = Hair(
            Head((0.0, 1.6, 0.0), 0.1, rotation=turn),
            strands=sizes.strands,
            particles=10,
            seed=1,
            solver=ImplicitEuler(preconditioner=preconditioner),
        )
        start = time.perf_counter()
        for _ in range(sizes.steps):
            hair.step(H)
            iterations.append(hair.last_report.iterations)
        means.append((time.perf_counter() - start) / sizes.steps)
    return {
        "ms": 1e3 * min(means[1:]),
        "particles": hair.n,
        "iterations": float(np.mean(iterations)),
    }


def run(sizes: Sizes, *, quick: bool, out=print) -> dict:
    """Measure, print the tables and return the figures."""
    info = machine()
    figures: dict = {
        "date": datetime.date.today().isoformat(),
        "quick": quick,
        "sizes": {"small": sizes.small, "large": sizes.large},
        "cpu_count": info["cpu_count"],
        "numba_threads": info["numba_threads"],
        "background_busy_cores": info["background_busy_cores"],
    }
    out(
        table(
            [
                ("machine", f"{info['usable_cores']} usable cores, {info['processor']}"),
                ("other load", f"{info['background_busy_cores']:.2f} cores busy at the start"),
                ("cloth", "1 m², 0.2 kg/m², springs 200/50/5 N/m, top corners pinned"),
            ],
            title="motes cloth benchmark" + (" (--quick sizes)" if quick else ""),
        )
    )
    small = time_implicit(sizes.small, sizes)
    large = time_implicit(sizes.large, sizes)
    small_jacobi = time_implicit(sizes.small, sizes, "jacobi")
    large_jacobi = time_implicit(sizes.large, sizes, "jacobi")
    realtime = H / (small["ms"] * 1e-3)
    figures |= {
        "implicit_64_ms": small["ms"],
        "implicit_64_median_ms": small["median_ms"],
        "implicit_64_iterations": small["iterations"],
        "implicit_128_ms": large["ms"],
        "implicit_128_median_ms": large["median_ms"],
        "implicit_128_iterations": large["iterations"],
        "implicit_128_over_64": large["ms"] / small["ms"],
        "implicit_64_realtime_factor": realtime,
        "jacobi_64_ms": small_jacobi["ms"],
        "jacobi_64_iterations": small_jacobi["iterations"],
        "jacobi_128_ms": large_jacobi["ms"],
        "jacobi_128_iterations": large_jacobi["iterations"],
        "jacobi_128_over_64": large_jacobi["ms"] / small_jacobi["ms"],
        "multigrid_speedup_64": small_jacobi["ms"] / small["ms"],
        "multigrid_speedup_128": large_jacobi["ms"] / large["ms"],
    }
    rows = []
    for name, result in (("multigrid", (small, large)), ("jacobi", (small_jacobi, large_jacobi))):
        for side, r in zip((sizes.small, sizes.large), result, strict=True):
            rows.append(
                (
                    f"{side}×{side} {name}",
                    f"{r['ms']:8.2f} ms/step (median {r['median_ms']:.2f}), "
                    f"{r['iterations']:.1f} CG iterations",
                )
            )
        rows.append(("  ratio", f"{result[1]['ms'] / result[0]['ms']:8.2f}x for 4x the particles"))
    out()
    out(
        table(
            [
                *rows,
                ("real time", f"{realtime:8.2f} simulated s per wall s at h = 1/60 s (target > 3)"),
                (
                    "multigrid",
                    f"{figures['multigrid_speedup_64']:8.2f}x and "
                    f"{figures['multigrid_speedup_128']:.2f}x faster than block Jacobi",
                ),
            ],
            title="1. Implicit Euler at h = 1/60 s",
        )
    )
    rows = []
    for scheme, key in (("explicit_euler", "explicit"), ("semi_implicit_euler", "semi_implicit")):
        h = largest_stable_step(sizes.small, scheme, sizes)
        cost = time_explicit(sizes.small, scheme, h, sizes)
        factor = h / cost
        figures |= {
            f"{key}_64_largest_stable_step": h,
            f"{key}_64_ms": 1e3 * cost,
            f"{key}_64_realtime_factor": factor,
        }
        rows += [
            (
                scheme,
                f"largest stable step {h:.3g} s ({1 / h:,.0f} steps per s), "
                f"{1e3 * cost:.3f} ms/step",
            ),
            (
                "",
                f"{factor:.4f} simulated s per wall s; implicit is {realtime / factor:.1f}x faster",
            ),
        ]
    figures["implicit_vs_explicit_speedup"] = realtime / figures["explicit_64_realtime_factor"]
    figures["implicit_vs_semi_implicit_speedup"] = (
        realtime / figures["semi_implicit_64_realtime_factor"]
    )
    out()
    out(
        table(
            rows,
            title=f"2. Explicit steps on the {sizes.small}×{sizes.small} cloth "
            f"(stable over {sizes.window} s)",
        )
    )
    hair = time_hair(sizes)
    hair_jacobi = time_hair(sizes, "jacobi")
    figures |= {
        "hair_2000_ms": hair["ms"],
        "hair_2000_iterations": hair["iterations"],
        "hair_2000_realtime_factor": H / (hair["ms"] * 1e-3),
        "hair_2000_jacobi_ms": hair_jacobi["ms"],
        "hair_2000_jacobi_iterations": hair_jacobi["iterations"],
    }
    out()
    out(
        table(
            [
                ("strands", f"{sizes.strands:,} × 10 particles ({hair['particles']:,})"),
                (
                    "step",
                    f"{hair['ms']:8.2f} ms at h = 1/60 s, {hair['iterations']:.1f} CG "
                    f"iterations: {1e3 / hair['ms']:.0f} steps per s",
                ),
                (
                    "block Jacobi",
                    f"{hair_jacobi['ms']:8.2f} ms, {hair_jacobi['iterations']:.1f} CG iterations",
                ),
            ],
            title="3. Hair on a turning head",
        )
    )
    return figures


def main(argv: list[str] | None = None) -> dict:
    return benchmark_main(
        argv,
        prog="python -m benchmarks.cloth",
        doc=__doc__,
        quick_help="16×16 and 32×32 cloths, short windows",
        run=lambda quick: run(Sizes.quick() if quick else Sizes.full(), quick=quick),
    )


if __name__ == "__main__":
    main()
