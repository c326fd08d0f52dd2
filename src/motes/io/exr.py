"""OpenEXR stills: the frame in linear light (half float) and its depth, for compositing.

``motes run SCENE -o still.exr`` writes the last frame as OpenEXR through the Academy
Software Foundation's own Python binding (the ``OpenEXR`` package, the extra
``motes[exr]``, imported when an ``.exr`` is asked for): channels ``R``, ``G``, ``B`` in
half float, scene-referred linear radiance times the scene's exposure, before tone
mapping (values above 1 kept: a compositor grades them), and ``Z`` in float32, the view
depth [m] of the nearest opaque surface (infinite where there is none, as OpenEXR's
depth convention has it). ZIP compression. The metadata (scene, source, seed, motes
version) is a ``motes`` string attribute of the header holding a JSON object.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ._atomic import replacing

#: The extra that installs the binding.
EXTRA = "exr"


class ExrUnavailable(ImportError):
    """The ``OpenEXR`` package is not installed (the message says how to install it)."""


def _openexr():
    try:
        import OpenEXR
    except ImportError:
        raise ExrUnavailable(
            f"writing .exr needs the OpenEXR package: pip install 'motes[{EXTRA}]'"
        ) from None
    return OpenEXR


def check_available() -> None:
    """Raise :class:`ExrUnavailable` unless ``.exr`` files can be written."""
    _openexr()


def write_exr(
    path, color: np.ndarray, depth: np.ndarray | None = None, metadata=None, alpha=None
) -> None:
    """Write ``color`` ((h, w, 3) linear RGB, stored as half float), ``depth`` ((h, w)
    [m], stored as float32 ``Z``) and ``alpha`` ((h, w) coverage, half float ``A``; the
    colour premultiplied by it, as OpenEXR's convention has it) to the OpenEXR file
    ``path``, atomically.

    Values beyond half float's range (65504) are stored as infinity, so clip first what
    must stay finite.
    """
    OpenEXR = _openexr()
    color = np.asarray(color)
    if color.ndim != 3 or color.shape[2] != 3:
        raise ValueError(f"color must have shape (height, width, 3), got {color.shape}")
    channels = {"RGB": np.ascontiguousarray(color, dtype=np.float16)}
    if alpha is not None:
        alpha = np.asarray(alpha)
        if alpha.shape != color.shape[:2]:
            raise ValueError(f"alpha must have shape {color.shape[:2]}, got {alpha.shape}")
        rgba = np.concatenate([color, alpha[..., None]], axis=2)
        channels = {"RGBA": np.ascontiguousarray(rgba, dtype=np.float16)}
    if depth is not None:
        depth = np.asarray(depth)
        if depth.shape != color.shape[:2]:
            raise ValueError(f"depth must have shape {color.shape[:2]}, got {depth.shape}")
        channels["Z"] = np.ascontiguousarray(depth, dtype=np.float32)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    if metadata:
        header["motes"] = json.dumps(dict(metadata))
    path = Path(path)
    with replacing(path) as tmp, OpenEXR.File(header, channels) as exr:
        exr.write(str(tmp))


def read_exr(path) -> tuple[np.ndarray, np.ndarray | None, dict]:
    """``(color, depth, metadata)`` of an OpenEXR file written by :func:`write_exr`:
    (h, w, 3) float32 (or (h, w, 4), premultiplied RGBA, for one with alpha), (h, w)
    float32 or None, and the ``motes`` header record."""
    OpenEXR = _openexr()
    with OpenEXR.File(str(path)) as exr:
        channels = exr.channels()
        record = exr.header().get("motes")
        key = "RGBA" if "RGBA" in channels else "RGB"
        color = np.asarray(channels[key].pixels, dtype=np.float32)
        depth = np.asarray(channels["Z"].pixels, dtype=np.float32) if "Z" in channels else None
    return color, depth, json.loads(record) if record else {}
