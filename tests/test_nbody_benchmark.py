"""The n-body benchmark: its JSON contract (slow tier: pytreegrav compiles for half a
minute) and that its float64 reference is the direct sum it claims (no timing asserts)."""

import numpy as np
import pytest
from benchmarks import nbody
from numpy.testing import assert_allclose

import naive_nbody as naive
from benchmark_contract import quick_figures

REQUIRED = (
    "direct_gpairs_per_s",
    "barnes_hut_1m_s",
    "barnes_hut_rms_error",
    "knn_clustered_speedup_vs_ckdtree",
)


@pytest.mark.slow
def test_quick_run_ends_with_one_json_line_of_positive_finite_figures(capsys):
    figures = quick_figures(nbody, capsys, REQUIRED)
    assert figures["quick"] is True
    assert figures["barnes_hut_rms_error"] < 5e-3


def test_reference_field_is_the_direct_sum():
    position, mass = nbody.sphere(500, seed=4)
    targets = np.array([0, 7, 499])
    expected = naive.inverse_square(position, mass, 0.01)[:, targets]
    # float64 sums of 500 terms in a different order: a few ulps of the largest.
    assert_allclose(nbody.reference_at(position, mass, targets, 0.01), expected, rtol=1e-12)


def test_errors_are_relative_per_particle():
    reference = np.array([[1.0, 0.0], [0.0, 2.0], [0.0, 0.0]])
    rms, worst = nbody.errors(reference * np.array([1.01, 0.98]), reference)
    assert_allclose([rms, worst], [np.sqrt((0.01**2 + 0.02**2) / 2), 0.02])
