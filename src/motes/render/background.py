"""Backgrounds: a solid colour or a vertical gradient, in linear light."""

from __future__ import annotations

import numpy as np

from ..color import parse_color


class Background:
    """Fill for the frame before anything is drawn.

    Parameters
    ----------
    top : colour
        Colour at the top row (hex strings are sRGB, tuples linear; alpha ignored).
    bottom : colour, optional
        Colour at the bottom row; the rows between blend linearly. ``None``: solid ``top``.
    """

    def __init__(self, top="#000000", bottom=None):
        self.top = parse_color(top)[:3]
        self.bottom = self.top if bottom is None else parse_color(bottom)[:3]

    def fill(self, frame) -> None:
        """Write the background into ``frame.color`` (every pixel)."""
        t = (np.arange(frame.height) + 0.5) / frame.height
        rows = (1 - t)[:, None] * self.top + t[:, None] * self.bottom
        frame.color[:] = rows[:, None, :].astype(np.float32)
