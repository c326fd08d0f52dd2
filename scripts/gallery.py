"""Render the gallery: a still and an animated GIF of every built-in scene.

    python scripts/gallery.py [--only NAME ...] [--out docs/gallery]

Writes ``NAME.png`` (the frame at ``--still-at`` of the run, 640×360) and ``NAME.gif``
(every third frame, 256×144) for each scene, and ``docs/gallery/README.md`` with the
particle counts (with ``--only``, the other scenes' sections are kept). Everything is
seeded, so the same machine gives the same files.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from motes.io.frames import open_writer, save_image
from motes.scene import builtin_scenes, load_scene

ROOT = Path(__file__).resolve().parent.parent
#: Where in the run each still is taken (fraction of the frames), where 0.6 misses the
#: moment that shows the effect.
STILL_AT = {
    "explosion": 0.14,
    "galaxies": 0.65,
    "fireworks": 0.5,
    "curtain": 0.85,
    "hair": 0.35,
    "ragdoll_stairs": 0.2,
    "starlings": 0.9,
    "fish_school": 0.5,
}


def render_scene(name: str, out: Path, *, still_at: float, still_size, gif_size, gif_stride):
    scene = load_scene(name)
    frames = scene.frame_count
    still_frame = min(frames, max(1, round(still_at * frames)))
    gif_fps = scene.fps / gif_stride
    start = time.perf_counter()
    with open_writer(out / f"{name}.gif", fps=gif_fps) as gif:
        for frame in range(1, frames + 1):
            scene.advance()
            if frame == still_frame:
                save_image(out / f"{name}.png", scene.render(still_size))
            if frame % gif_stride == 0:
                gif.write(scene.render(gif_size))
    return scene, still_frame, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="*", help="scene names (default: all built-in)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "gallery")
    parser.add_argument(
        "--still-at",
        type=float,
        default=None,
        help="fraction of the run for every still (default: 0.6, or the scene's STILL_AT)",
    )
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    scenes = builtin_scenes()
    rows = []
    for name in args.only or scenes:
        scene, still_frame, seconds = render_scene(
            name,
            args.out,
            still_at=args.still_at if args.still_at is not None else STILL_AT.get(name, 0.6),
            still_size=(640, 360),
            gif_size=(256, 144),
            gif_stride=3,
        )
        counts = ", ".join(f"{k} {v}" for k, v in scene.counts().items())
        print(f"{name:10s} {scene.frame_count:4d} frames  {seconds:6.1f} s  {counts}")
        rows.append((name, scenes[name], still_frame, scene.frame_count, counts))
    write_index(args.out, rows, scenes)


def write_index(out: Path, rows, scenes) -> None:
    """Write ``README.md``: the sections of ``rows``, and the other built-in scenes' kept."""
    sections = _sections(out / "README.md")
    for name, description, still_frame, frames, counts in rows:
        sections[name] = [
            f"## {name}",
            "",
            description,
            "",
            f"![{name}]({name}.png) ![{name} animated]({name}.gif)",
            "",
            f"Still: frame {still_frame} of {frames}. Live particles at the end: {counts}.",
            "",
        ]
    lines = [
        "# Gallery",
        "",
        "Every built-in scene, rendered by `python scripts/gallery.py` (stills 640×360,",
        "animations 256×144 at a third of the frame rate). Run any of them at full size with",
        "`motes run NAME`.",
        "",
    ]
    for name in sorted(sections):
        if name in scenes:
            lines += sections[name]
    (out / "README.md").write_text("\n".join(lines).rstrip("\n") + "\n")


def _sections(index: Path) -> dict[str, list[str]]:
    """The per-scene sections of an existing index, by scene name."""
    if not index.exists():
        return {}
    sections: dict[str, list[str]] = {}
    current = None
    for line in index.read_text().splitlines():
        if line.startswith("## "):
            current = line[3:].strip()
            sections[current] = []
        if current is not None:
            sections[current].append(line)
    return sections


if __name__ == "__main__":
    main()
