"""The ragdoll benchmark: its JSON contract, and that its NumPy baseline does the same work."""

import json
import math

import numpy as np
from benchmarks import ragdoll
from numpy.testing import assert_allclose

REQUIRED = (
    "ragdolls_100_ms",
    "ragdolls_100_1thread_ms",
    "lattice_100k_speedup_vs_numpy",
    "lattice_100k_parallel_speedup_vs_numpy",
    "lattice_100k_1thread_speedup_vs_numpy",
    "lattice_100k_projections_per_s",
)


def test_quick_run_ends_with_one_json_line_of_positive_finite_figures(capsys):
    returned = ragdoll.main(["--quick"])
    lines = capsys.readouterr().out.rstrip("\n").split("\n")
    figures = json.loads(lines[-1])
    assert figures["quick"] is True
    for key in REQUIRED:
        assert isinstance(figures[key], float), key
        assert math.isfinite(figures[key]) and figures[key] > 0, (key, figures[key])
    assert figures["ragdolls_100_particles"] == 15 * figures["sizes"]["ragdolls"]
    assert figures == json.loads(json.dumps(returned, sort_keys=True))
    assert sum(line.startswith("{") for line in lines) == 1


def test_numpy_sweep_computes_what_the_kernel_computes():
    constraints, position, inv_mass = ragdoll.lattice(40)
    ours, theirs = position.copy(), position.copy()
    for _ in range(3):
        constraints.sweep(ours, inv_mass, 1 / 60)
        ragdoll.numpy_sweep(constraints, theirs, inv_mass)
    assert np.abs(ours - position).max() > 1e-4  # it did relax something
    # The same float64 projections in the same order; fastmath reassociation only.
    assert_allclose(ours, theirs, rtol=0, atol=1e-12)
