"""Wedges: a scene run for every combination of a few values of its keys, side by side.

``motes wedge SCENE --set KEY=V1,V2,V3 [--set KEY2=...] -o DIR`` makes one variant per
combination of the values (the Cartesian product, the first key varying slowest), and
for each simulates the scene with those values set over it (as ``motes run --set``
does) and draws it to ``DIR/NAME.mp4`` (or ``.gif``, or a ``.png`` of the last frame),
beside a ``DIR/NAME.png`` of its last frame. ``NAME`` is the variant's number and its
values (``01_system.flame.capacity-4000_scene.seed-2``). Then ``DIR/contact_sheet.png``
shows every variant's last frame, labelled with its values, and ``DIR/wedge.json``
records each variant's values, files, time and, for one that failed, why.

A variant that fails (a value the scene refuses, a simulation that diverges) is
reported and the others go on. Variants already in ``DIR`` are kept, so a wedge that was
interrupted resumes where it stopped. Variants run one after another in this process,
or as tasks on Dask (:func:`~motes.scene.farm.dask_client`: a local cluster of
single-threaded processes, or a running cluster), each on one Numba thread; drawing
does not depend on the thread count, so the files are the same either way.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io._atomic import replacing
from ..io.frames import _save_png
from .overrides import parse_value
from .schema import SceneError

#: The contact sheet's and the summary's file names in the wedge's folder.
SHEET = "contact_sheet.png"
SUMMARY = "wedge.json"
#: Output formats of a variant: a video, a looping GIF, or a still of the last frame.
FORMATS = ("mp4", "gif", "png")
#: Width of a tile of the contact sheet [px]; its height follows the frames' aspect.
TILE_WIDTH = 320


class WedgeError(ValueError):
    """A wedge that cannot run as asked: the message is one line for the user."""


@dataclass(frozen=True)
class Variant:
    """One combination of values: ``overrides`` (key path -> value, all of them),
    ``label`` (the varied keys and values, for people) and ``name`` (a file stem)."""

    index: int
    overrides: dict
    label: str
    name: str


def split_values(text: str) -> list[str]:
    """The comma-separated values of ``V1,V2,...``; commas inside brackets, braces or
    quotes belong to a value (``[0, 1, 0],[1, 0, 0]`` is two arrays)."""
    values, depth, quote, start = [], 0, None, 0
    for k, char in enumerate(text):
        if quote is not None:
            quote = None if char == quote else quote
        elif char in "\"'":
            quote = char
        elif char in "[{":
            depth += 1
        elif char in "]}":
            depth -= 1
        elif char == "," and depth == 0:
            values.append(text[start:k].strip())
            start = k + 1
    values.append(text[start:].strip())
    return values


def parse_axes(assignments: Sequence[str]) -> dict[str, list]:
    """``["KEY=V1,V2", ...]`` as ``{key: [value, ...]}`` (values parsed as TOML, as
    ``motes run --set`` parses them), keys in the order given."""
    axes: dict[str, list] = {}
    for text in assignments:
        key, sep, values = text.partition("=")
        key = key.strip()
        if not sep or not key:
            raise WedgeError(f"--set takes KEY=V1,V2,... (like scene.seed=1,2,3), got {text!r}")
        if key in axes:
            raise WedgeError(f"--set gives {key} twice; give all its values in one --set")
        parts = split_values(values)
        if any(part == "" for part in parts):
            raise WedgeError(f"--set {key}: an empty value in {values!r}")
        axes[key] = [parse_value(part) for part in parts]
    if not axes:
        raise WedgeError("a wedge needs at least one --set KEY=V1,V2,...")
    return axes


def _shown(value) -> str:
    """A value as written in a label: TOML-like, without quotes around text."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, list):
        return "[" + ", ".join(map(_shown, value)) + "]"
    return str(value)


def _stem(text: str) -> str:
    """``text`` as a plain file-name part (letters, digits, ``.``, ``-``, ``_``)."""
    cleaned = "".join(c if c.isalnum() or c in ".-" else "_" for c in text).strip("._")
    return cleaned or "value"


def variants(axes: dict[str, list]) -> list[Variant]:
    """Every combination of the axes' values, the first key varying slowest. Keys given
    one value are set in every variant and left out of the labels and names."""
    varied = [key for key, values in axes.items() if len(values) > 1]
    combos = list(itertools.product(*axes.values()))
    width = len(str(len(combos) - 1))
    out = []
    for index, combo in enumerate(combos):
        overrides = dict(zip(axes, combo, strict=True))
        shown = [(key, _shown(overrides[key])) for key in varied]
        label = ", ".join(f"{key}={value}" for key, value in shown) or "as given"
        name = "_".join([f"{index:0{width}d}", *(f"{_stem(k)}-{_stem(v)}" for k, v in shown)])
        out.append(Variant(index, overrides, label, name))
    return out


def run_variant(
    variant: Variant,
    *,
    scene: str,
    fixed: dict,
    seed: int | None,
    frames: int | None,
    resolution: tuple[int, int] | None,
    folder: str,
    fmt: str,
    threads: int | None = None,
) -> dict:
    """Simulate and draw one variant into ``folder`` (a task, here or on a worker).

    Returns the variant's record for the summary: its values and label, ``"ok"`` with
    the files and seconds taken, or ``"failed"`` with the error's message. Only
    ``KeyboardInterrupt`` leaves it.
    """
    from ..finite import NonFiniteError
    from ..io.frames import open_writer
    from .scene import load_scene

    if threads is not None:
        import numba

        numba.set_num_threads(threads)
    record = {"index": variant.index, "label": variant.label, "values": variant.overrides}
    out = Path(folder)
    video, still = out / f"{variant.name}.{fmt}", out / f"{variant.name}.png"
    start = time.perf_counter()
    try:
        values = {**fixed, **variant.overrides}
        loaded = load_scene(scene, seed=seed, overrides=values, check_finite=True)
        count = frames or loaded.frame_count
        size = resolution or loaded.camera.resolution
        loaded.renderer(size)  # a frame that would not fit in memory fails here
        last = None
        writer = None if fmt == "png" else open_writer(video, fps=loaded.fps)
        with writer if writer is not None else contextlib.nullcontext():
            for index in range(count):
                loaded.advance()
                if writer is not None or index == count - 1:
                    last = loaded.render(size)
                if writer is not None:
                    writer.write(last)
        _save_png(still, last, {"scene": loaded.name, "wedge": variant.label})
    except (SceneError, NonFiniteError, MemoryError, ValueError, OSError) as error:
        return record | {"status": "failed", "error": str(error)}
    except Exception as error:  # one variant's failure must not stop the rest
        return record | {"status": "failed", "error": f"{type(error).__name__}: {error}"}
    files = [still.name] if fmt == "png" else [video.name, still.name]
    seconds = time.perf_counter() - start
    return record | {"status": "ok", "files": files, "frames": count, "seconds": seconds}


def done(variant: Variant, folder: Path, fmt: str) -> bool:
    """Whether ``variant``'s files are already in ``folder`` (a resumed wedge)."""
    files = [folder / f"{variant.name}.png"]
    if fmt != "png":
        files.append(folder / f"{variant.name}.{fmt}")
    return all(path.is_file() for path in files)


def run_wedge(
    scene: str,
    axes: dict[str, list],
    folder: Path,
    *,
    fixed: dict | None = None,
    seed: int | None = None,
    frames: int | None = None,
    resolution: tuple[int, int] | None = None,
    fmt: str = "mp4",
    workers: int | None = None,
    scheduler: str | None = None,
    client=None,
    progress: Callable[[int], None] | None = None,
) -> list[dict]:
    """Run every variant of ``axes`` not yet in ``folder``; write the contact sheet and
    the summary; return the variants' records (in order).

    ``workers``, ``scheduler`` or ``client`` run the variants on Dask
    (:func:`~motes.scene.farm.dask_client`); otherwise they run here, one after another.
    ``progress`` is called with the count of variants finished (or found finished).
    """
    if fmt not in FORMATS:
        raise WedgeError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    folder.mkdir(parents=True, exist_ok=True)
    every = variants(axes)
    todo = [v for v in every if not done(v, folder, fmt)]
    finished = len(every) - len(todo)
    if progress is not None:
        progress(finished)
    options = {"scene": scene, "fixed": dict(fixed or {}), "seed": seed, "frames": frames,
               "resolution": resolution, "folder": str(folder.resolve()), "fmt": fmt}  # fmt: skip
    records: dict[int, dict] = {}
    if workers is None and scheduler is None and client is None:
        for variant in todo:
            records[variant.index] = run_variant(variant, **options)
            finished += 1
            if progress is not None:
                progress(finished)
    else:
        from distributed import as_completed

        from .farm import dask_client

        with dask_client(workers=workers, scheduler=scheduler, client=client) as connected:
            futures = connected.map(run_variant, todo, **options, threads=1, pure=False)
            for future in as_completed(futures):
                record = future.result()
                records[record["index"]] = record
                finished += 1
                if progress is not None:
                    progress(finished)
    for variant in every:
        if variant.index not in records:  # done by an earlier run
            files = [f"{variant.name}.png"] + ([] if fmt == "png" else [f"{variant.name}.{fmt}"])
            records[variant.index] = {"index": variant.index, "label": variant.label,
                                      "values": variant.overrides, "status": "ok",
                                      "files": files[::-1], "resumed": True}  # fmt: skip
    ordered = [records[v.index] for v in every]
    title = f"{Path(scene).stem}: {len(every)} variants"
    if frames is not None:
        title += f", last of {frames} frames"
    contact_sheet(every, ordered, folder, title=title)
    summary = {"scene": scene, "axes": axes, "fixed": dict(fixed or {}), "seed": seed,
               "frames": frames, "format": fmt, "variants": ordered}  # fmt: skip
    with replacing(folder / SUMMARY) as tmp:
        Path(tmp).write_text(json.dumps(summary, indent=2, default=str) + "\n")
    return ordered


def contact_sheet(
    every: Sequence[Variant], records: Sequence[dict], folder: Path, *, title: str
) -> Path:
    """``folder/contact_sheet.png``: each variant's last frame in a grid, labelled with
    its values; a failed variant's tile says why."""
    from PIL import Image, ImageDraw, ImageFont

    stills = {}
    for variant, record in zip(every, records, strict=True):
        path = folder / f"{variant.name}.png"
        if record["status"] == "ok" and path.is_file():
            with Image.open(path) as image:
                stills[variant.index] = image.convert("RGB")
    aspect = 9 / 16
    if stills:
        first = next(iter(stills.values()))
        aspect = first.height / first.width
    tile_w = TILE_WIDTH
    tile_h = max(1, round(tile_w * aspect))
    font = ImageFont.load_default(size=13)
    line = 18
    label_h = 2 * line + 6
    columns = math.ceil(math.sqrt(len(every)))
    if len(axes_sizes := [n for n in _axis_sizes(every) if n > 1]) >= 2 and axes_sizes[-1] <= 8:
        columns = axes_sizes[-1]  # a table: the last key's values across, the rest down
    rows = math.ceil(len(every) / columns)
    pad, head = 8, 30
    width = pad + columns * (tile_w + pad)
    height = head + rows * (tile_h + label_h + pad) + pad
    sheet = Image.new("RGB", (width, height), (24, 24, 27))
    draw = ImageDraw.Draw(sheet)
    draw.text((pad, 8), title, fill=(235, 235, 235), font=ImageFont.load_default(size=15))
    for slot, (variant, record) in enumerate(zip(every, records, strict=True)):
        x = pad + (slot % columns) * (tile_w + pad)
        y = head + (slot // columns) * (tile_h + label_h + pad)
        still = stills.get(variant.index)
        if still is not None:
            sheet.paste(still.resize((tile_w, tile_h), Image.Resampling.LANCZOS), (x, y))
            colour = (235, 235, 235)
            text = variant.label
        else:
            draw.rectangle((x, y, x + tile_w - 1, y + tile_h - 1), fill=(60, 20, 20))
            for k, part in enumerate(_wrap(f"failed: {record.get('error', '')}", 44)[:6]):
                draw.text((x + 6, y + 6 + k * line), part, fill=(255, 170, 160), font=font)
            colour = (255, 140, 130)
            text = f"{variant.label} (failed)"
        for k, part in enumerate(_wrap(f"{variant.index}: {text}", 46)[:2]):
            draw.text((x, y + tile_h + 4 + k * line), part, fill=colour, font=font)
    path = folder / SHEET
    _save_png(path, np.asarray(sheet), {"wedge": title})
    return path


def _axis_sizes(every: Sequence[Variant]) -> list[int]:
    """How many values each key takes across the variants, in the keys' order."""
    if not every:
        return []
    keys = list(every[0].overrides)
    return [len({json.dumps(v.overrides[k], default=str) for v in every}) for k in keys]


def _wrap(text: str, width: int) -> list[str]:
    """``text`` cut into lines of at most ``width`` characters, at spaces where it can."""
    import textwrap

    return textwrap.wrap(text, width, break_long_words=True) or [""]
