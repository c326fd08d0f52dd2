"""Bloom: the glow around light brighter than white, as a lens and the eye scatter it.

Light above a threshold (in exposed linear radiance: 1 is white before the tone curve)
is spread by a blur and put back: ``color += strength · (blur(bright) − bright)``, with
``bright = max(color − threshold / exposure, 0)`` per channel. The blur is the mean of
:data:`LEVELS` Gaussians whose widths halve from ``radius`` (a share of the frame's
height), a sharp core with a wide skirt as in measured glare; each is taken on a
pyramid of 2 × 2 means at the level where it is 2 to 4 pixels wide, and the levels are
summed from the coarsest up, each doubled bilinearly into the next (compiled kernels,
:mod:`.bloom_kernels`): a few milliseconds a frame whatever the radius. The blur is
normalised and reflects at the frame's edges: bloom moves light and adds none (the
frame's total within 1 %, tested); a frame with nothing above the threshold is left
exactly as it was.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _validate as check
from . import bloom_kernels as kern

#: A threshold nothing exceeds: :func:`bloom_kernels.double_add` then only adds (finite:
#: the kernels' fast math assumes no infinities).
NO_THRESHOLD = np.float32(3.0e38)

#: Gaussians summed, their standard deviations radius, radius/2, radius/4, ...
LEVELS = 4


@dataclass(frozen=True)
class Bloom:
    """Glow around bright light (emissive particles, fire, sparks, the sun on water).

    Parameters
    ----------
    strength : float
        Share of the light above the threshold that is spread, 0 to 1.
    radius : float
        Standard deviation of the widest Gaussian as a share of the frame's height,
        0.001 to 0.5 (0.03 on a 720-line frame: about 22 pixels).
    threshold : float
        Exposed linear radiance above which light blooms, >= 0 (1: white).
    """

    strength: float = 0.3
    radius: float = 0.03
    threshold: float = 1.0

    def __post_init__(self):
        values = {
            "strength": check.real("bloom.strength", self.strength, low=0.0, high=1.0),
            "radius": check.real("bloom.radius", self.radius, low=0.001, high=0.5),
            "threshold": check.non_negative("bloom.threshold", self.threshold),
        }
        for name, value in values.items():
            object.__setattr__(self, name, value)

    def apply(self, color: np.ndarray, *, exposure: float = 1.0) -> None:
        """Add the glow to ``color`` (height, width, 3) float32 linear light, in place."""
        _check_image("color", color)
        threshold = np.float32(self.threshold / exposure)
        half = np.empty(((color.shape[0] + 1) // 2, (color.shape[1] + 1) // 2, 3), np.float32)
        if self.strength == 0.0 or not kern.halve_above(color, threshold, half):
            return
        glow = glare_half(half, self.radius * color.shape[0])
        kern.double_add(glow, color, np.float32(self.strength), threshold)


def glare_half(half: np.ndarray, sigma: float) -> np.ndarray:
    """The mean of :data:`LEVELS` Gaussian blurs, of standard deviations ``sigma``,
    ``sigma / 2``, ... [full-size pixels], of the light ``half`` (the full-size light's
    2 × 2 means), at half size. Each Gaussian is taken on the level of a pyramid of
    2 × 2 means where it is 2 to 4 pixels wide (the half-size level at the least), and
    the levels are summed from the coarsest up, each doubled bilinearly into the next."""
    level_of = [max(1, int(np.log2(max(sigma / 2.0**k, 1.0) / 2.0))) for k in range(LEVELS)]
    pyramid = [None, half]
    while len(pyramid) <= max(level_of) and min(pyramid[-1].shape[:2]) > 1:
        below = pyramid[-1]
        smaller = np.empty(((below.shape[0] + 1) // 2, (below.shape[1] + 1) // 2, 3), np.float32)
        kern.halve(below, smaller)
        pyramid.append(smaller)
    deepest = len(pyramid) - 1
    total = None
    for level in range(deepest, 0, -1):
        here = np.zeros_like(pyramid[level])
        if total is not None:
            kern.double_add(total, here, np.float32(1.0), NO_THRESHOLD)
        for k in range(LEVELS):
            if min(level_of[k], deepest) == level:
                width = sigma / 2.0**k / 2.0**level
                here += _blurred(pyramid[level], width) * np.float32(1.0 / LEVELS)
        total = here
    return total


def _blurred(image: np.ndarray, sigma: float) -> np.ndarray:
    """``image`` blurred by a Gaussian of ``sigma`` pixels (reflected at the edges)."""
    reach = max(1, int(np.ceil(3.0 * sigma)))
    x = np.arange(-reach, reach + 1, dtype=np.float64)
    weights = np.exp(-0.5 * (x / max(sigma, 1e-3)) ** 2)
    weights = (weights / weights.sum()).astype(np.float32)
    across = np.empty_like(image)
    kern.blur_rows(image, weights, across)
    out = np.empty_like(image)
    kern.blur_columns(across, weights, out)
    return out


def _check_image(name: str, image) -> None:
    """``image`` must be a writable, C-contiguous (height, width, 3) float32 array."""
    if not (
        isinstance(image, np.ndarray)
        and image.dtype == np.float32
        and image.ndim == 3
        and image.shape[2] == 3
        and image.flags.c_contiguous
        and image.flags.writeable
    ):
        shape = getattr(image, "shape", None)
        dtype = getattr(image, "dtype", type(image).__name__)
        raise ValueError(
            f"{name} must be a writable C-contiguous (height, width, 3) float32 array, "
            f"got {dtype} {shape}"
        )
