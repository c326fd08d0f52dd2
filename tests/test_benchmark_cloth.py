"""The cloth benchmark's JSON contract (no timing asserts)."""

import json
import math

from benchmarks import cloth

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
    returned = cloth.main(["--quick"])
    lines = capsys.readouterr().out.rstrip("\n").split("\n")
    figures = json.loads(lines[-1])
    assert figures["quick"] is True
    for key in REQUIRED:
        assert isinstance(figures[key], float), key
        assert math.isfinite(figures[key]) and figures[key] > 0, (key, figures[key])
    assert figures == json.loads(json.dumps(returned, sort_keys=True))
    assert sum(line.startswith("{") for line in lines) == 1
