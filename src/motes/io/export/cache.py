"""The particle cache as an exporter, so ``--export`` takes it like the others.

A thin adapter over :class:`~motes.io.cache.CacheWriter` (the format is described in
``docs/cache-format.md``): ``.h5`` (streamed, compressed) or ``.npz`` (spooled to disk,
written when closed). It records faces, curves, body transforms and the surfaces of
liquids drawn as surfaces (the scene makes each surface once a frame for drawing and
exporting alike).
"""

from __future__ import annotations

from ..cache import CacheWriter
from ..entry import Entry
from .base import ExportError, ExportWriter


class CacheExport(ExportWriter):
    """Frames into a particle cache (``.h5``, ``.hdf5`` or ``.npz``).

    ``significant_digits`` (``.h5`` only) keeps that many significant decimal digits of
    every floating-point attribute: lossy, and smaller (see :class:`CacheWriter`).
    """

    suffixes = (".h5", ".hdf5", ".npz")
    surfaces = True

    def __init__(self, path, *, significant_digits: int | None = None, **options):
        super().__init__(path, **options)
        try:
            self.cache = CacheWriter(
                self.path,
                significant_digits=significant_digits,
                scene=self.scene,
                seed=self.seed,
                fps=self.fps,
                overrides=self.overrides,
            )
        except (TypeError, ValueError) as error:
            raise ExportError(str(error)) from None

    def _write(self, frame: int, time: float, entries: dict[str, Entry]) -> None:
        self.cache.add_frame(time, entries)

    def _finish(self) -> None:
        self.cache.close()
