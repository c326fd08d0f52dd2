"""``motes run``, ``export``, ``render``, ``wedge`` (:mod:`.wedge_command`), ``view``
(:mod:`.view_command`), ``scenes``, ``show``, ``demo`` and ``--version``.

User mistakes (a bad scene key, a missing file, a bad option, a size that would not fit
in memory, a body that diverges while the scene runs) end with exit status 2 and one
line ``motes: error: ...`` on stderr, without a traceback. So does a particle whose state
turns NaN or infinite (checked after every frame unless ``--no-check-finite``), after
the frames before it have been written. Ctrl-C ends with status 130, SIGTERM with 143,
after every finished frame has been written and the video closed.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

from .common import (
    UserError,
    dask_options,
    digits,
    frame_range,
    image_options,
    integer_from,
    positive,
    resolution,
    terminate_as_interrupt,
)

RUN_EXAMPLES = """\
examples:
  motes run fire                          render the built-in fire to fire.mp4
  motes run fire -o fire.gif --frames 60  60 frames to an animated GIF
  motes run smoke -o still.png            the last frame as a PNG
  motes run fire -o fire.exr --frame 90   frame 90 in linear light with depth (OpenEXR)
  motes run my_scene.toml -o frames/      a numbered PNG sequence in frames/
  motes run rain --resolution 640x360 --seed 3 --export rain.h5
  motes run cloth_drop --no-render --export cloth.usdc    OpenUSD for Blender, Houdini
  motes run fountain --no-render --export out/drops.####.ply  a PLY file per frame
  motes run fire --set system.flame.emitter.0.rate.rate=500 --set camera.fov=40
"""

EXPORT_EXAMPLES = """\
examples:
  motes export run.h5 run.usdc               one time-sampled OpenUSD stage
  motes export run.h5 run.pvd                ParaView: run.pvd and run/*.vtp
  motes export run.h5 frames/run.####.geo    Houdini: a .geo file per frame
"""

RENDER_EXAMPLES = """\
examples:
  motes run rain --no-render --export rain.h5    simulate once ...
  motes render rain.h5 -o rain.mp4               ... draw it as often as wanted
  motes render rain.h5 -o still.png --frames 119:120 --resolution 1920x1080
  motes render run.h5 -o frames/ --scene my_scene.toml   a cache of a scene file
  motes render rain.h5 -o frames/ --workers 2    on a local Dask cluster (resumable)
  motes render rain.h5 -o side.mp4 --set 'camera.position=[6, 2, 4]' --set camera.fov=30
"""


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="motes", description="motes: particle systems, simulated and rendered headless."
    )
    parser.add_argument("--version", action="store_true", help="print the version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    run = sub.add_parser(
        "run",
        help="simulate a scene and render it to a video, images or a cache",
        description="Simulate a scene (a built-in name or a .toml file) and render it.",
        epilog=RUN_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    run.add_argument("scene", metavar="NAME_OR_FILE", help="built-in scene name or .toml file")
    run.add_argument(
        "-o",
        "--output",
        metavar="OUT",
        help="OUT.mp4, OUT.gif, OUT.png (last frame) or a directory for PNG "
        "frames (default: NAME.mp4)",
    )
    length = run.add_mutually_exclusive_group()
    length.add_argument(
        "--frames",
        type=integer_from(1),
        metavar="N",
        help="number of frames (default: the scene's duration × fps)",
    )
    length.add_argument(
        "--frame",
        type=integer_from(1),
        metavar="N",
        help="a still of frame N (counted from 1), with -o NAME.png or NAME.exr: the "
        "frames before it are simulated, not drawn",
    )
    length.add_argument(
        "--time",
        type=positive,
        metavar="T",
        help="a still of the frame at T seconds (the nearest), as --frame",
    )
    run.add_argument(
        "--seed", type=integer_from(0), metavar="S", help="random seed (overrides the scene)"
    )
    run.add_argument(
        "--set",
        action="append",
        default=[],
        dest="overrides",
        metavar="KEY=VALUE",
        help="set a value of the scene file, e.g. scene.seed=7, camera.fov=40, "
        "system.0.emitter.0.rate.rate=500 or system.NAME.capacity=5000 (a TOML value; "
        "other text is a string); repeatable",
    )
    image_options(run)
    run.add_argument(
        "--resolution",
        type=resolution,
        metavar="WxH",
        help="image size, e.g. 1280x720 (default: the scene's)",
    )
    run.add_argument(
        "--export",
        metavar="PATH",
        help="also write the particles for other tools, by extension: CACHE.h5 or .npz "
        "(docs/cache-format.md), .usd/.usda/.usdc (OpenUSD), .pvd (ParaView), or a file "
        "per frame NAME.####.ply / NAME.####.geo (docs/exports.md)",
    )
    run.add_argument(
        "--significant-digits",
        type=digits,
        metavar="D",
        help="with --export CACHE.h5: keep D significant decimal digits (1 to 15) of every "
        "float attribute; lossy and smaller (3: within 0.05 %%, about half the size)",
    )
    run.add_argument(
        "--no-render", action="store_true", help="simulate (and export) without rendering images"
    )
    run.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the frames of an earlier run in a non-empty frame folder",
    )
    run.add_argument(
        "--no-check-finite",
        dest="check_finite",
        action="store_false",
        help="do not stop at the first particle whose state turns NaN or infinite",
    )
    run.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")
    export = sub.add_parser(
        "export",
        help="convert a particle cache (.h5, .npz) to OpenUSD, VTK, PLY or Houdini .geo",
        description="Write the frames of a cache that motes run --export CACHE.h5 wrote "
        "in another format, chosen by OUT's extension (see docs/exports.md).",
        epilog=EXPORT_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    export.add_argument("cache", metavar="CACHE", help="a particle cache (.h5 or .npz)")
    export.add_argument(
        "output",
        metavar="OUT",
        help=".usd/.usda/.usdc, .pvd, NAME.####.ply or NAME.####.geo (#### is the frame)",
    )
    export.add_argument(
        "--fps",
        type=positive,
        metavar="F",
        help="frames per second of the cache (default: the one it records)",
    )
    export.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")
    render = sub.add_parser(
        "render",
        help="draw a particle cache (.h5, .npz) again with its scene, without simulating",
        description="Draw the frames of a cache that motes run --export CACHE.h5 wrote, "
        "with the look of the scene it records (camera, lights, objects, looks), as "
        "motes run drew them. Every kind can be drawn from a cache but trails (a flock's "
        "or a rigid world's path over its last steps).",
        epilog=RENDER_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    render.add_argument("cache", metavar="CACHE", help="a particle cache (.h5 or .npz)")
    render.add_argument(
        "-o",
        "--output",
        metavar="OUT",
        required=True,
        help="OUT.mp4, OUT.gif, OUT.png (last frame) or a directory for PNG frames",
    )
    render.add_argument(
        "--frames",
        type=frame_range,
        metavar="A:B",
        help="the cached frames A to B - 1 (counted from 0, as Python slices; default: all)",
    )
    image_options(render)
    render.add_argument(
        "--resolution",
        type=resolution,
        metavar="WxH",
        help="image size, e.g. 1280x720 (default: the scene's)",
    )
    render.add_argument(
        "--scene",
        metavar="NAME_OR_FILE",
        help="the scene to draw with (default: the one the cache records; a scene file's "
        "path is not recorded)",
    )
    render.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="draw with another camera, render setting or light: a camera.*, render.* or "
        "light.* key of the scene, as motes run --set takes it (camera.position=[4, 2, 6], "
        "camera.fov=30, render.exposure=1.5); repeatable",
    )
    render.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the frames of an earlier run in a non-empty frame folder",
    )
    dask_options(
        render,
        workers="draw the frames on a local Dask cluster of N single-threaded processes "
        "(OUT a folder; frames already in it are kept: an interrupted render resumes)",
        scheduler="draw the frames on a running Dask cluster, e.g. tcp://host:8786 (as --workers)",
    )
    render.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")
    from .view_command import add_parser as add_view
    from .wedge_command import add_parser as add_wedge

    add_wedge(sub)
    add_view(sub)
    sub.add_parser("scenes", help="list the built-in scenes")
    show = sub.add_parser(
        "show",
        help="print a built-in scene's TOML (a start for a scene of your own)",
        description="Print a built-in scene file, e.g. motes show fire > my_fire.toml",
    )
    show.add_argument("scene", metavar="NAME", help="built-in scene name")
    sub.add_parser("demo", help="render the built-in fire to fire.mp4 (same as: motes run fire)")
    return parser


def main(argv: list[str] | None = None) -> int:
    from .._memory import InsufficientMemoryError

    parser = _parser()
    args = parser.parse_args(argv)
    if args.version:
        from .._version import __version__

        print(f"motes {__version__}")
        return 0
    if args.command is None:
        parser.print_help()
        return 0
    if args.command == "demo":
        args = parser.parse_args(["run", "fire", "-o", "fire.mp4"])
    try:
        if args.command == "scenes":
            return _list_scenes()
        if args.command == "show":
            return _show(args.scene)
        if args.command == "export":
            return _export(args)
        if args.command == "render":
            return _render(args)
        if args.command == "wedge":
            from .wedge_command import run as wedge

            return wedge(args)
        if args.command == "view":
            from .view_command import run as view

            return view(args)
        return _run(args)
    except (UserError, InsufficientMemoryError) as error:
        print(f"motes: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\nmotes: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # The reader went away (``motes scenes | head``): not an error of ours. Point
        # stdout at /dev/null so that the interpreter's final flush does not fail too.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


def _show(name: str) -> int:
    from ..scene import SceneError
    from ..scene.scene import builtin_text

    try:
        sys.stdout.write(builtin_text(name))
    except SceneError as error:
        raise UserError(str(error)) from None
    sys.stdout.flush()  # a closed pipe fails here, where main() reports it quietly
    return 0


def _list_scenes() -> int:
    from ..scene import builtin_scenes

    scenes = builtin_scenes()
    width = max(map(len, scenes), default=0)
    for name, description in scenes.items():
        print(f"{name:<{width}}  {description}")
    sys.stdout.flush()  # a closed pipe fails here, where main() reports it quietly
    return 0


def _default_output(scene_name: str) -> str:
    """``NAME.mp4`` in the current directory; a name that would leave it is refused.

    Scene files are validated to hold plain names; this guards scenes built in Python.
    """
    from ..scene.schema import SceneError, file_name

    try:
        return f"{file_name(scene_name, 'scene.name')}.mp4"
    except SceneError as error:
        raise UserError(f"{error}; give the output with -o") from None


def _record(scene) -> dict[str, str]:
    """What an output records of how it was made: enough to make it again."""
    from .._version import __version__

    record = {
        "scene": scene.name,
        "source": str(scene.source),
        "seed": str(scene.seed),
        "motes_version": __version__,
    }
    if scene.overrides:
        # TOML values are JSON values except dates, which no scene key takes.
        record["overrides"] = json.dumps(scene.overrides, default=str)
    return record


def _check_writable(path: Path | None) -> None:
    """Refuse, before simulating, an output whose folder cannot be written."""
    if path is None:
        return
    folder = path if path.suffix == "" and path.is_dir() else path.resolve().parent
    if folder.is_dir() and not os.access(folder, os.W_OK | os.X_OK):
        raise UserError(f"cannot write to {folder}: permission denied")


def _exporter(path: str, **options):
    """The writer of ``--export PATH`` (or ``motes export``'s OUT), checked: its format,
    its folder, that it can be written, and that its optional package is installed."""
    from ..io.export import ExportError, writer_class, writer_for

    try:
        writer_class(path).check_package()
        if not Path(path).resolve().parent.is_dir():
            raise ExportError(f"export directory does not exist: {Path(path).parent}")
        _check_writable(Path(path))
        return writer_for(path, **options)
    except ExportError as error:
        raise UserError(str(error)) from None


def _export(args) -> int:
    """``motes export CACHE OUT``: replay a cache through the writer OUT's extension picks."""
    from ..io.cache import DamagedCacheError, load_cache
    from ..io.export import ExportError, export_cache, writer_class
    from .progress import Progress

    try:
        writer_class(args.output).check_package()
    except ExportError as error:
        raise UserError(str(error)) from None
    source = Path(args.cache)
    if source.resolve() == Path(args.output).resolve():
        raise UserError(f"OUT is the cache itself: {args.output}")
    try:
        cache = load_cache(source)
    except FileNotFoundError:
        raise UserError(f"no such cache: {args.cache}") from None
    except (ValueError, OSError) as error:
        raise UserError(str(error)) from None
    fps = args.fps or cache.fps
    if fps is None:
        raise UserError(
            f"{args.cache} does not record its frame rate (written by an older motes): "
            "give it with --fps"
        )
    writer = _exporter(
        args.output, fps=fps, scene=cache.scene, seed=cache.seed, overrides=cache.overrides
    )
    progress = Progress(cache.frame_count, label=source.name, enabled=not args.quiet)
    start = time.perf_counter()
    try:
        with writer:
            export_cache(cache, writer, progress=progress.update)
    except KeyboardInterrupt:
        progress.close()
        held = writer.frames_written
        print(f"motes: interrupted; {args.output} holds {held} frames", file=sys.stderr)
        return 130
    except (ExportError, DamagedCacheError) as error:
        progress.close()
        raise UserError(str(error)) from None
    progress.close()
    if not args.quiet:
        elapsed = time.perf_counter() - start
        print(f"{writer.frames_written} frames in {elapsed:.1f} s; wrote {args.output}")
    return 0


def _clear_frames(folder: Path, *, overwrite: bool) -> None:
    """A frame folder must hold only this run's frames: refuse one with files in it, or,
    with ``--overwrite``, remove an earlier run's frames (and nothing else)."""
    from ..io.frames import SEQUENCE_METADATA

    if not folder.is_dir():
        return
    present = sorted(folder.iterdir())
    if not present:
        return
    if not overwrite:
        raise UserError(
            f"frame folder {folder} is not empty ({len(present)} entries); frames of two "
            "runs would mix: give --overwrite to replace its frames, or another folder"
        )
    for path in present:
        if path.name == SEQUENCE_METADATA or re.fullmatch(r"frame_\d{5,}\.png", path.name):
            path.unlink()


def _warn_dropped(scene, warned: set) -> None:
    """Warn once per system whose births were dropped at its capacity."""
    for name, system in scene.systems.items():
        dropped = system.store.dropped
        if dropped and name not in warned:
            warned.add(name)
            print(
                f"\nmotes: warning: system {name!r} is full ({system.store.capacity} "
                f"particles): {dropped} births dropped so far; raise its capacity",
                file=sys.stderr,
            )


def _render(args) -> int:
    """``motes render CACHE -o OUT``: draw a cache's frames with its scene."""
    from ..io.cache import DamagedCacheError, load_cache
    from ..io.frames import SequenceWriter, open_writer
    from ..scene import SceneError
    from ..scene.overrides import parse_assignment
    from ..scene.replay import Replay, ReplayError, load_for
    from .progress import Progress

    output = Path(args.output)
    if output.suffix.lower() not in OUTPUTS:
        raise UserError(f"-o must end in .mp4, .gif, .png or .exr, or be a directory; got {output}")
    _check_exr(output)
    _check_alpha(args, output)
    if output.parent != Path() and not output.parent.is_dir():
        raise UserError(f"output directory does not exist: {output.parent}")
    _check_writable(output)
    try:
        cache = load_cache(Path(args.cache))
    except FileNotFoundError:
        raise UserError(f"no such cache: {args.cache}") from None
    except (ValueError, OSError) as error:
        raise UserError(str(error)) from None
    try:
        overrides = dict(parse_assignment(text) for text in args.overrides)
        scene = load_for(cache, args.scene, overrides)
        replay = Replay(scene, cache)
    except (SceneError, ReplayError) as error:
        raise UserError(str(error)) from None
    except OSError as error:
        raise UserError(f"cannot read {args.scene}: {error.strerror}") from None
    indices = range(cache.frame_count)
    if args.frames is not None:
        indices = indices[slice(*args.frames)]
    if not indices:
        raise UserError(f"--frames selects no frame of the {cache.frame_count} in the cache")
    resolution = args.resolution or scene.camera.resolution
    still = output.suffix.lower() in (".png", ".exr")
    if still:
        indices = indices[-1:]  # a .png or .exr keeps only the last frame
    farm = args.workers is not None or args.scheduler is not None
    if farm and output.suffix != "":
        raise UserError(f"--workers and --scheduler write a folder of PNG frames; got -o {output}")
    if farm and (args.alpha or args.bits != 8):
        raise UserError("--workers and --scheduler draw 8-bit frames without alpha, for now")
    if output.suffix == "" and (args.overwrite or not farm):
        _clear_frames(output, overwrite=args.overwrite)
    scene.renderer(resolution)  # a frame that would not fit in memory fails here
    progress = Progress(len(indices), label=Path(args.cache).name, enabled=not args.quiet)
    if farm:
        return _render_farm(args, scene, indices, resolution, progress, overrides)
    if output.suffix.lower() == ".exr":
        replay.place(indices[-1])
        states = replay.states(indices[-1])
        _write_exr(output, scene.renderer(resolution), scene, states, alpha=args.alpha)
        if not args.quiet:
            print(f"wrote {output} (cached frame {indices[-1]})")
        return 0
    progress.begin()
    start = time.perf_counter()
    done = 0
    interrupted = False
    failure = None
    with contextlib.ExitStack() as outputs:
        signals = outputs.enter_context(terminate_as_interrupt())
        # Frames are numbered as in the cache, as a render on Dask numbers them.
        opened = (
            SequenceWriter(output, start=indices[0], metadata=_record(scene))
            if output.suffix == ""
            else open_writer(output, fps=scene.fps, metadata=_record(scene))
        )
        writer = outputs.enter_context(opened)
        outputs.callback(progress.close)
        try:
            for index in indices:
                if args.alpha or args.bits == 16:
                    replay.place(index)
                    writer.write(_picture(args, scene, resolution, replay.states(index)))
                else:
                    writer.write(replay.render(index, resolution))
                done += 1
                progress.update(done)
        except KeyboardInterrupt:
            interrupted = True
        # a surface too wide, a cache mismatch, a damaged cache
        except (SceneError, ReplayError, DamagedCacheError) as error:
            failure = UserError(f"{error} (after {done} frames)")
    if failure is not None:
        raise failure
    if interrupted:
        held = writer.frames_written
        how = "terminated" if signals["terminated"] else "interrupted"
        print(f"motes: {how} after {done} frames; {output} holds {held}", file=sys.stderr)
        return 143 if signals["terminated"] else 130
    if not args.quiet:
        elapsed = time.perf_counter() - start
        print(f"{done} frames in {elapsed:.1f} s ({done / elapsed:.1f} fps); wrote {output}")
    return 0


def _render_farm(args, scene, indices, resolution, progress, overrides) -> int:
    """``motes render --workers N`` / ``--scheduler ADDRESS``: the frames on Dask."""
    from ..io.cache import DamagedCacheError
    from ..scene import SceneError
    from ..scene.farm import FarmError, render_on_dask
    from ..scene.replay import ReplayError

    output = Path(args.output)
    progress.begin()
    start = time.perf_counter()
    try:
        with terminate_as_interrupt():
            drawn = render_on_dask(
                Path(args.cache), output, list(indices), scene=args.scene, overrides=overrides,
                resolution=resolution, workers=args.workers, scheduler=args.scheduler,
                metadata=_record(scene), progress=progress.update,
            )  # fmt: skip
    except KeyboardInterrupt:
        progress.close()
        held = len(list(output.glob("frame_*.png")))
        print(
            f"motes: interrupted; {output} holds {held} frames (run again to draw the rest)",
            file=sys.stderr,
        )
        return 130
    except (FarmError, SceneError, ReplayError, DamagedCacheError) as error:
        progress.close()
        raise UserError(str(error)) from None
    progress.close()
    if not args.quiet:
        elapsed = time.perf_counter() - start
        kept = len(indices) - drawn
        print(
            f"{drawn} frames in {elapsed:.1f} s on Dask"
            + (f" ({kept} already there)" if kept else "")
            + f"; wrote {output}"
        )
    return 0


#: What -o may end in ("": a folder of PNG frames).
OUTPUTS = ("", ".mp4", ".gif", ".png", ".exr")


def _check_exr(output: Path | None) -> None:
    """An ``.exr`` output needs the OpenEXR package: say so before anything runs."""
    if output is not None and output.suffix.lower() == ".exr":
        from ..io.exr import ExrUnavailable, check_available

        try:
            check_available()
        except ExrUnavailable as error:
            raise UserError(str(error)) from None


def _write_exr(output: Path, renderer, scene, states, *, alpha: bool = False) -> None:
    """The frame now as OpenEXR: linear colour times the exposure, and the depth; with
    ``alpha``, premultiplied over a transparent background, with its coverage."""
    from ..io.exr import write_exr

    frame = renderer.render_scene_hdr(scene, states, transparent=alpha)
    color = frame.color * renderer.exposure
    write_exr(output, color, frame.depth, _record(scene), alpha=frame.alpha)


def _check_alpha(args, output: Path | None) -> None:
    """``--alpha`` needs an image format with alpha; ``--bits 16`` a PNG one (and pypng)."""
    suffix = None if output is None else output.suffix.lower()
    if args.alpha and suffix not in (".exr", ".png", ""):
        raise UserError("--alpha needs -o NAME.exr, NAME.png or a folder of PNG frames")
    if args.bits == 16:
        if suffix not in (".png", ""):
            raise UserError("--bits 16 needs -o NAME.png or a folder of PNG frames")
        try:
            import png  # noqa: F401
        except ImportError:
            raise UserError(
                "16-bit PNG needs the pypng package: pip install 'motes[png16]'"
            ) from None


def _picture(args, scene, resolution, states=None) -> np.ndarray:
    """The frame now as the image to write: the 8-bit sRGB frame, or with ``--alpha``
    (straight alpha over a transparent background) or ``--bits 16`` the file's pixels."""
    renderer = scene.renderer(resolution)
    if not args.alpha and args.bits == 8:
        return renderer.render_scene(scene, states)
    from ..render.tonemap import to_display

    frame = renderer.render_scene_hdr(scene, states, transparent=args.alpha)
    return to_display(frame.color, exposure=renderer.exposure, tonemap=renderer.tonemap,
                      alpha=frame.alpha, bits=args.bits)  # fmt: skip


def _run(args) -> int:
    from ..scene import SceneError, load_scene
    from ..scene.overrides import parse_assignment
    from .compile_ahead import CompileAhead, kernels_cached

    first_run = not args.no_render and not kernels_cached()
    try:
        overrides = dict(parse_assignment(text) for text in args.overrides)
        scene = load_scene(
            args.scene, seed=args.seed, overrides=overrides, check_finite=args.check_finite
        )
    except SceneError as error:
        raise UserError(str(error)) from None
    except OSError as error:
        raise UserError(f"cannot read {args.scene}: {error.strerror}") from None
    frames = args.frames or scene.frame_count
    output = None if args.no_render else Path(args.output or _default_output(scene.name))
    resolution = args.resolution or scene.camera.resolution
    if output is not None and output.suffix.lower() not in OUTPUTS:
        raise UserError(f"-o must end in .mp4, .gif, .png or .exr, or be a directory; got {output}")
    still = output is not None and output.suffix.lower() in (".png", ".exr")
    if args.frame is not None or args.time is not None:
        if not still:
            raise UserError("--frame and --time draw one frame: give -o NAME.png or NAME.exr")
        frames = args.frame or max(1, round(args.time * scene.fps))
    _check_exr(output)
    _check_alpha(args, output)
    if output is not None and output.parent != Path() and not output.parent.is_dir():
        raise UserError(f"output directory does not exist: {output.parent}")
    _check_writable(output)
    # Every mistake in --export (its extension, ####, its folder, a missing package) is
    # found here, before the first frame is simulated.
    if args.significant_digits is not None and Path(args.export or "").suffix.lower() not in (
        ".h5",
        ".hdf5",
    ):
        raise UserError("--significant-digits needs --export CACHE.h5 (an HDF5 cache)")
    digits = (
        {} if args.significant_digits is None else {"significant_digits": args.significant_digits}
    )
    exporter = (
        _exporter(
            args.export,
            **digits,
            fps=scene.fps,
            scene=scene.name,
            seed=scene.seed,
            overrides=scene.overrides,
        )
        if args.export
        else None
    )
    if output is not None and output.suffix == "":
        _clear_frames(output, overwrite=args.overwrite)
    # On a first run, a second process compiles the drawing kernels meanwhile: started
    # as early as it can be, before the renderer is made and the video opened.
    ahead = None
    if output is not None:
        ahead = CompileAhead.start(
            args.scene, seed=args.seed, overrides=args.overrides, resolution=resolution,
            check_finite=args.check_finite, first_run=first_run,
        )  # fmt: skip
    try:
        return _run_frames(args, scene, frames, output, resolution, still, exporter, ahead)
    finally:
        if ahead is not None:
            ahead.close()


def _run_frames(args, scene, frames, output, resolution, still, exporter, ahead) -> int:
    """``motes run``'s frames: simulated, drawn and written (see :func:`_run`)."""
    from ..finite import NonFiniteError
    from ..io.frames import open_writer
    from ..scene import SceneError
    from .progress import Progress

    if output is not None:
        scene.renderer(resolution)  # a frame that would not fit in memory fails here

    progress = Progress(frames, label=scene.name, enabled=not args.quiet)
    progress.begin()
    start = time.perf_counter()
    done = 0
    interrupted = False
    failure = None
    warned: set[str] = set()
    # An ExitStack closes every output even when closing another one fails (a second
    # Ctrl-C, an ffmpeg error): each keeps the frames finished so far.
    with contextlib.ExitStack() as outputs:
        signals = outputs.enter_context(terminate_as_interrupt())
        exr = output is not None and output.suffix.lower() == ".exr"
        writer = (
            outputs.enter_context(open_writer(output, fps=scene.fps, metadata=_record(scene)))
            if output and not exr
            else None
        )
        if exporter is not None:
            outputs.enter_context(exporter)
        outputs.callback(progress.close)
        try:
            # A .png or .exr keeps only the last frame: render just that one.
            for index in range(frames):
                scene.advance()
                drawn = writer is not None and (not still or index == frames - 1)
                if ahead is not None and (drawn or (exr and index == frames - 1)):
                    ahead.finish(lambda: scene.renderer(resolution).draw_particles(scene))
                    ahead = None
                if drawn:
                    writer.write(_picture(args, scene, resolution))
                if exr and index == frames - 1:
                    renderer = scene.renderer(resolution)
                    _write_exr(output, renderer, scene, None, alpha=args.alpha)
                if exporter is not None:
                    entries = scene.entries(surfaces=exporter.surfaces)
                    exporter.write_frame(scene.frame, scene.time, entries)
                done += 1
                progress.update(done)
                _warn_dropped(scene, warned)
        except KeyboardInterrupt:
            interrupted = True
        except SceneError as error:  # a body diverged, a surface spread too far
            failure = UserError(f"{error} (after {done} frames)")
        except NonFiniteError as error:
            failure = error  # reported once every output is closed
    if failure is not None:
        held = writer.frames_written if writer is not None else 0
        kept = f"; {output} holds the {held} frame{'s' * (held != 1)} before" if held else ""
        raise UserError(f"{failure}{kept}")
    if interrupted:
        # Ctrl-C can land after a frame reached the output and before it was counted
        # here: the writer's own count is what the file holds.
        held = writer.frames_written if writer is not None else 0
        kept = f"; {output} holds {held} frame{'s' * (held != 1)}" if held else ""
        how = "terminated" if signals["terminated"] else "interrupted"
        print(f"motes: {how} after {done} frames{kept}", file=sys.stderr)
        return 143 if signals["terminated"] else 130
    if not args.quiet:
        elapsed = time.perf_counter() - start
        counts = ", ".join(f"{k} {v}" for k, v in scene.counts().items())
        wrote = " and ".join(str(p) for p in (output, args.export) if p)
        print(f"{done} frames in {elapsed:.1f} s ({done / elapsed:.1f} fps); particles: {counts}")
        if wrote:
            print(f"wrote {wrote}")
        for name, system in scene.systems.items():
            if system.store.dropped:
                print(f"{name}: {system.store.dropped} births dropped at capacity")
    return 0
