"""The cloth benchmark's JSON contract (no timing asserts)."""

from benchmarks import cloth

from benchmark_contract import quick_figures

REQUIRED = (
    "implicit_64_ms",
    "implicit_128_ms",
    "implicit_64_realtime_factor",
    "implicit_vs_explicit_speedup",
    "implicit_vs_semi_implicit_speedup",
    "explicit_64_largest_stable_step",
    "hair_2000_ms",
)


def test_quick_run_ends_with_one_json_line_of_positive_finite_figures(capsys):
    figures = quick_figures(cloth, capsys, REQUIRED)
    assert figures["quick"] is True
