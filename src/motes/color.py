"""Colour parsing and the sRGB transfer function.

motes composites in linear light. Hex strings (``"#ff7a1a"``) are taken as sRGB-encoded,
as every colour picker shows them, and decoded to linear, so a hex colour drawn at full
opacity comes out of the renderer as the same hex value. Tuples are linear already.
"""

from __future__ import annotations

import numpy as np


def srgb_to_linear(encoded):
    """Decode sRGB values in [0, 1] to linear light (IEC 61966-2-1), elementwise."""
    c = np.asarray(encoded, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(linear):
    """Encode linear values in [0, 1] as sRGB (IEC 61966-2-1), elementwise."""
    c = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def parse_color(value) -> np.ndarray:
    """Linear RGBA float64 (4,) from ``"#rgb"``, ``"#rrggbb"``, ``"#rrggbbaa"`` or a tuple.

    Hex colours are sRGB-encoded and decoded here (alpha is linear as written); RGB or
    RGBA tuples are linear values (intensities may exceed 1 for HDR light).
    """
    if isinstance(value, str):
        text = value.strip().lstrip("#")
        if len(text) == 3:
            text = "".join(ch * 2 for ch in text)
        if len(text) not in (6, 8) or any(ch not in "0123456789abcdefABCDEF" for ch in text):
            raise ValueError(f"colour must look like '#rrggbb' or '#rrggbbaa', got {value!r}")
        channels = [int(text[i : i + 2], 16) / 255 for i in range(0, len(text), 2)]
        channels[:3] = srgb_to_linear(channels[:3]).tolist()
    else:
        channels = list(np.asarray(value, dtype=np.float64).ravel())
    if len(channels) == 3:
        channels.append(1.0)
    rgba = np.asarray(channels, dtype=np.float64)
    if rgba.shape != (4,) or not np.all(np.isfinite(rgba)) or np.any(rgba < 0):
        raise ValueError(f"colour must be 3 or 4 finite non-negative values, got {value!r}")
    return rgba
