"""The fluid and dam-break benchmarks: their JSON contracts in quick mode (no timing asserts)."""

import json
import math

from benchmarks import dam_break, fluid


def last_json(capsys):
    lines = capsys.readouterr().out.rstrip("\n").split("\n")
    assert sum(line.startswith("{") for line in lines) == 1
    return json.loads(lines[-1])


def test_fluid_quick_run_reports_positive_finite_figures(capsys):
    returned = fluid.main(["--quick"])
    figures = last_json(capsys)
    assert figures["quick"] is True
    for key in ("neighbors_65k_ms", "neighbors_speedup_vs_ckdtree", "step_100k_ms"):
        assert isinstance(figures[key], float) and math.isfinite(figures[key]) and figures[key] > 0
    assert 30 < figures["mean_neighbors"] < 45
    assert figures == json.loads(json.dumps(returned, sort_keys=True))


def test_dam_break_quick_run_reports_deviations(capsys):
    dam_break.main(["--quick"])
    figures = last_json(capsys)
    for key in ("max_rel_dev", "mean_rel_dev", "mean_density_error"):
        assert isinstance(figures[key], float) and 0 <= figures[key] < 1
    assert figures["resolution"] == 10 and figures["steps"] > 100
