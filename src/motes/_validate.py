"""Parameter validation shared by every public constructor.

Each check raises ``ValueError`` (or ``TypeError`` for a wrong kind of value) with a
message that names the parameter and the allowed range, so bad input fails at
construction and never inside a compiled kernel.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


def real(
    name: str,
    value,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
    allow_inf: bool = False,
) -> float:
    """Return ``value`` as a float after checking it is finite and within ``[low, high]``.

    ``low_open`` / ``high_open`` make the bound strict. Infinite values are refused unless
    ``allow_inf`` (e.g. a lifetime of ``inf`` for immortal particles).
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    x = float(value)
    if math.isnan(x) or (math.isinf(x) and not allow_inf):
        raise ValueError(f"{name} must be finite, got {x}")
    if low is not None and (x < low or (low_open and x == low)):
        raise ValueError(f"{name} must be {'>' if low_open else '>='} {low}, got {x}")
    if high is not None and (x > high or (high_open and x == high)):
        raise ValueError(f"{name} must be {'<' if high_open else '<='} {high}, got {x}")
    return x


def positive(name: str, value, *, allow_inf: bool = False) -> float:
    """A finite real number > 0."""
    return real(name, value, low=0.0, low_open=True, allow_inf=allow_inf)


def non_negative(name: str, value, *, allow_inf: bool = False) -> float:
    """A finite real number >= 0."""
    return real(name, value, low=0.0, allow_inf=allow_inf)


def unit_interval(name: str, value) -> float:
    """A real number in [0, 1]."""
    return real(name, value, low=0.0, high=1.0)


def integer(name: str, value, *, low: int | None = None) -> int:
    """An integer (not a bool) >= ``low``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    if low is not None and value < low:
        raise ValueError(f"{name} must be >= {low}, got {value}")
    return int(value)


def vector(name: str, value, size: int = 3) -> np.ndarray:
    """A finite float64 vector of ``size`` components."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a sequence of {size} numbers, got {value!r}") from None
    if arr.shape != (size,):
        raise ValueError(f"{name} must have shape ({size},), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf), got {arr.tolist()}")
    return arr


def unit_vector(name: str, value) -> np.ndarray:
    """A finite 3-vector of non-zero length, returned normalised."""
    arr = vector(name, value)
    norm = float(np.linalg.norm(arr))
    if norm < 1e-12:
        raise ValueError(f"{name} must have non-zero length, got {arr.tolist()}")
    return arr / norm


def points(name: str, value, *, columns: int = 3, min_rows: int = 1) -> np.ndarray:
    """A finite float64 array of shape (rows, columns) with at least ``min_rows`` rows."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != columns:
        raise ValueError(f"{name} must have shape (n, {columns}), got shape {arr.shape}")
    if arr.shape[0] < min_rows:
        raise ValueError(f"{name} needs at least {min_rows} rows, got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr


def choice(name: str, value, allowed: Sequence[str]) -> str:
    """One of the strings in ``allowed``."""
    if value not in allowed:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, allowed))}, got {value!r}")
    return value
