"""The ``.npz`` particle cache as an exporter, so ``--export`` takes it like the others.

A thin adapter over :class:`~motes.io.cache.CacheWriter` (the format is described in
``docs/cache-format.md``): the cache keeps every frame in memory and writes the file when
closed. It records faces, curves and body transforms, not liquid surfaces (a surface is
rebuilt from the particles).
"""

from __future__ import annotations

from ..cache import CacheWriter
from ..entry import Entry
from .base import ExportWriter


class CacheExport(ExportWriter):
    """Frames into a ``.npz`` particle cache."""

    suffixes = (".npz",)
    surfaces = False

    def __init__(self, path, **options):
        super().__init__(path, **options)
        self.cache = CacheWriter(
            self.path, scene=self.scene, seed=self.seed, fps=self.fps, overrides=self.overrides
        )

    def _write(self, frame: int, time: float, entries: dict[str, Entry]) -> None:
        self.cache.add_frame(time, entries)

    def _finish(self) -> None:
        self.cache.close()
