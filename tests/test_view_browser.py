"""``motes view`` in a real browser: headless Chromium shows the fire, and Ctrl-C stops it.

The viewer runs as ``motes view fire`` in a subprocess; Chromium (software WebGL) opens
its page, driven over the DevTools protocol (:mod:`benchmarks.browser`). Skipped
without a ``chromium`` binary (Debian: ``apt-get install chromium``) or without viser.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import pytest

pytest.importorskip("viser")

from benchmarks.browser import (
    DevTools,
    HeadlessChromium,
    ViewerProcess,
    find_chromium,
    open_viewer,
    pixels,
    screenshot,
    wait_for_drawing,
    wait_for_status,
)

CHROMIUM = find_chromium()
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="no chromium binary on PATH")

#: The page's 3D view is drawn over a flat clear colour (viser's dark theme).
BACKGROUND = np.array([20, 20, 20])
#: Columns of the 1280 px wide view between the software-rendering notice (top left, to
#: x = 311) and the panel (right, from x = 881): only the scene is drawn there.
SCENE_COLUMNS = slice(384, 845)


@dataclass(frozen=True)
class Visit:
    """What a browser saw of ``motes view fire``, and how the viewer ended."""

    status: dict  #: the panel's status before the screenshots
    image: np.ndarray  #: (720, 1280, 3) uint8: the last screenshot taken
    console: list[str]  #: the page's and its worker's console lines
    exit_status: int | None  #: the viewer's, after SIGINT
    viewer_log: str


def drawn_share(image: np.ndarray) -> float:
    """Share of the scene's columns that differ from the background by more than 8 of
    255 in a channel (the flame's particles are opaque discs, many of them near black)."""
    scene = image[:, SCENE_COLUMNS].astype(np.int16)
    return float(np.mean(np.abs(scene - BACKGROUND).max(axis=-1) > 8))


def fire_share(image: np.ndarray) -> float:
    """Share of the scene's columns in red to orange: red well above green and blue."""
    r, g, b = (image[:, SCENE_COLUMNS, k].astype(np.int16) for k in range(3))
    return float(np.mean((r >= 60) & (r - g >= 25) & (r - b >= 30)))


def shows_the_fire(image: np.ndarray) -> bool:
    # When drawn, the flame covers 30 to 50% of these columns and its red and orange
    # discs 8 to 20%; a blank or not yet faded-in canvas has none of either.
    return drawn_share(image) > 0.1 and fire_share(image) > 0.02


@pytest.fixture(scope="module")
def visit(tmp_path_factory) -> Visit:
    """Open the fire in Chromium, screenshot until it shows, then Ctrl-C the viewer
    while the page is still connected. Everything stops, pass or fail."""
    log_dir = tmp_path_factory.mktemp("view")
    # Left in reverse order: the viewer gets SIGINT while Chromium still shows its page.
    with (
        HeadlessChromium(CHROMIUM) as chrome,
        ViewerProcess("fire", log_dir=log_dir) as viewer,
        DevTools(chrome.page_socket) as page,
    ):
        open_viewer(page, viewer.url)
        # 20 frames (0.67 s): the flame has risen and holds thousands of particles.
        status = wait_for_status(page, lambda s: s["frame"] >= 20, timeout=60,
                                 what="the viewer's frames in the page")  # fmt: skip
        image = _screenshot_until(page, shows_the_fire, timeout=30)
        console = list(page.console)
    return Visit(status, image, console, viewer.exit_status, viewer.log(lines=300))


def _screenshot_until(page: DevTools, done, *, timeout: float) -> np.ndarray:
    """Screenshots of freshly drawn frames until ``done(image)``; the last one after
    ``timeout`` [s] (the page fades in after connecting; each software-rendered
    screenshot takes a second or more)."""
    deadline = time.monotonic() + timeout
    while True:
        wait_for_drawing(page)
        image = pixels(screenshot(page))
        if done(image) or time.monotonic() > deadline:
            return image


def test_the_page_shows_the_live_status(visit):
    assert visit.status["frame"] >= 20
    # 14,000 births a second living 0.5 to 1.2 s: thousands after 20 frames.
    assert visit.status["particles"] > 2_000
    assert visit.status["simulated_fps"] > 0


def test_the_view_shows_the_flame(visit):
    assert visit.image.shape == (720, 1280, 3)
    drawn, fire = drawn_share(visit.image), fire_share(visit.image)
    assert shows_the_fire(visit.image), f"drawn {drawn:.1%}, fire-coloured {fire:.1%}"


def test_the_page_logs_no_errors(visit):
    errors = [line for line in visit.console if line.startswith(("error:", "exception:"))]
    assert errors == []


def test_ctrl_c_stops_the_viewer_with_status_0(visit):
    assert visit.exit_status == 0, visit.viewer_log
    assert "motes view: stopped" in visit.viewer_log
