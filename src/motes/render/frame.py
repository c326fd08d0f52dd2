"""The frame being drawn: linear-light colour and the depth of opaque geometry."""

from __future__ import annotations

import numpy as np

from .. import _validate as check


class Frame:
    """Render target shared by every layer of one image.

    Layers draw in order onto the same frame: background, opaque geometry (writes
    ``color`` and ``depth``), then particles (read ``depth`` for occlusion and soft
    fading, write ``color``). Tone mapping turns ``color`` into an 8-bit sRGB image.

    Attributes
    ----------
    color : (height, width, 3) float32
        Linear-light radiance, unbounded above (HDR).
    depth : (height, width) float32
        View-space depth [m] of the nearest opaque surface; ``inf`` where there is none.
    alpha : (height, width) float32 or None
        Coverage, for a frame drawn over a transparent background.
    """

    def __init__(self, width: int, height: int):
        width = check.integer("width", width, low=1)
        height = check.integer("height", height, low=1)
        self.color = np.zeros((height, width, 3), dtype=np.float32)
        self.depth = np.full((height, width), np.inf, dtype=np.float32)
        #: (height, width) float32 coverage in [0, 1] of a frame drawn over a transparent
        #: background (``color`` is then premultiplied by it); None otherwise.
        self.alpha: np.ndarray | None = None

    @property
    def width(self) -> int:
        return self.color.shape[1]

    @property
    def height(self) -> int:
        return self.color.shape[0]
