"""The colour of hot matter: a blackbody's radiance in linear sRGB, for volumes' emission.

Planck's spectral radiance integrated against the CIE 1931 colour-matching functions
(the multi-lobe fit of Wyman, Sloan & Shirley 2013), converted to linear sRGB and scaled
to luminance 1 at ``BLACKBODY_REFERENCE_K``; :func:`blackbody_table` tabulates it for the
kernels.
"""

from __future__ import annotations

import functools

import numpy as np

#: Below this temperature [K] a voxel emits nothing (Draper's point, where a heated body
#: starts to glow visibly; Planck's luminance there is 1e-6 of the reference's).
BLACKBODY_MIN_K = 798.0
#: The temperature [K] whose blackbody luminance ``blackbody_rgb`` normalises to 1.
BLACKBODY_REFERENCE_K = 1500.0
#: Kelvin per entry of the kernels' blackbody table, and its last temperature [K].
TABLE_STEP_K = 4.0
TABLE_MAX_K = 16000.0

_H = 6.62607015e-34  # Planck constant [J s]
_C = 2.99792458e8  # speed of light [m/s]
_K = 1.380649e-23  # Boltzmann constant [J/K]

#: XYZ to linear sRGB (IEC 61966-2-1, D65 white).
_XYZ_TO_SRGB = np.array(
    [
        [3.2404542, -1.5371385, -0.4985314],
        [-0.9692660, 1.8760108, 0.0415560],
        [0.0556434, -0.2040259, 1.0572252],
    ]
)


def _lobe(wavelength, mean, left, right):
    """A Gaussian with a different width on each side of its mean [nm]."""
    width = np.where(wavelength < mean, left, right)
    return np.exp(-0.5 * ((wavelength - mean) / width) ** 2)


def colour_matching(wavelength) -> np.ndarray:
    """CIE 1931 2° colour-matching functions (3, n) at ``wavelength`` [nm]: the
    multi-lobe fit of Wyman, Sloan & Shirley (2013), "Simple analytic approximations to
    the CIE XYZ color matching functions", JCGT 2(2), eq. 2 (sums of piecewise
    Gaussians, within a few percent of the tabulated functions)."""
    w = np.asarray(wavelength, dtype=np.float64)
    x = (
        1.056 * _lobe(w, 599.8, 37.9, 31.0)
        + 0.362 * _lobe(w, 442.0, 16.0, 26.7)
        - 0.065 * _lobe(w, 501.1, 20.4, 26.2)
    )
    y = 0.821 * _lobe(w, 568.8, 46.9, 40.5) + 0.286 * _lobe(w, 530.9, 16.3, 31.1)
    z = 1.217 * _lobe(w, 437.0, 11.8, 36.0) + 0.681 * _lobe(w, 459.0, 26.0, 13.8)
    return np.stack([x, y, z])


def blackbody_xyz(temperature) -> np.ndarray:
    """CIE XYZ (..., 3) of a blackbody at ``temperature`` [K] (array_like, > 0): Planck's
    spectral radiance ``2hc²/λ⁵ / (exp(hc/λkT) - 1)`` integrated against the
    colour-matching functions over 360-830 nm in 1 nm steps (arbitrary units)."""
    kelvin = np.asarray(temperature, dtype=np.float64)
    lam = np.arange(360.0, 831.0)
    metres = lam * 1e-9
    with np.errstate(over="ignore"):
        planck = 2 * _H * _C**2 / metres**5 / np.expm1(_H * _C / (metres * _K * kelvin[..., None]))
    return planck @ colour_matching(lam).T


@functools.cache
def _reference_luminance() -> float:
    return float(blackbody_xyz(BLACKBODY_REFERENCE_K)[1])


def blackbody_rgb(temperature) -> np.ndarray:
    """Linear sRGB (..., 3) of a blackbody at ``temperature`` [K].

    Planck's law integrated against the CIE 1931 colour-matching functions
    (:func:`blackbody_xyz`), converted to linear sRGB (D65) with channels below 0 (out
    of gamut, the blue of a red-hot body) clipped to 0, and scaled so that a blackbody at
    ``BLACKBODY_REFERENCE_K`` (1500 K) has luminance ``Y = 1``; 0 below
    ``BLACKBODY_MIN_K``. The brightness follows Planck: relative to 1500 K, a body at
    1000 K has luminance 3.5e-4, at 2000 K 60, at 3000 K 3,900.

    Examples
    --------
    >>> rgb = blackbody_rgb([1000.0, 1500.0, 6500.0])
    >>> bool(rgb[0, 0] > rgb[0, 1] > rgb[0, 2]), round(float(rgb[2, 2] / rgb[2, 0]), 2)
    (True, 0.99)
    """
    kelvin = np.asarray(temperature, dtype=np.float64)
    hot = kelvin >= BLACKBODY_MIN_K
    xyz = blackbody_xyz(np.where(hot, kelvin, BLACKBODY_REFERENCE_K))
    rgb = np.clip(xyz @ _XYZ_TO_SRGB.T, 0.0, None) / _reference_luminance()
    return np.where(hot[..., None], rgb, 0.0)


@functools.cache
def blackbody_table() -> np.ndarray:
    """:func:`blackbody_rgb` every ``TABLE_STEP_K`` from 0 to ``TABLE_MAX_K``, float32
    (entries, 3): what the kernels interpolate (within 0.3 % of the function above
    1000 K)."""
    table = blackbody_rgb(np.arange(0.0, TABLE_MAX_K + TABLE_STEP_K, TABLE_STEP_K))
    table = table.astype(np.float32)
    table.flags.writeable = False
    return table
