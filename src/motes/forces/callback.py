"""A force computed by user code over whole arrays."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .base import Force


class CallbackForce(Force):
    """Force from a user function over arrays (never called per particle).

    Parameters
    ----------
    function : callable ``(position, velocity, time) -> force``
        ``position`` and ``velocity`` are ``(n, 3)`` views [m], [m/s]; returns an
        ``(n, 3)`` array of forces [N]. It must not modify its inputs.
    reads : tuple of str
        Extra attributes the function needs (allocated in the store).
    """

    def __init__(self, function: Callable, *, reads: tuple[str, ...] = ()):
        if not callable(function):
            raise TypeError(f"function must be callable, got {function!r}")
        self.function = function
        self.reads = ("position", "velocity", *reads)

    def accumulate(self, store, position, velocity, time, out) -> None:
        n = position.shape[1]
        force = np.asarray(self.function(position.T, velocity.T, time))
        if force.shape != (n, 3):
            raise ValueError(
                f"CallbackForce function must return shape ({n}, 3), got {force.shape}"
            )
        if not np.all(np.isfinite(force)):
            raise ValueError("CallbackForce function returned NaN or infinite forces")
        out += force.T
