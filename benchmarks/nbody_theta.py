"""Barnes–Hut accuracy and time against the opening angle θ, on a Plummer sphere.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.nbody_theta           # 1,000,000 points
    PYTHONPATH=src python -m benchmarks.nbody_theta --quick   # 50,000 points

For θ = 0.3, 0.4, ... 1.0, with monopoles and with quadrupoles: one float32 evaluation
of gravity (no softening) on a Plummer sphere (G = M = a = 1), its time (best of two
after a warm-up), and its error against float64 direct summation at 1,000 random
particles: RMS and maximum of ``|a - a_direct| / |a_direct|``. Prints the Markdown
table of ``docs/nbody.md``, then the JSON figures.
"""

from __future__ import annotations

import numpy as np

from ._common import benchmark_main, machine, time_calls
from .nbody import SAMPLE, barnes_hut, errors, reference_at, sphere

THETAS = (0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)


def measure(quick: bool) -> dict:
    n = 50_000 if quick else 1_000_000
    position, mass = sphere(n, seed=1)
    p32 = position.astype(np.float32)
    targets = np.sort(np.random.default_rng(2).choice(n, SAMPLE, replace=False))
    reference = reference_at(position, mass, targets)
    rows = []
    for theta in THETAS:
        row = {"theta": theta}
        for quadrupole in (False, True):
            timing = time_calls(
                lambda t=theta, q=quadrupole: barnes_hut(p32, mass, t, quadrupole=q), repeat=2
            )
            field = barnes_hut(p32, mass, theta, quadrupole=quadrupole)[:, targets]
            rms, worst = errors(field.astype(np.float64), reference)
            key = "quadrupole" if quadrupole else "monopole"
            row[key] = {"rms": rms, "max": worst, "seconds": timing.best}
        rows.append(row)
    lines = [
        f"Plummer sphere, {n:,} particles, float32, no softening",
        "",
        "| θ | RMS error | max error | time [s] | RMS error (quadrupole) "
        "| max error (quadrupole) | time [s] (quadrupole) |",
        "|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        m, q = row["monopole"], row["quadrupole"]
        lines.append(
            f"| {row['theta']:.1f} | {m['rms']:.1e} | {m['max']:.1e} | {m['seconds']:.2f} "
            f"| {q['rms']:.1e} | {q['max']:.1e} | {q['seconds']:.2f} |"
        )
    print("\n".join(lines))
    figures = {"particles": n, "rows": rows, "quick": quick}
    figures.update(machine())
    return figures


def main(argv=None) -> dict:
    return benchmark_main(
        argv, prog="python -m benchmarks.nbody_theta", doc=__doc__,
        quick_help="50,000 points", run=measure,
    )  # fmt: skip


if __name__ == "__main__":
    main()
