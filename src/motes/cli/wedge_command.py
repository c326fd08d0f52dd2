"""``motes wedge SCENE --set KEY=V1,V2 -o DIR``: every combination, simulated and drawn."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from .common import UserError, dask_options, integer_from, resolution, terminate_as_interrupt

EXAMPLES = """\
examples:
  motes wedge fire --set system.flame.emitter.0.rate.rate=6000,12000,24000 -o wedge/
  motes wedge rain --set scene.seed=1,2 --set system.drops.emitter.0.rate.rate=1500,3000 -o w/
  motes wedge my_scene.toml --set 'camera.position=[0, 2, 8],[4, 2, 6]' --format png -o w/
  motes wedge fire --set scene.seed=1,2,3,4 -o wedge/ --workers 2    on a local Dask cluster

Each variant is DIR/NN_KEY-VALUE....mp4 with a still of its last frame beside it;
DIR/contact_sheet.png shows them all, labelled; DIR/wedge.json records each one's
values and, for one that failed, why. Variants already in DIR are kept (run again to
resume); a failed variant does not stop the others, and the exit status is then 1.
"""


def add_parser(sub) -> None:
    """The ``wedge`` subcommand's arguments."""
    wedge = sub.add_parser(
        "wedge",
        help="run a scene for every combination of a few values, with a contact sheet",
        description="Simulate and draw SCENE once for every combination of the values given "
        "with --set KEY=V1,V2,... (as motes run --set, with several values), each into its "
        "own file named by its values, then a labelled contact sheet of their last frames.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    wedge.add_argument("scene", metavar="SCENE", help="built-in scene name or scene .toml file")
    wedge.add_argument(
        "--set",
        dest="axes",
        action="append",
        required=True,
        metavar="KEY=V1,V2,...",
        help="a key and its values, comma-separated (commas inside [..] or quotes belong to "
        "the value); repeatable: every combination is run; one value sets it in every variant",
    )
    wedge.add_argument("-o", "--output", metavar="DIR", required=True, help="the wedge's folder")
    wedge.add_argument(
        "--frames",
        type=integer_from(1),
        metavar="N",
        help="frames per variant (default: the scene's)",
    )
    wedge.add_argument(
        "--resolution", type=resolution, metavar="WxH", help="image size (default: the scene's)"
    )
    wedge.add_argument("--seed", type=integer_from(0), help="random seed (default: the scene's)")
    wedge.add_argument(
        "--format",
        choices=("mp4", "gif", "png"),
        default="mp4",
        help="each variant as a video, a GIF or a still of its last frame (default: mp4)",
    )
    wedge.add_argument(
        "--overwrite", action="store_true", help="run again the variants already in DIR"
    )
    dask_options(
        wedge,
        workers="run the variants on a local Dask cluster of N single-threaded processes",
        scheduler="run the variants on a running Dask cluster, e.g. tcp://host:8786 (its "
        "workers need motes and must see DIR)",
    )
    wedge.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")


def run(args) -> int:
    """``motes wedge``: check everything, run the variants, report each one."""
    from ..scene import SceneError, load_scene
    from ..scene.farm import FarmError
    from ..scene.wedge import WedgeError, parse_axes, variants
    from .progress import Progress

    try:
        axes = parse_axes(args.axes)
    except WedgeError as error:
        raise UserError(str(error)) from None
    try:
        load_scene(args.scene, seed=args.seed)  # the scene exists and reads
    except SceneError as error:
        raise UserError(str(error)) from None
    except OSError as error:
        raise UserError(f"cannot read {args.scene}: {error.strerror}") from None
    if args.workers is not None or args.scheduler is not None:
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise UserError(
                "running on Dask needs the distributed package: pip install 'motes[farm]'"
            ) from None
    folder = Path(args.output)
    if folder.exists() and not folder.is_dir():
        raise UserError(f"-o must be a folder; {folder} is a file")
    if not folder.resolve().parent.is_dir():
        raise UserError(f"the folder above {folder} does not exist")
    every = variants(axes)
    if args.overwrite and folder.is_dir():
        for variant in every:
            for suffix in (".png", f".{args.format}"):
                (folder / f"{variant.name}{suffix}").unlink(missing_ok=True)
    progress = Progress(len(every), label=f"wedge {Path(args.scene).stem}", enabled=not args.quiet)
    progress.begin()
    start = time.perf_counter()
    # The scene is given by the path the user typed: make it absolute for the workers.
    scene = args.scene
    if Path(scene).suffix.lower() == ".toml":
        scene = str(Path(scene).resolve())
    try:
        with terminate_as_interrupt():
            records = _run_wedge(args, scene, axes, folder, progress)
    except KeyboardInterrupt:
        progress.close()
        print(
            f"motes: interrupted; the variants finished are in {folder} (run again to resume)",
            file=sys.stderr,
        )
        return 130
    except (FarmError, WedgeError) as error:
        progress.close()
        raise UserError(str(error)) from None
    progress.close()
    failed = [r for r in records if r["status"] != "ok"]
    if not args.quiet:
        elapsed = time.perf_counter() - start
        width = max(len(r["label"]) for r in records)
        for record in records:
            if record["status"] == "ok":
                how = "kept" if record.get("resumed") else f"{record['seconds']:.2f} s"
                print(f"  {record['index']:>3}  {record['label']:<{width}}  ok ({how})")
            else:
                print(
                    f"  {record['index']:>3}  {record['label']:<{width}}  FAILED: {record['error']}"
                )
        print(
            f"{len(records) - len(failed)} of {len(records)} variants in {elapsed:.1f} s; "
            f"wrote {folder / 'contact_sheet.png'} and {folder / 'wedge.json'}"
        )
    for record in failed:
        print(f"motes: variant {record['label']} failed: {record['error']}", file=sys.stderr)
    return 1 if failed else 0


def _run_wedge(args, scene: str, axes: dict, folder: Path, progress) -> list[dict]:
    from ..scene.wedge import run_wedge

    return run_wedge(
        scene, axes, folder, seed=args.seed, frames=args.frames, resolution=args.resolution,
        fmt=args.format, workers=args.workers, scheduler=args.scheduler,
        progress=progress.update,
    )  # fmt: skip
