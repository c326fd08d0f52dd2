"""``motes view SCENE_OR_CACHE``: watch and steer a simulation in the browser."""

from __future__ import annotations

import argparse
import sys
import threading
import webbrowser
from pathlib import Path

from .common import UserError, integer_from, terminate_as_interrupt

EXAMPLES = """\
examples:
  motes view fire                        simulate the fire, watch it in the browser
  motes view my_scene.toml --port 8090   a scene file (edit it, press Restart to reload)
  motes view run.h5                      play a cache back (motes run --export run.h5)
  motes view rain --no-browser --host 0.0.0.0   serve to other machines, open no browser

The page has play, pause, step, restart and a timeline back through the frames
simulated so far; the scene's numbers as sliders and fields (those marked ⟲ act at
restart, the others from the next step); and a button that saves them as a scene file.
Ctrl-C stops the viewer.
"""

#: Default port; taken, the next free one is used (an explicit --port is not moved).
DEFAULT_PORT = 8080
#: Cache files ``motes view`` plays back.
CACHE_SUFFIXES = (".h5", ".hdf5", ".npz")


def add_parser(sub) -> None:
    """The ``view`` subcommand's arguments."""
    view = sub.add_parser(
        "view",
        help="watch and steer a scene live in the browser, or play a cache back",
        description="Simulate SCENE (a built-in name or a .toml file) and show it live in the "
        "browser, or play back a particle cache (.h5, .npz).",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    view.add_argument("scene", metavar="SCENE_OR_CACHE", help="built-in scene, .toml file or cache")
    view.add_argument(
        "--port", type=integer_from(0), metavar="P",
        help=f"port to serve on (default {DEFAULT_PORT}, or the next free one; 0: any free port)",
    )  # fmt: skip
    view.add_argument(
        "--host", default="127.0.0.1",
        help="address to listen on (default 127.0.0.1: this machine only; 0.0.0.0: every "
        "network the machine is on)",
    )  # fmt: skip
    view.add_argument("--no-browser", action="store_true", help="do not open a browser")
    view.add_argument("--seed", type=integer_from(0), metavar="S", help="random seed")
    view.add_argument(
        "--set", action="append", default=[], dest="overrides", metavar="KEY=VALUE",
        help="set a value of the scene file, as motes run --set (repeatable)",
    )  # fmt: skip
    view.add_argument(
        "--history", type=integer_from(16), default=1024, metavar="MB",
        help="memory for the frames kept to scrub back through (default 1024 MB; the "
        "oldest are let go past it)",
    )  # fmt: skip
    view.add_argument(
        "--max-points", type=integer_from(1000), default=1_000_000, metavar="N",
        help="particles sent per frame at most; more are thinned by a stride (default 1000000)",
    )  # fmt: skip


def run(args) -> int:
    """``motes view``: serve until Ctrl-C (exit status 0) or a startup error (2)."""
    try:
        import viser  # noqa: F401
    except ImportError:
        raise UserError("motes view needs viser: pip install 'motes[view]'") from None
    from ..view.server import Viewer, ViewError

    source, error = _source(args)
    source.max_points = args.max_points
    port = args.port if args.port is not None else _free_from(args.host, DEFAULT_PORT)
    try:
        viewer = Viewer(source, host=args.host, port=port, log=_log, error=error)
    except ViewError as problem:
        raise UserError(str(problem)) from None
    print(f"motes view: serving {viewer.url} (Ctrl-C stops)", flush=True)
    if not args.no_browser:
        threading.Thread(target=webbrowser.open, args=(viewer.url,), daemon=True).start()
    stopped = threading.Event()
    with terminate_as_interrupt():
        viewer.start()
        try:
            while not stopped.wait(0.5):
                pass
        except KeyboardInterrupt:
            pass
        finally:
            viewer.stop()
    print("motes view: stopped", file=sys.stderr)
    return 0


def _log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _source(args):
    """The source to show and, for a scene file that does not load, its error (the
    viewer starts anyway and shows it; Restart reads the file again)."""
    from ..scene import SceneError
    from ..scene.overrides import parse_assignment
    from ..view.sources import LiveSource

    path = Path(args.scene)
    if path.suffix.lower() in CACHE_SUFFIXES:
        return _cache_source(args, path), None
    try:
        overrides = dict(parse_assignment(text) for text in args.overrides)
    except SceneError as error:
        raise UserError(str(error)) from None
    source = LiveSource(args.scene, seed=args.seed, overrides=overrides,
                        history=args.history << 20)  # fmt: skip
    try:
        source.restart()
    except SceneError as error:
        if path.suffix.lower() == ".toml" and path.is_file():
            print(f"motes view: the scene did not load: {error}", file=sys.stderr)
            return source, str(error)
        raise UserError(str(error)) from None
    return source, None


def _cache_source(args, path: Path):
    from ..io.cache import load_cache
    from ..scene import SceneError
    from ..scene.replay import Replay, ReplayError, load_for
    from ..view.sources import CacheSource

    if args.overrides or args.seed is not None:
        raise UserError("--set and --seed change a simulation; a cache plays as it was made")
    try:
        cache = load_cache(path)
    except FileNotFoundError:
        raise UserError(f"no such cache: {path}") from None
    except (ValueError, OSError) as error:
        raise UserError(str(error)) from None
    try:
        replay = Replay(load_for(cache), cache)
    except (SceneError, ReplayError, OSError) as error:
        # shown as it is: particles, meshes and curves without the scene's looks
        print(f"motes view: drawing the cache without its scene ({error})", file=sys.stderr)
        replay = None
    return CacheSource(cache, replay)


def _free_from(host: str, port: int) -> int:
    """``port``, or the next free one above it."""
    from ..view.server import ViewError, check_port

    for candidate in range(port, port + 100):
        try:
            return check_port(host, candidate)
        except ViewError:
            continue
    return 0
