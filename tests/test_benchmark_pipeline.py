"""The export benchmark's JSON contract (no timing asserts)."""

import pytest
from benchmarks import pipeline

from benchmark_contract import quick_figures


def test_quick_run_ends_with_one_json_line_of_positive_finite_figures(capsys):
    for module in ("pxr", "vtkmodules", "plyfile"):
        pytest.importorskip(module)
    required = ["npz_cache_mpoints_per_s", *(f for f in pipeline.FORMATS if "export" in f)]
    figures = quick_figures(pipeline, capsys, required)
    assert figures["quick"] is True and figures["skipped"] == []
    assert figures["points"] == 20_000 and figures["frames"] == 3
    assert figures["usd_vs_npz"] > 0
    assert figures["cache_compression_ratio_lossy"] > figures["cache_compression_ratio"] > 1
    assert figures["dask_render_efficiency"] > 0 and figures["dask_render_workers"] == 2
