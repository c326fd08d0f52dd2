"""The ragdoll benchmark: its JSON contract, and that its NumPy baseline does the same work."""

import numpy as np
from benchmarks import ragdoll
from numpy.testing import assert_allclose

from benchmark_contract import quick_figures

REQUIRED = (
    "ragdolls_100_ms",
    "ragdolls_100_1thread_ms",
    "lattice_100k_speedup_vs_numpy",
    "lattice_100k_parallel_speedup_vs_numpy",
    "lattice_100k_1thread_speedup_vs_numpy",
    "lattice_100k_projections_per_s",
)


def test_quick_run_ends_with_one_json_line_of_positive_finite_figures(capsys):
    figures = quick_figures(ragdoll, capsys, REQUIRED)
    assert figures["quick"] is True
    assert figures["ragdolls_100_particles"] == 15 * figures["sizes"]["ragdolls"]


def test_numpy_sweep_computes_what_the_kernel_computes():
    constraints, position, inv_mass = ragdoll.lattice(40)
    ours, theirs = position.copy(), position.copy()
    for _ in range(3):
        constraints.sweep(ours, inv_mass, 1 / 60)
        ragdoll.numpy_sweep(constraints, theirs, inv_mass)
    assert np.abs(ours - position).max() > 1e-4  # it did relax something
    # The same float64 projections in the same order; fastmath reassociation only.
    assert_allclose(ours, theirs, rtol=0, atol=1e-12)
