"""Reading and writing: images, videos and particle caches.

Pillow and ffmpeg (``imageio-ffmpeg``) are imported only when an image or video is
actually written or read.
"""

from .cache import Cache, CacheWriter, load_cache
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
