"""Frame time of every built-in scene: how long one frame takes to draw at its own size.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.scenes            # every scene, a few minutes
    PYTHONPATH=src python -m benchmarks.scenes --quick    # three scenes at 320 x 180

Each scene is loaded, simulated for one second (its first second when shorter), then
its frame is drawn at the scene's own resolution: one warm-up draw (kernels load or
compile), then the best and the median of three. The simulation is not timed. It
prints a table, then one line of JSON: ``render_ms`` (scene -> best ms),
``render_median_ms``, ``resolution`` (scene -> [width, height]).

To compare with an earlier version of motes, run this file against that version's
package (the script reads nothing newer than ``load_scene``, ``Scene.advance`` and
``Scene.render``)::

    git worktree add /tmp/before COMMIT
    PYTHONPATH=/tmp/before/src python -m benchmarks.scenes

Scenes that version does not have are left out of its figures.
"""

from __future__ import annotations

import datetime
from pathlib import Path

import motes
from motes.scene import load_scene

from ._common import benchmark_main, machine, table, time_calls

QUICK = ("fire", "dam_break", "ragdoll_stairs")


def builtin_names() -> list[str]:
    """The built-in scenes of the motes that is imported."""
    folder = Path(motes.__file__).parent / "scene" / "builtin"
    return sorted(p.stem for p in folder.glob("*.toml"))


def frame_time(name: str, *, quick: bool):
    """``(resolution, Timing)`` of drawing scene ``name`` after one simulated second."""
    scene = load_scene(name)
    frames = min(round(scene.fps), scene.frame_count)
    for _ in range(frames):
        scene.advance()
    size = (320, 180) if quick else tuple(scene.camera.resolution)
    return size, time_calls(lambda: scene.render(size), repeat=3)


def run(*, quick: bool, out=print) -> dict:
    info = machine()
    names = [n for n in builtin_names() if not quick or n in QUICK]
    figures: dict = {
        "date": datetime.date.today().isoformat(),
        "quick": quick,
        "motes": str(Path(motes.__file__).parent),
        "cpu_count": info["cpu_count"],
        "numba_threads": info["numba_threads"],
        "background_busy_cores": info["background_busy_cores"],
        "render_ms": {},
        "render_median_ms": {},
        "resolution": {},
    }
    rows = []
    for name in names:
        size, timing = frame_time(name, quick=quick)
        figures["render_ms"][name] = 1e3 * timing.best
        figures["render_median_ms"][name] = 1e3 * timing.median
        figures["resolution"][name] = list(size)
        shown = f"{size[0]} x {size[1]}  {1e3 * timing.best:8.1f} ms"
        rows.append((name, f"{shown} (median {1e3 * timing.median:.1f})"))
        out(f"  {name:<22} {rows[-1][1]}", flush=True)
    out()
    out(table(rows, title="Frame time of the built-in scenes after one simulated second"))
    return figures


def main(argv: list[str] | None = None) -> dict:
    return benchmark_main(
        argv,
        prog="python -m benchmarks.scenes",
        doc=__doc__,
        quick_help="fire, dam_break and ragdoll_stairs at 320 x 180",
        run=lambda quick: run(quick=quick),
    )


if __name__ == "__main__":
    main()
