"""The live viewer in a browser: ``motes view fire`` at about a million particles, watched
by headless Chromium with software WebGL.

Run from the repository root (needs viser, ``pip install 'motes[view]'``, and a
``chromium`` binary, e.g. Debian's ``apt-get install chromium``)::

    PYTHONPATH=src python -m benchmarks.view            # ~1,000,000 particles, 2-5 minutes
    PYTHONPATH=src python -m benchmarks.view --quick    # ~100,000, under a minute
    PYTHONPATH=src python -m benchmarks.view --screenshot view.png   # the page at the end

The built-in fire with 850,000 births a second (85,000 with ``--quick``) living 0.8 to
1.6 s holds about 1.02 million particles (102,000) once the first have died; every one
is sent (``--max-points`` at the capacity: no stride). The viewer runs in a subprocess
(its frame rate capped at the scene's 30 fps, as by default), Chromium opens its page
over the DevTools protocol (:mod:`benchmarks.browser`), and once the live count reached
90% of that and a warm-up of :data:`WARMUP` s passed, :data:`WINDOW` s are measured
(longer when the page answers late: its main thread can wait many seconds on a frame;
rates are per second of the page's own clock):

- ``*_browser_fps``: animation frames in which WebGL drew, per second (viser draws on
  demand, so this is the page's drawing rate); ``*_raf_fps``: all animation frames;
- ``*_frames_received_fps`` and ``*_mb_per_s``: websocket messages carrying point
  clouds that reached the page, and their bytes; ``*_point_clouds_created_per_frame``:
  viser ``PointCloudMessage`` s among them (1: the point cloud is made anew each frame
  rather than updated in place);
- ``*_sim_fps``: the panel's "simulated N fps" (one step and its packet, the median of
  samples about once a second, read from the status texts the page received: the text
  the page shows waits for its next animation frame); ``*_frames_advanced_fps``: frames
  the viewer moved on by, per second; ``*_particles``: the panel's live count (median);
- ``*_viewer_cores``, ``*_chromium_cores``: CPU time of the viewer's process and of all
  of Chromium's over the window, per second of wall time (by Chromium process in the
  table).

Keys say ``1m`` (``100k`` with ``--quick``). The machine's other work competes with
the viewer and the browser for the same cores; the closing line counts both of them
among the "other processes".
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from ._common import machine, run_and_report, table
from .browser import (
    DevTools,
    HeadlessChromium,
    ViewerProcess,
    counters,
    cpu_seconds,
    descendants,
    find_chromium,
    open_viewer,
    parse_status,
    process_kind,
    received_status,
    screenshot,
    wait_for_status,
)

#: Seconds measured, and seconds waited before (the page settles its pixel ratio).
WINDOW = 10.0
WARMUP = 3.0
#: Seconds a screenshot may take (a new frame is drawn for it), and any other request to
#: the page (its main thread can wait tens of seconds on a million-point frame).
SCREENSHOT_TIMEOUT = 180.0
PAGE_TIMEOUT = 120.0
#: Mean lifetime of the fire's particles [s]: uniform on [0.8, 1.6].
MEAN_LIFETIME = 1.2


@dataclass(frozen=True)
class Size:
    """Births per second, the system's capacity, and the key's label."""

    rate: int
    capacity: int
    label: str

    @property
    def expected(self) -> int:
        """Live particles once births balance deaths."""
        return round(self.rate * MEAN_LIFETIME)

    def viewer_args(self) -> list[str]:
        return [
            "--set", f"system.flame.capacity={self.capacity}",
            "--set", f"system.flame.emitter.0.rate.rate={self.rate}",
            "--max-points", str(self.capacity),
            "--history", "256",  # MB of frames kept: nothing is scrubbed here
        ]  # fmt: skip


FULL = Size(850_000, 1_300_000, "1m")
QUICK = Size(85_000, 130_000, "100k")


class CpuMeter:
    """CPU time of processes (by label) between construction and :meth:`cores`."""

    def __init__(self, labelled: dict[int, str]):
        self.labelled = labelled
        self._start = {pid: cpu_seconds(pid) for pid in labelled}
        self._wall = time.perf_counter()

    def cores(self) -> dict[str, float]:
        """Cores used on average [CPU s / s] by each label."""
        wall = time.perf_counter() - self._wall
        used: dict[str, float] = {}
        for pid, label in self.labelled.items():
            spent = max(cpu_seconds(pid) - self._start[pid], 0.0)
            used[label] = used.get(label, 0.0) + spent / wall
        return used


def measure(page: DevTools, meter_pids: dict[int, str]) -> dict:
    """Counters, status samples and CPU over :data:`WINDOW` seconds."""
    meter = CpuMeter(meter_pids)
    samples = [counters(page)]
    deadline = time.monotonic() + WINDOW
    while time.monotonic() < deadline:
        time.sleep(1.0)
        samples.append(counters(page))
    cores = meter.cores()
    first, last = samples[0], samples[-1]
    seconds = (last["now"] - first["now"]) / 1e3  # the page's own clock [ms]
    delta = {k: last[k] - first[k] for k in ("animationFrames", "drawnFrames", "frames", "bytes")}
    created = last["types"].get("PointCloudMessage", 0) - first["types"].get("PointCloudMessage", 0)
    # As received, not as shown: the page's text waits for its next animation frame.
    statuses = [parse_status(sample["status"]) for sample in samples]
    return {
        "browser_fps": delta["drawnFrames"] / seconds,
        "browser_frames_drawn": delta["drawnFrames"],
        "raf_fps": delta["animationFrames"] / seconds,
        "frames_received_fps": delta["frames"] / seconds,
        "mb_per_s": delta["bytes"] / seconds / 1e6,
        "mb_per_frame": delta["bytes"] / max(delta["frames"], 1) / 1e6,
        "point_clouds_created_per_frame": created / max(delta["frames"], 1),
        "sim_fps": statistics.median(s.get("simulated_fps", 0.0) for s in statuses),
        "shown_fps": statistics.median(s["shown_fps"] for s in statuses),
        "frames_advanced_fps": (statuses[-1]["frame"] - statuses[0]["frame"]) / seconds,
        "particles": round(statistics.median(s["particles"] for s in statuses)),
        "status_samples": len(samples),
        "window_seconds": seconds,
        "viewer_cores": cores.pop("viewer"),
        "chromium_cores": sum(cores.values()),
        "chromium_cores_by_process": cores,
    }


def chromium_pids(chrome: HeadlessChromium) -> dict[int, str]:
    """Chromium's processes by kind, numbered where a kind repeats (``renderer 2``)."""
    labelled, seen = {}, {}
    for pid in chrome.process_ids():
        kind = process_kind(pid)
        seen[kind] = seen.get(kind, 0) + 1
        labelled[pid] = kind if seen[kind] == 1 else f"{kind} {seen[kind]}"
    return labelled


def watch(size: Size, *, screenshot_path: Path | None) -> tuple[dict, list[str], float]:
    """Serve the fire at ``size``, open it in Chromium and :func:`measure`; also the
    page's console lines and the seconds the live count took to reach 90%."""
    binary = find_chromium()
    if binary is None:
        raise SystemExit("benchmarks.view needs Chromium: e.g. apt-get install chromium")
    with (
        tempfile.TemporaryDirectory(prefix="motes-view-bench-") as logs,
        HeadlessChromium(binary) as chrome,
        ViewerProcess("fire", *size.viewer_args(), log_dir=Path(logs)) as viewer,
        DevTools(chrome.page_socket, timeout=PAGE_TIMEOUT) as page,
    ):
        open_viewer(page, viewer.url)
        started = time.perf_counter()
        wait_for_status(page, lambda s: s["particles"] >= 0.9 * size.expected, timeout=300,
                        what=f"{0.9 * size.expected:,.0f} live particles",
                        read=received_status)  # fmt: skip
        ramp = time.perf_counter() - started
        time.sleep(WARMUP)
        pids = {pid: "viewer" for pid in descendants(viewer.pid)} | chromium_pids(chrome)
        figures = measure(page, pids)
        if screenshot_path is not None:
            save_screenshot(page, screenshot_path)
        console = list(page.console)
    return figures, console, ramp


def save_screenshot(page: DevTools, path: Path) -> None:
    """The page as a PNG at ``path``, or a note that it did not draw in time (the
    figures are kept either way)."""
    try:
        path.write_bytes(screenshot(page, timeout=SCREENSHOT_TIMEOUT))
    except TimeoutError:
        print(f"no screenshot: the page drew no frame within {SCREENSHOT_TIMEOUT:.0f} s")
    else:
        print(f"screenshot saved: {path}")


def _rows(measured: dict, size: Size, ramp: float) -> list[tuple[str, str]]:
    m = measured
    rows = [
        ("particles", f"{m['particles']:,} live (expected {size.expected:,}), all sent; "
                      f"90% reached after {ramp:.0f} s"),
        ("window", f"{m['window_seconds']:7.1f} s  (longer than {WINDOW:.0f} s where the page "
                   "answered late)"),
        ("browser draws", f"{m['browser_fps']:7.2f} fps  ({m['browser_frames_drawn']} drawn; "
                          f"animation frames {m['raf_fps']:.2f}/s)"),
        ("frames received", f"{m['frames_received_fps']:7.2f} fps  ({m['mb_per_s']:.1f} MB/s, "
                            f"{m['mb_per_frame']:.2f} MB a frame)"),
        ("point clouds made anew", f"{m['point_clouds_created_per_frame']:7.2f} per frame"),
        ("simulated", f"{m['sim_fps']:7.2f} fps  (one step and its packet; capped at 30 "
                      "shown by real time)"),
        ("viewer moved on", f"{m['frames_advanced_fps']:7.2f} frames/s  (it says shown "
                            f"{m['shown_fps']:.1f} fps; {m['status_samples']} samples)"),
        ("CPU, viewer", f"{m['viewer_cores']:7.2f} cores"),
        ("CPU, Chromium", f"{m['chromium_cores']:7.2f} cores"),
    ]  # fmt: skip
    busy = sorted(m["chromium_cores_by_process"].items(), key=lambda kv: -kv[1])
    rows += [(f"  {kind}", f"{cores:7.2f}") for kind, cores in busy if cores >= 0.01]
    return rows


def run(quick: bool, screenshot_path: Path | None) -> dict:
    """Measure, print the tables and return the figures."""
    size = QUICK if quick else FULL
    info = machine()
    load = os.getloadavg()
    rows = [
        ("machine", f"{info['usable_cores']} usable cores, {info['processor']}"),
        ("other load", f"{info['background_busy_cores']:.2f} cores busy before starting; "
                       f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}"),
        ("browser", "headless Chromium, WebGL on SwiftShader (CPU), 1280 x 720"),
        ("window", f"{WINDOW:.0f} s after a {WARMUP:.0f} s warm-up"),
    ]  # fmt: skip
    print(table(rows, title="motes view in a browser" + (" (--quick sizes)" if quick else "")))
    measured, console, ramp = watch(size, screenshot_path=screenshot_path)
    print()
    print(table(_rows(measured, size, ramp), title=f"fire, {size.expected:,} particles"))
    lines = sorted(set(console))
    print()
    print(table([("", line[:160]) for line in lines] or [("", "(none)")],
                title="browser console (distinct lines)"))  # fmt: skip
    figures = {f"view_{size.label}_{key}": value for key, value in measured.items()}
    figures |= {
        "quick": quick,
        "load_average_1min": load[0],
        "browser_console_errors": sum(line.startswith(("error", "exception")) for line in lines),
    }
    return figures | info


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.view",
                                     description=__doc__.split("\n\n")[0])  # fmt: skip
    parser.add_argument("--quick", action="store_true",
                        help="about 100,000 particles, not 1,000,000 (keys say 100k)")  # fmt: skip
    parser.add_argument("--screenshot", type=Path, metavar="PATH",
                        help="save the page as a PNG at the end of the window")  # fmt: skip
    args = parser.parse_args(argv)
    return run_and_report(lambda: run(args.quick, args.screenshot))


if __name__ == "__main__":
    main()
