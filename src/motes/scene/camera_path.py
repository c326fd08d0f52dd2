"""A camera that moves along keyframes (``[[camera.key]]`` in a scene file).

Each key gives a time and the eye position, look-at target and field of view there.
Between keys every quantity follows a cubic Hermite curve with Catmull–Rom tangents
for uneven spacing, ``m_k = (p_{k+1} − p_{k−1}) / (t_{k+1} − t_{k−1})`` (Catmull & Rom
1974), so the path passes through every key with a continuous velocity; the tangent
is zero at the first and last keys, so the camera eases in and out. Before the first key
and after the last the camera holds still.
"""

from __future__ import annotations

import numpy as np

from .. import _validate as check


class CameraPath:
    """Keyframed eye positions, targets and fields of view.

    Parameters
    ----------
    times : (k,) array_like
        Key times [s], strictly increasing, k >= 1.
    positions, targets : (k, 3) array_like
        Eye and look-at point at each key [m].
    fovs : (k,) array_like
        Vertical field of view at each key [deg].
    """

    def __init__(self, times, positions, targets, fovs):
        self.times = np.asarray(times, dtype=np.float64)
        k = len(self.times)
        if self.times.ndim != 1 or k < 1 or not np.all(np.isfinite(self.times)):
            raise ValueError("times must be a non-empty array of finite numbers")
        if np.any(np.diff(self.times) <= 0):
            raise ValueError(f"times must increase strictly, got {self.times.tolist()}")
        self.positions = check.points("positions", positions, min_rows=k)[:k]
        self.targets = check.points("targets", targets, min_rows=k)[:k]
        self.fovs = np.asarray(fovs, dtype=np.float64).reshape(k)
        # One (k, 7) table: the curve of each quantity is the same Hermite spline.
        self._values = np.column_stack([self.positions, self.targets, self.fovs])
        self._tangents = _catmull_rom_tangents(self.times, self._values)

    def at(self, time: float) -> tuple[np.ndarray, np.ndarray, float]:
        """Eye position (3,) [m], target (3,) [m] and fov [deg] at ``time`` [s]."""
        t, values = self.times, self._values
        if time <= t[0] or len(t) == 1:
            row = values[0]
        elif time >= t[-1]:
            row = values[-1]
        else:
            k = int(np.searchsorted(t, time, side="right")) - 1
            h = t[k + 1] - t[k]
            s = (time - t[k]) / h
            h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
            h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
            m0, m1 = self._tangents[k], self._tangents[k + 1]
            row = h00 * values[k] + h10 * h * m0 + h01 * values[k + 1] + h11 * h * m1
        return row[:3].copy(), row[3:6].copy(), float(row[6])

    def __repr__(self) -> str:
        return f"CameraPath({len(self.times)} keys, {self.times[0]:g} to {self.times[-1]:g} s)"


def _catmull_rom_tangents(times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Tangents of the values per unit time; zero at the ends (ease in and out)."""
    tangents = np.zeros_like(values)
    if len(times) > 2:
        span = (times[2:] - times[:-2])[:, None]
        tangents[1:-1] = (values[2:] - values[:-2]) / span
    return tangents
