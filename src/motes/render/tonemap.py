"""Tone mapping: linear HDR radiance to 8-bit sRGB pixels."""

from __future__ import annotations

from enum import StrEnum
from functools import lru_cache

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


def _curve(x: np.ndarray, curve: ToneMap) -> np.ndarray:
    if curve is ToneMap.REINHARD:
        return x / (1.0 + x)
    if curve is ToneMap.ACES:
        return (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)
    return x


#: Mantissa bits of a float32 that pick its bucket in :func:`_output_table` (at least;
#: more where a curve is steep enough to put two output steps into one bucket).
BUCKET_BITS = 9
#: The largest finite float32's bits: the threshold of an output never reached.
_NEVER = 0x7F7FFFFF


def _outputs(bits: np.ndarray, curve: ToneMap, exposure: float) -> np.ndarray:
    """The exact 8-bit output (int64) of float32 values given by their int32 ``bits``:
    ``round(255 · sRGB(min(curve(exposure · v), 1)))``, evaluated in float64."""
    v = np.asarray(bits, np.int64).astype(np.int32).view(np.float32).astype(np.float64)
    y = _curve(np.maximum(exposure * v, 0.0), curve)
    return np.rint(255.0 * linear_to_srgb(np.minimum(y, 1.0))).astype(np.int64)


@lru_cache(maxsize=16)
def _output_table(curve: ToneMap, exposure: float):
    """What :func:`_tonemap_kernel` needs to map float32 bits to 8-bit outputs exactly.

    The output is a non-decreasing step function of the value; for non-negative floats
    the value's order is its bits' order. ``thresholds[o]`` holds the bits of the least
    float32 whose output is at least ``o`` (found by bisection over the bits), 0 for
    ``o = 0`` and :data:`_NEVER` for 256. The floats between the first and the last
    threshold are cut into buckets of ``2^-bucket_bits`` relative width (the bits
    shifted right by ``shift``), narrow enough that each holds at most one threshold:
    ``first[b]``, the output at bucket ``b``'s start, and one comparison with the next
    threshold give any value's output. Returns ``(first, thresholds, base, shift)``,
    bucket ``b`` being the bits ``(base + b) << shift`` onward (read only, shared).
    """
    # Bisection over the bits of the finite non-negative floats, all 255 steps at once.
    target = np.arange(1, 256)
    low = np.zeros(255, np.int64)
    high = np.full(255, _NEVER + 1, np.int64)  # one past the last: "never reached"
    while (low < high).any():
        middle = (low + high) // 2
        reached = _outputs(np.minimum(middle, _NEVER), curve, exposure) >= target
        reached &= middle <= _NEVER
        high = np.where(reached, middle, high)
        low = np.where(reached, low, middle + 1)
    thresholds = np.concatenate([[0], np.minimum(low, _NEVER), [_NEVER]]).astype(np.int32)
    for bits in range(BUCKET_BITS, 24):
        shift = 23 - bits
        base = max(int(thresholds[1]) >> shift, 0)
        buckets = np.arange(base, (int(thresholds[255]) >> shift) + 1, dtype=np.int64)
        first = _outputs(buckets << shift, curve, exposure)
        last = _outputs(np.minimum(((buckets + 1) << shift) - 1, _NEVER), curve, exposure)
        if (last - first).max(initial=0) <= 1:
            break
    first = first.astype(np.uint8)
    for array in (first, thresholds):
        array.flags.writeable = False
    return first, thresholds, np.int32(base), np.int32(shift)


@parallel_kernel
def _tonemap_kernel(bits, first, thresholds, base, shift, out):
    """``out`` (flat uint8) = the 8-bit output of each float32 given by its int32 ``bits``
    (:func:`_output_table`): the output at the start of its bucket, plus one where it
    reaches the next threshold.

    Integer arithmetic only: exact (the float64 curve's rounding, not an interpolation
    of it), and no float the kernels' fast-math flags could misread (negative values
    have negative bits and give 0; an infinite or NaN value 255). The image is one flat
    run of channels split into fixed blocks (see :mod:`motes._jit`). A 1280 × 720 frame
    on one thread: 8.0 ms as the interpolated table of ``x / (1 + x)`` it replaced, 3.1
    ms so.
    """
    n = bits.shape[0]
    last = first.shape[0] - 1
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for k in range(start, stop):
            b = bits[k]
            o = np.int32(first[min(max((b >> shift) - base, 0), last)])
            o += np.int32(b >= thresholds[o + 1])
            out[k] = np.uint8(min(o, 255))


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
    bits = np.ascontiguousarray(color, dtype=np.float32).view(np.int32).reshape(-1)
    _tonemap_kernel(bits, *_output_table(curve, exposure), out.reshape(-1))
    return out


def to_srgb(color, *, exposure: float = 1.0, tonemap: str = "aces") -> np.ndarray:
    """The tone curve and sRGB encoding of :func:`to_srgb8`, evaluated for each value, as
    float32 in [0, 1] (not rounded to 8 bits): for 16-bit output."""
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
