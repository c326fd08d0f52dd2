"""Exports that other tools read: OpenUSD, VTK (ParaView), PLY, Houdini ``.geo``, ``.npz``.

:func:`writer_for` chooses the writer by the output's extension:

===========================  ===========================================  =============
output                       what is written                              needs
===========================  ===========================================  =============
``run.h5``, ``run.npz``      the particle cache (docs/cache-format.md)    nothing more
``run.usd``, ``.usda``,      one time-sampled USD stage                   ``motes[usd]``
``.usdc``                    (:mod:`~motes.io.export.usd`)                (usd-core)
``run.pvd``                  a ParaView collection of per-frame ``.vtp``  ``motes[vtk]``
                             files in ``run/`` (:mod:`~.vtk`)             (vtk)
``drops.####.ply``           per-frame binary PLY (:mod:`~.ply`)          ``motes[ply]``
                                                                          (plyfile)
``drops.####.geo``           per-frame Houdini ASCII geometry             nothing more
                             (:mod:`~.geo`)
===========================  ===========================================  =============

Every writer takes frames one at a time (:meth:`~base.ExportWriter.write_frame`), per
entry an :class:`~motes.io.entry.Entry` (particles, and a cloth's faces, hair's curves,
a rigid world's body transforms, a liquid's surface), and names attributes by the one
map of :mod:`~motes.io.export.attributes`. The heavy packages are imported when a writer
is made, so a missing one is reported (:class:`ExportError`, naming the extra to
install) before anything is simulated. :func:`export_cache` replays a cache through the
same writers (``motes export CACHE OUT``).

Examples
--------
>>> with writer_for("run.usdc", fps=30, scene="fire") as out:  # doctest: +SKIP
...     for _ in range(60):
...         scene.advance()
...         out.write_frame(scene.frame, scene.time, scene.entries())
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .base import FRAME_MARK, ExportError, ExportWriter, frame_path

__all__ = [
    "FORMATS",
    "FRAME_MARK",
    "ExportError",
    "ExportWriter",
    "export_cache",
    "frame_path",
    "writer_for",
]

#: Suffix -> (module, class) of its writer; modules are imported on use.
FORMATS: dict[str, tuple[str, str]] = {
    ".h5": ("cache", "CacheExport"),
    ".hdf5": ("cache", "CacheExport"),
    ".npz": ("cache", "CacheExport"),
    ".usd": ("usd", "UsdWriter"),
    ".usda": ("usd", "UsdWriter"),
    ".usdc": ("usd", "UsdWriter"),
    ".pvd": ("vtk", "VtkWriter"),
    ".ply": ("ply", "PlyWriter"),
    ".geo": ("geo", "GeoWriter"),
}


def writer_class(path) -> type[ExportWriter]:
    """The writer class for ``path``'s extension; :class:`ExportError` for another."""
    import importlib

    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        known = ", ".join(FORMATS)
        raise ExportError(
            f"cannot export to {Path(path).name}: the extension must be one of {known} "
            "(.ply and .geo with #### for the frame number)"
        )
    module, name = FORMATS[suffix]
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)


def writer_for(
    path,
    *,
    fps: float,
    scene: str | None = None,
    seed: int | None = None,
    overrides: Mapping[str, object] | None = None,
    **options,
) -> ExportWriter:
    """The writer for ``path``, chosen by its extension (see the module docstring).

    ``options`` go to the writer's class (``significant_digits`` for an ``.h5`` cache).

    Raises
    ------
    ExportError
        For an unknown extension, a per-frame format without ``####`` in the name (or
        ``####`` in a one-file format), a folder that does not exist, or a missing
        optional package (the message names ``pip install 'motes[EXTRA]'``).
    """
    cls = writer_class(path)
    return cls(path, fps=fps, scene=scene, seed=seed, overrides=overrides, **options)


def frame_numbers(times: np.ndarray, fps: float) -> np.ndarray:
    """Frame numbers of a cache's ``times`` [s] at ``fps``: ``round(time * fps)``, which
    gives back the numbers ``motes run`` used (frame ``f`` is at ``f / fps``)."""
    numbers = np.rint(np.asarray(times, dtype=np.float64) * fps).astype(np.int64)
    if len(numbers) > 1 and np.any(np.diff(numbers) <= 0):
        raise ExportError(
            f"the cache's frame times do not give increasing frame numbers at {fps:g} fps; "
            "give the frame rate they were recorded at with --fps"
        )
    return numbers


def export_cache(cache, writer: ExportWriter, *, progress=None) -> int:
    """Write every frame of ``cache`` (a :class:`~motes.io.cache.Cache`) with ``writer``.

    Frame numbers come from the frame times at the writer's fps (:func:`frame_numbers`);
    each entry keeps the faces, curves and body transforms the cache recorded. Returns
    the number of frames written; ``progress(done)`` is called after each.
    """
    numbers = frame_numbers(cache.times, writer.fps)
    for index, (number, time) in enumerate(zip(numbers, cache.times, strict=True)):
        entries = {name: cache.entry(index, name) for name in cache.names}
        writer.write_frame(int(number), float(time), entries)
        if progress is not None:
            progress(index + 1)
    return len(numbers)
