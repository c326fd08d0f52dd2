"""Colour parsing: hex strings and tuples to linear RGBA floats."""

from __future__ import annotations

import numpy as np


def parse_color(value) -> np.ndarray:
    """RGBA float64 (4,) from ``"#rgb"``, ``"#rrggbb"``, ``"#rrggbbaa"``, RGB or RGBA in [0, 1].

    Hex colours are taken as given (no sRGB decoding): motes treats colour values as the
    linear intensities the renderer accumulates.
    """
    if isinstance(value, str):
        text = value.strip().lstrip("#")
        if len(text) == 3:
            text = "".join(ch * 2 for ch in text)
        if len(text) not in (6, 8) or any(ch not in "0123456789abcdefABCDEF" for ch in text):
            raise ValueError(f"colour must look like '#rrggbb' or '#rrggbbaa', got {value!r}")
        channels = [int(text[i : i + 2], 16) / 255 for i in range(0, len(text), 2)]
    else:
        channels = list(np.asarray(value, dtype=np.float64).ravel())
    if len(channels) == 3:
        channels.append(1.0)
    rgba = np.asarray(channels, dtype=np.float64)
    if rgba.shape != (4,) or not np.all(np.isfinite(rgba)) or np.any(rgba < 0):
        raise ValueError(f"colour must be 3 or 4 finite non-negative values, got {value!r}")
    return rgba
