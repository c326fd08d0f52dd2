"""Export throughput: a million-particle fire written frame by frame to each format.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.pipeline           # 1,000,000 points x 10 frames
    PYTHONPATH=src python -m benchmarks.pipeline --quick   # 20,000 points x 3 frames

The demo fire held at a steady live count (:func:`benchmarks.emitter.fire_system`, the
emitter benchmark's), stepped between frames so every frame holds new values (USD's
crate files share identical arrays: unchanged frames would measure nothing), is written
through the exporters ``motes run --export`` uses (:func:`motes.io.export.writer_for`):
ids, positions, velocities, radius, age, lifetime, colour and birth size, 68 bytes a
point. Only ``write_frame`` and the final ``close`` are timed, not the steps. Figures, in
millions of points written per second (points of all frames over the writer's time):

- ``usd_export_mpoints_per_s``: a time-sampled ``.usdc`` (the headline; target >= 20);
- ``usd_core_export_mpoints_per_s``: the same with the core attributes only (ids,
  positions, velocities, widths: 36 bytes a point), where USD's own time goes;
- ``vtp_export_mpoints_per_s``: ``.pvd`` with a ``.vtp`` per frame (LZ4-compressed);
- ``ply_export_mpoints_per_s``: a binary ``.ply`` per frame;
- ``npz_cache_mpoints_per_s``: the baseline, the ``.npz`` particle cache of the same
  frames (spooled to disk frame by frame, one uncompressed archive at the end), with
  each format's ratio to it (``*_vs_npz``);
- ``h5_cache_mpoints_per_s``, ``h5_lossy_cache_mpoints_per_s``: the ``.h5`` cache
  (streamed, shuffled and deflated), every bit kept, and with 3 significant digits;
- ``cache_compression_ratio``: the ``.npz`` cache's size over the ``.h5`` cache's, every
  bit kept (the issue's target is >= 3), ``cache_compression_ratio_lossy`` the same with
  3 significant digits; ``*_cache_mb_per_mpf``: each cache's megabytes per million
  particle-frames;
- ``dask_render_efficiency``: drawing the frames of a cache of the ``rain`` scene (24 at
  960 × 540; ``--quick``: 4 of a small emitter at 160 × 90) with ``motes render``'s Dask
  path on ``N = 2`` single-threaded local workers, against the same frames drawn one
  after another on one thread in this process (the same task, :func:`motes.scene.farm.
  draw_frame`): serial time over ``N`` times the farm's time (target >= 0.8). Both are
  warmed up first (each worker draws a frame: the scene built, the kernels loaded), so
  the figure is the farm's steady throughput, not the cluster's start.

Files go to a temporary folder (the page cache, on a machine with memory to spare: the
figures are the writers', not the disk's). Formats whose package is not installed are
skipped and named.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from motes.io.entry import Entry
from motes.io.export import ExportError, writer_for
from motes.state import ParticleState

from ._common import benchmark_main, machine, table
from .emitter import DT, FPS, fire_system

#: Figure -> (output name, whether only the core attributes are written, the writer's
#: options). The first is the baseline.
FORMATS = {
    "npz_cache_mpoints_per_s": ("run.npz", False, {}),
    "h5_cache_mpoints_per_s": ("run.h5", False, {}),
    "h5_lossy_cache_mpoints_per_s": ("lossy.h5", False, {"significant_digits": 3}),
    "usd_export_mpoints_per_s": ("run.usdc", False, {}),
    "usd_core_export_mpoints_per_s": ("core.usdc", True, {}),
    "vtp_export_mpoints_per_s": ("run.pvd", False, {}),
    "ply_export_mpoints_per_s": ("run.####.ply", False, {}),
}


def core(state: ParticleState) -> ParticleState:
    """``state`` with its ids, positions, velocities and radius only."""
    return ParticleState(state.ids, state.positions, state.velocities, state.radius)


def time_export(
    path: Path, system, frames: int, *, only_core: bool, options: dict
) -> tuple[float, int]:
    """Seconds spent writing ``frames`` frames of ``system`` to ``path``, and the points
    written. The system is stepped (untimed) before each frame."""
    writer = writer_for(path, fps=FPS, scene="fire", **options)
    spent, points = 0.0, 0
    for frame in range(1, frames + 1):
        system.step(DT)
        state = system.particle_state()
        entry = Entry(core(state) if only_core else state)
        start = time.perf_counter()
        writer.write_frame(frame, frame * DT, {"fire": entry})
        spent += time.perf_counter() - start
        points += state.count
    start = time.perf_counter()
    writer.close()
    return spent + time.perf_counter() - start, points


def run(quick: bool) -> dict:
    points, frames = (20_000, 3) if quick else (1_000_000, 10)
    figures: dict = {"quick": quick, "points": points, "frames": frames, **machine()}
    print(f"building a fire of {points:,} particles ...", file=sys.stderr, flush=True)
    system = fire_system(points)
    for _ in range(3):  # the kernels' first calls (compilation or cache loading)
        system.step(DT)
    rows = []
    skipped = []
    with tempfile.TemporaryDirectory(prefix="motes-pipeline-") as folder:
        for figure, (output, only_core, options) in FORMATS.items():
            name = figure.removesuffix("_mpoints_per_s").removesuffix("_export")
            print(f"{name} ...", file=sys.stderr, flush=True)
            try:
                seconds, written = time_export(
                    Path(folder) / output, system, frames, only_core=only_core, options=options
                )
            except ExportError as error:  # its package is not installed
                skipped.append(name)
                rows.append((name, f"skipped: {error}"))
                continue
            rate = written / seconds / 1e6
            figures[figure] = rate
            figures[f"{name}_seconds"] = seconds
            shown = f"{rate:7.2f} M points/s  ({written:,} points in {seconds:.2f} s)"
            if name.endswith("_cache"):
                size = (Path(folder) / output).stat().st_size
                figures[f"{name}_mb_per_mpf"] = size / 1e6 / (written / 1e6)
                shown += f", {size / written:.1f} B/point"
            rows.append((f"{output:<13} {name}", shown))
    base = figures["npz_cache_mpoints_per_s"]
    for figure in list(FORMATS)[1:]:
        if figure in figures:
            name = figure.removesuffix("_mpoints_per_s").removesuffix("_export")
            figures[f"{name}_vs_npz"] = figures[figure] / base
    npz = figures["npz_cache_mb_per_mpf"]
    figures["cache_compression_ratio"] = npz / figures["h5_cache_mb_per_mpf"]
    figures["cache_compression_ratio_lossy"] = npz / figures["h5_lossy_cache_mb_per_mpf"]
    figures["skipped"] = skipped
    print(table(rows, title=f"Export of {points:,} points x {frames} frames (write + close)"))
    ratios = [
        ("every bit kept", f"{figures['cache_compression_ratio']:.2f}"),
        ("3 significant digits", f"{figures['cache_compression_ratio_lossy']:.2f}"),
    ]
    print(table(ratios, title=".npz cache size / .h5 cache size (target >= 3)"))
    figures |= farm_efficiency(quick)
    return figures


QUICK_SCENE = """
[scene]
name = "puff"
fps = 30
seed = 1

[[system]]
name = "puff"
capacity = 2000
  [[system.emitter]]
  shape = { type = "sphere", radius = 0.3 }
  rate = { type = "per_second", rate = 3000 }
  speed = { uniform = [0.5, 1.5] }
  lifetime = 0.5
"""


def farm_efficiency(quick: bool, workers: int = 2) -> dict:
    """``dask_render_efficiency`` (see the module docstring); {} without ``distributed``."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        print("dask render: skipped (distributed is not installed)")
        return {}
    import numba

    from motes.cli.main import main as motes
    from motes.scene.farm import draw_frame

    frames, resolution = (4, (160, 90)) if quick else (24, (960, 540))
    with tempfile.TemporaryDirectory(prefix="motes-farm-") as folder:
        root = Path(folder)
        cache = root / "farm.npz"
        # --quick: a small scene of one emitter, whose kernels load fast.
        scene = "rain"
        if quick:
            scene = str(root / "puff.toml")
            Path(scene).write_text(QUICK_SCENE)
        motes(["run", scene, "--frames", str(frames + workers), "--no-render", "--export",
               str(cache), "-q"])  # fmt: skip
        options = {"cache": str(cache), "scene": scene if quick else None,
                   "resolution": resolution, "metadata": None}  # fmt: skip
        previous = numba.get_num_threads()
        try:
            draw_frame(0, folder=folder, **options)  # warm-up
            start = time.perf_counter()
            for index in range(workers, frames + workers):
                draw_frame(index, folder=folder, **options)
            serial = time.perf_counter() - start
        finally:
            numba.set_num_threads(previous)
        out = root / "farm"
        out.mkdir()
        with (
            LocalCluster(
                n_workers=workers,
                threads_per_worker=1,
                dashboard_address=None,
                scheduler_kwargs={"dashboard_address": ":0"},  # not 8787: it may be taken
            ) as c,
            Client(c) as client,
        ):
            # One warm-up frame on each worker (the scene built, the kernels loaded).
            names = list(client.scheduler_info()["workers"])
            warm = [client.submit(draw_frame, k, folder=str(out), workers=[w], pure=False,
                                  **options) for k, w in enumerate(names)]  # fmt: skip
            client.gather(warm)
            tasks = range(workers, frames + workers)
            start = time.perf_counter()
            client.gather(client.map(draw_frame, tasks, folder=str(out), pure=False, **options))
            farm = time.perf_counter() - start
    efficiency = serial / (workers * farm)
    shown = f"{efficiency:.2f} (serial {serial:.2f} s, {workers} workers {farm:.2f} s)"
    print(table([(f"{frames} frames, {resolution[0]}x{resolution[1]}", shown)],
                title="Drawing a cache on Dask: serial time / (N x farm time)"))  # fmt: skip
    return {
        "dask_render_efficiency": efficiency,
        "dask_render_serial_s": serial,
        "dask_render_farm_s": farm,
        "dask_render_workers": workers,
    }


def main(argv: list[str] | None = None) -> dict:
    return benchmark_main(
        argv,
        prog="python -m benchmarks.pipeline",
        doc=__doc__,
        quick_help="20,000 points x 3 frames",
        run=run,
    )


if __name__ == "__main__":
    main()
