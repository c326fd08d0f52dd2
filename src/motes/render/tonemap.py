"""Tone mapping: linear HDR radiance to 8-bit sRGB pixels."""

from __future__ import annotations

from enum import StrEnum
from functools import cache

import numba
import numpy as np

from .. import _validate as check
from .._jit import block_bounds, block_count, parallel_kernel
from ..color import linear_to_srgb


class ToneMap(StrEnum):
    """Curve that compresses HDR radiance into [0, 1] before sRGB encoding.

    ``clamp`` clips at 1 (exact for LDR scenes); ``reinhard`` is x / (1 + x)
    (Reinhard et al. 2002); ``aces`` is Narkowicz's (2015) fit of the ACES filmic curve,
    which keeps dense additive fire from burning out to flat white.
    """

    CLAMP = "clamp"
    REINHARD = "reinhard"
    ACES = "aces"


#: Entries of the lookup table over u = x / (1 + x), which maps [0, inf) onto [0, 1).
LUT_SIZE = 4096


def _curve(x: np.ndarray, curve: ToneMap) -> np.ndarray:
    if curve is ToneMap.REINHARD:
        return x / (1.0 + x)
    if curve is ToneMap.ACES:
        return (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)
    return x


@cache
def _lookup_table(curve: ToneMap) -> np.ndarray:
    """sRGB-encoded output [0, 255] sampled uniformly in u = x / (1 + x), float32
    (read only: one table per curve, shared by every call).

    Evaluating pow() per channel cost 38 ms for a 1280×720 frame; interpolating this
    table costs a few, and the interpolation error is far below one output step.
    """
    u = np.linspace(0.0, 1.0, LUT_SIZE + 1)
    x = u / np.maximum(1.0 - u, 1e-12)  # the last entry stands for +inf
    y = _curve(x, curve)
    table = (255.0 * linear_to_srgb(np.minimum(y, 1.0))).astype(np.float32)
    table.flags.writeable = False
    return table


@parallel_kernel
def _tonemap_kernel(color, exposure, lut, out):
    """``out`` (h, w, 3) uint8 = the table interpolated at each channel of ``color``.

    The channels are independent, so the image is one flat run of values, split into
    fixed blocks (see :mod:`motes._jit`), whose loop LLVM vectorises (3 nested loops
    over rows, columns and channels did not).
    """
    values = color.reshape(-1)
    pixels = out.reshape(-1)
    n = values.shape[0]
    size = lut.shape[0] - 1
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for k in range(start, stop):
            x = max(values[k] * exposure, 0.0)
            f = x / (1.0 + x) * size
            i = min(int(f), size - 1)
            w = f - i
            pixels[k] = np.uint8(lut[i] + w * (lut[i + 1] - lut[i]) + 0.5)


def to_srgb8(color, *, exposure: float = 1.0, tonemap: str = "aces", out=None) -> np.ndarray:
    """Tone-map a linear HDR image and encode it as sRGB.

    Parameters
    ----------
    color : (h, w, 3) float32
        Linear radiance (a :class:`~motes.render.frame.Frame`'s ``color``).
    exposure : float
        Multiplier applied before the curve, > 0 (photographic exposure: ×2 = one stop).
    tonemap : {"clamp", "reinhard", "aces"}
    out : (h, w, 3) uint8, optional
        C-contiguous buffer to write into.

    Returns
    -------
    (h, w, 3) uint8 sRGB image.
    """
    color = np.asarray(color)
    if color.ndim != 3 or color.shape[2] != 3:
        raise ValueError(f"color must have shape (h, w, 3), got {color.shape}")
    exposure = check.positive("exposure", exposure)
    curve = ToneMap(check.choice("tonemap", tonemap, [t.value for t in ToneMap]))
    if out is None:
        out = np.empty(color.shape, dtype=np.uint8)
    elif out.shape != color.shape or out.dtype != np.uint8 or not out.flags.c_contiguous:
        raise ValueError(
            f"out must be a C-contiguous uint8 array of shape {color.shape}, got "
            f"{out.dtype} {out.shape}"
        )
    _tonemap_kernel(
        np.ascontiguousarray(color, dtype=np.float32), exposure, _lookup_table(curve), out
    )
    return out


def to_srgb(color, *, exposure: float = 1.0, tonemap: str = "aces") -> np.ndarray:
    """The tone curve and sRGB encoding of :func:`to_srgb8`, evaluated exactly (no
    lookup table), as float32 in [0, 1]: for 16-bit output, where the table's error
    would show."""
    color = np.asarray(color, dtype=np.float32)
    exposure = check.positive("exposure", exposure)
    curve = ToneMap(check.choice("tonemap", tonemap, [t.value for t in ToneMap]))
    mapped = _curve(np.maximum(color * exposure, 0.0), curve)
    return linear_to_srgb(np.minimum(mapped, 1.0)).astype(np.float32)


def to_display(
    color,
    *,
    exposure: float = 1.0,
    tonemap: str = "aces",
    alpha: np.ndarray | None = None,
    bits: int = 8,
) -> np.ndarray:
    """A frame as the pixels of an image file: RGB, or RGBA with ``alpha``, 8 or 16 bits.

    ``color`` is linear light; with ``alpha`` (coverage, (h, w)) it is premultiplied, as
    a frame drawn over a transparent background is, and the image holds straight alpha,
    as PNG does: the colour divided by the alpha, then tone mapped (where the alpha is 0
    the colour is dropped: light added over nothing is kept only by OpenEXR).
    """
    bits = check.choice("bits", bits, [8, 16])
    color = np.asarray(color, dtype=np.float32)
    if alpha is not None:
        alpha = np.clip(np.asarray(alpha, dtype=np.float32), 0.0, 1.0)
        covered = alpha > 0
        straight = np.zeros_like(color)
        straight[covered] = color[covered] / alpha[covered][:, None]
        color = straight
    if bits == 8 and alpha is None:
        return to_srgb8(color, exposure=exposure, tonemap=tonemap)
    top, dtype = (255, np.uint8) if bits == 8 else (65535, np.uint16)
    channels = [to_srgb(color, exposure=exposure, tonemap=tonemap)]
    if alpha is not None:
        channels.append(alpha[..., None])
    return np.rint(np.concatenate(channels, axis=2) * top).astype(dtype)
