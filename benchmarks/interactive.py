"""Interactive budgets: a million-particle fire stepped and drawn each frame, and the wait
for the first run's first frame.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.interactive            # about five minutes
    PYTHONPATH=src python -m benchmarks.interactive --quick    # seconds: 20,000 particles,
                                                               # no cold start

- **frame**: the demo fire (:func:`motes.demo.build_fire`) held at 1,000,000 live
  particles (:func:`benchmarks.emitter.fire_system`), their radii scaled by
  :data:`SIZE` (about 3 px across: ``fire_1m_sprite_px``), one step of 1/60 s and its frame
  drawn as additive sprites at 1280 x 720 from the ``fire`` scene's camera, tone mapped
  to 8 bits: ``fire_1m_frame_ms`` (target <= 33, 30 frames a second), and the two parts
  timed alone in the same run, ``fire_1m_step_ms`` (target <= 18) and
  ``fire_1m_draw_ms`` (the sprites' own target, ``additive_1m_ms`` of
  ``benchmarks.render``, is <= 15 for the splat of a million sprites of 2.5-3.7 px
  over the whole frame; here they crowd into the flame, and the frame is cleared,
  filled and tone mapped too).
- **cold start**: ``python -m motes run fire -o fire.mp4`` in a fresh process with an
  empty kernel cache (``NUMBA_CACHE_DIR`` set to a new folder): seconds until its
  progress line for frame 1 (``cold_first_frame_s``, target <= 10) and until it exits
  (``cold_start_fire_s``, target <= 25); then the same command again with the cache it
  left (``warm_start_fire_s``). These first runs compile in two processes, as a user's
  does (:mod:`motes.cli.compile_ahead`); the baseline is a first run in one process
  (``MOTES_COMPILE_AHEAD=0``: ``cold_first_frame_one_process_s``,
  ``cold_start_fire_one_process_s``). Skipped with ``--quick`` (the figures are then
  null): compiling takes a minute or more each time.

Timings are the best of several calls after warm-up calls, with the median beside them.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from motes import Camera, Renderer, SpriteStyle
from motes.cli.compile_ahead import SWITCH

from ._common import benchmark_main, machine, table, time_calls
from .emitter import fire_system

WIDTH, HEIGHT = 1280, 720
#: The demo fire's step [s] (its birth rate is per frame of 1/60 s).
DT = 1.0 / 60.0
#: Scale of the demo fire's particle radii at a million: sprites about 3 px across from
#: the scene camera, as the 1M additive sprites of ``benchmarks.render`` (a fire of
#: 14,000 particles 5 to 40 px across, held at a million, would be one white blur).
SIZE = 0.07
#: A progress line of ``motes run`` for frame 1 (``fire [###...] 1/240 ...``).
FIRST_FRAME = re.compile(r"\s1/\d+\s")


def bench_frame(live: int, repeat: int) -> dict:
    """Step plus draw of the fire held at ``live`` particles, and each part alone."""
    system = fire_system(live, size=SIZE)
    camera = Camera((0.0, 1.1, 3.6), (0.0, 0.9, 0.0), fov=40, resolution=(WIDTH, HEIGHT))
    renderer = Renderer(camera, supersample=1)
    drawn = [(system, SpriteStyle(blend="additive"))]

    def frame():
        system.step(DT)
        renderer.render(drawn)

    both = time_calls(frame, repeat=repeat, warmup=2)
    step = time_calls(lambda: system.step(DT), repeat=repeat, warmup=1)
    draw = time_calls(lambda: renderer.render(drawn), repeat=repeat, warmup=1)
    # Measured on the state drawn (sizes over life act from the first step on).
    state = system.particle_state()
    depth = camera.to_view(state.positions.T)[:, 2]
    diameter = 2.0 * state.radius * camera.pixels_per_metre(np.maximum(depth, 1e-3))
    return {
        "frame": both,
        "step": step,
        "draw": draw,
        "live": len(system),
        "diameter_px": float(np.median(diameter)),
    }


def run_fire(cache: Path, out: Path, *, ahead: bool = True) -> tuple[float | None, float]:
    """Run ``motes run fire`` with kernel cache ``cache``: seconds to frame 1's progress
    line (None if it never printed one) and to the end. Raises if the run fails.
    ``ahead``: whether a first run may compile in two processes (``MOTES_COMPILE_AHEAD``,
    :mod:`motes.cli.compile_ahead`)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), SWITCH: "1" if ahead else "0"}
    command = [sys.executable, "-m", "motes", "run", "fire", "-o", str(out), "--overwrite"]
    started = time.perf_counter()
    first = None
    lines = []
    with subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env
    ) as process:
        for line in process.stdout:
            lines.append(line)
            if first is None and FIRST_FRAME.search(line):
                first = time.perf_counter() - started
        status = process.wait()
    total = time.perf_counter() - started
    if status != 0:
        raise RuntimeError(f"{' '.join(command)} exited with {status}:\n{''.join(lines[-20:])}")
    return first, total


def bench_cold_start() -> dict:
    """The fire scene's first run with an empty kernel cache (as a user's: compiling in
    two processes), then a second one; and a first run in one process, the baseline."""
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "fire.mp4"
        cache, alone = Path(folder) / "numba", Path(folder) / "numba-alone"
        first, cold = run_fire(cache, out)
        _, warm = run_fire(cache, out)
        first_alone, cold_alone = run_fire(alone, out, ahead=False)
    return {"first": first, "cold": cold, "warm": warm, "first_alone": first_alone,
            "cold_alone": cold_alone}  # fmt: skip


def run(*, quick: bool, out=print) -> dict:
    info = machine()
    live = 20_000 if quick else 1_000_000
    f = bench_frame(live, repeat=3 if quick else 10)
    figures = {
        "date": time.strftime("%Y-%m-%d"),
        "quick": quick,
        "cpu_count": info["cpu_count"],
        "numba_threads": info["numba_threads"],
        "background_busy_cores": info["background_busy_cores"],
        "sizes": {"live": live, "resolution": [WIDTH, HEIGHT]},
        "fire_1m_frame_ms": 1e3 * f["frame"].best,
        "fire_1m_frame_median_ms": 1e3 * f["frame"].median,
        "fire_1m_step_ms": 1e3 * f["step"].best,
        "fire_1m_draw_ms": 1e3 * f["draw"].best,
        "fire_1m_live": f["live"],
        "fire_1m_sprite_px": f["diameter_px"],
    }
    frame_ms, median_ms = 1e3 * f["frame"].best, 1e3 * f["frame"].median
    rows = [
        ("fire", f"{live:,} live particles (after timing: {f['live']:,}), {WIDTH} x {HEIGHT}"),
        ("sprites", f"{f['diameter_px']:.1f} px across (median; radii x {SIZE} of the demo's)"),
        ("step + draw", f"{frame_ms:9.2f} ms (median {median_ms:.2f}; target <= 33)"),
        ("step alone", f"{1e3 * f['step'].best:9.2f} ms (target <= 18)"),
        ("draw alone", f"{1e3 * f['draw'].best:9.2f} ms (sprites and tone mapping)"),
    ]
    out(table(rows, title="1. A million-particle fire, stepped and drawn"))
    keys = ("first", "cold", "warm", "first_alone", "cold_alone")
    cold = dict.fromkeys(keys) if quick else bench_cold_start()
    figures |= {
        "cold_first_frame_s": cold["first"],
        "cold_start_fire_s": cold["cold"],
        "warm_start_fire_s": cold["warm"],
        "cold_first_frame_one_process_s": cold["first_alone"],
        "cold_start_fire_one_process_s": cold["cold_alone"],
    }

    def seconds(value, target=""):
        return "not measured (--quick)" if value is None else f"{value:7.1f} s{target}"

    rows = [
        ("command", "python -m motes run fire -o fire.mp4 (240 frames, 1280 x 720)"),
        ("cold: frame 1", seconds(cold["first"], " (target <= 10)")),
        ("cold: all", seconds(cold["cold"], " (target <= 25)")),
        ("warm: all", seconds(cold["warm"])),
        ("one process", "a first run without the helper that compiles the drawing:"),
        ("  frame 1", seconds(cold["first_alone"])),
        ("  all", seconds(cold["cold_alone"])),
    ]
    out()
    out(table(rows, title="2. The first run: an empty kernel cache"))
    return figures


def main(argv: list[str] | None = None) -> dict:
    return benchmark_main(
        argv,
        prog="python -m benchmarks.interactive",
        doc=__doc__,
        quick_help="20,000 particles, no cold start",
        run=lambda quick: run(quick=quick),
    )


if __name__ == "__main__":
    main()
