"""The interactive benchmark keeps the benchmark contract; its cold start parses the
progress line of frame 1."""

from benchmarks import interactive

from benchmark_contract import quick_figures

REQUIRED = ("fire_1m_frame_ms", "fire_1m_step_ms", "fire_1m_draw_ms")


def test_quick_run_reports_the_frame_and_leaves_the_cold_start_unmeasured(capsys):
    figures = quick_figures(interactive, capsys, REQUIRED)
    assert figures["sizes"]["live"] == 20_000 and figures["fire_1m_live"] > 15_000
    cold = ("cold_first_frame_s", "cold_start_fire_s", "warm_start_fire_s",
            "cold_first_frame_one_process_s", "cold_start_fire_one_process_s")  # fmt: skip
    for key in cold:
        assert key in figures and figures[key] is None


def test_the_first_frames_progress_line_is_recognised():
    assert interactive.FIRST_FRAME.search("fire [###.....] 1/240    2.7 fps       ? s left")
    assert not interactive.FIRST_FRAME.search("fire [########] 11/240   5.1 fps   40 s left")
    assert not interactive.FIRST_FRAME.search("fire: first frame (kernels compile ...)")
