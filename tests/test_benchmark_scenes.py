"""The scenes benchmark keeps the benchmark contract (slow tier: it simulates scenes)."""

import pytest
from benchmarks import scenes

from benchmark_contract import quick_figures


@pytest.mark.slow
def test_quick_run_times_each_quick_scene_at_its_size(capsys):
    figures = quick_figures(scenes, capsys)
    assert set(figures["render_ms"]) == set(scenes.QUICK)
    for name in scenes.QUICK:
        assert figures["render_ms"][name] > 0
        assert figures["render_median_ms"][name] >= figures["render_ms"][name]
        assert figures["resolution"][name] == [320, 180]


def test_every_builtin_scene_is_listed():
    names = scenes.builtin_names()
    assert {"fire", "dam_break", "waterfall", "ragdoll_stairs"} <= set(names)
    assert len(names) == len(set(names)) >= 30
