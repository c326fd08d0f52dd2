"""Reading and writing: images, videos and particle caches.

Pillow and ffmpeg (``imageio-ffmpeg``) are imported only when an image or video is
actually written or read. Exports for other tools (OpenUSD, VTK, PLY, Houdini ``.geo``)
are in :mod:`motes.io.export`, each importing its package only when used.
"""

from .cache import Cache, CacheWriter, load_cache
from .entry import Entry
from .frames import (
    FrameWriter,
    GifWriter,
    Mp4Writer,
    PngWriter,
    SequenceWriter,
    contact_sheet,
    open_writer,
    read_image,
    read_metadata,
    save_image,
)

__all__ = [
    "Cache",
    "CacheWriter",
    "Entry",
    "FrameWriter",
    "GifWriter",
    "Mp4Writer",
    "PngWriter",
    "SequenceWriter",
    "contact_sheet",
    "load_cache",
    "open_writer",
    "read_image",
    "read_metadata",
    "save_image",
]
