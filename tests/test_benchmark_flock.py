"""The flock benchmark's JSON contract (no timing asserts; its NumPy baseline is checked
against the flock's step in tests/test_flock.py)."""

import pytest
from benchmarks import flock

from benchmark_contract import quick_figures

REQUIRED = ("flock_1m_ms", "flock_100k_ms", "flock_numpy_100k_ms", "flock_speedup_vs_numpy")


@pytest.mark.slow  # about 20 s: 100,000 and 20,000 boids, and the NumPy step
def test_quick_run_ends_with_one_json_line_of_positive_finite_figures(capsys):
    figures = quick_figures(flock, capsys, REQUIRED)
    assert figures["quick"] is True and figures["numba_threads"] >= 1
