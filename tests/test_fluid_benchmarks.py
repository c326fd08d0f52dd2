"""The fluid and dam-break benchmarks: their JSON contracts in quick mode (no timing asserts)."""

from benchmarks import dam_break, fluid

from benchmark_contract import quick_figures


def test_fluid_quick_run_reports_positive_finite_figures(capsys):
    required = (
        "neighbors_65k_ms",
        "neighbors_speedup_vs_ckdtree",
        "step_100k_ms",
        "step_100k_1thread_ms",
    )
    figures = quick_figures(fluid, capsys, required)
    assert figures["quick"] is True
    assert 30 < figures["mean_neighbors"] < 45


def test_dam_break_quick_run_reports_deviations(capsys):
    figures = quick_figures(dam_break, capsys)
    for key in ("max_rel_dev", "mean_rel_dev", "mean_density_error"):
        assert isinstance(figures[key], float) and 0 <= figures[key] < 1
    assert figures["resolution"] == 10 and figures["steps"] > 100
