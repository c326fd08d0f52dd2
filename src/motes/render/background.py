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
        color = frame.color
        color[:, 0, :] = rows
        # Copied across in doubling blocks: a broadcast of (h, 1, 3) over the width moves
        # three floats at a time and took 5x longer at 1280 x 720.
        done, width = 1, color.shape[1]
        while done < width:
            step = min(done, width - done)
            color[:, done : done + step, :] = color[:, :step, :]
            done += step
