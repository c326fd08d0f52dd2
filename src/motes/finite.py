"""Stopping at the first NaN or infinity in a particle state.

A force that divides by a vanishing distance or overflows float32 makes a particle's
velocity NaN, and from there its position; the renderer then draws nothing for it and a
run goes on producing frames that hide the fault. :func:`check_finite` scans every float
attribute of a :class:`~motes.state.ParticleState` and raises :class:`NonFiniteError`
naming the particle, the attribute and the value. ``motes run`` checks every system and
body once per frame (``--no-check-finite`` turns it off); in Python it is opt-in
(``load_scene(..., check_finite=True)``, or a call after any step).

The scan is a compiled pass over each row's bits, not its values: a float is NaN or
infinite exactly when its exponent bits are all set. The kernels are compiled with
``fastmath``, under which LLVM may assume that no float is NaN or infinite and fold a
test of the value away; integer operations on the bits keep their meaning.
"""

from __future__ import annotations

import numpy as np

from ._jit import block_bounds, block_count, serial_kernel
from .state import ParticleState, as_state

__all__ = ["INFINITE_OK", "NonFiniteError", "check_finite", "first_non_finite"]

#: Attributes scanned first, in this order (velocity goes bad first: a force's fault
#: reaches positions through it); then the state's other float fields in their order.
_FIRST = ("velocities", "positions", "radius")

#: What a message calls the core attributes.
_SINGULAR = {"velocities": "velocity", "positions": "position"}

#: Attributes whose values may be infinite (only NaN is refused): a lifetime of ``inf``
#: is an immortal particle.
INFINITE_OK = frozenset({"lifetime"})

#: Each float type's unsigned view, the mask that clears its sign bit, its exponent bits.
_BITS = {
    np.dtype(np.float32): (np.uint32, np.uint32(0x7FFF_FFFF), np.uint32(0x7F80_0000)),
    np.dtype(np.float64): (
        np.uint64,
        np.uint64(0x7FFF_FFFF_FFFF_FFFF),
        np.uint64(0x7FF0_0000_0000_0000),
    ),
}


class NonFiniteError(ValueError):
    """A particle's state holds NaN or infinity.

    Attributes
    ----------
    owner : str
        What holds the particle, e.g. ``"system 'fire'"``.
    particle : int
        The particle's id (``ParticleState.ids``).
    attribute : str
        The attribute, e.g. ``"velocity"``.
    value : tuple of float
        The particle's value of it (one per component).
    frame : int or None
        The frame after which it was found.
    time : float or None
        Simulated time [s] then.
    """

    def __init__(self, owner, particle, attribute, value, frame=None, time=None):
        self.owner = owner
        self.particle = particle
        self.attribute = attribute
        self.value = value
        self.frame = frame
        self.time = time
        shown = ", ".join(f"{v:g}" for v in value)
        when = ""
        if frame is not None:
            when = f" at frame {frame}" + (f", t = {time:.2f} s" if time is not None else "")
        super().__init__(
            f"{owner}: particle {particle} has a non-finite {attribute} ({shown}){when}"
        )


@serial_kernel
def first_at_least(bits, mask, threshold):
    """Index of the first entry of ``bits`` (floats seen as unsigned integers) with
    ``bits & mask >= threshold``, or -1. With ``mask`` clearing the sign bit, a
    ``threshold`` of the exponent bits finds NaN and infinity, one more finds NaN only.

    Each block's largest value is a vectorised reduction; only a block that holds a hit
    is searched.
    """
    n = bits.shape[0]
    for block in range(block_count(n)):
        start, stop = block_bounds(block, n)
        top = bits.dtype.type(0)
        for i in range(start, stop):
            top = max(top, bits[i] & mask)
        if top >= threshold:
            for i in range(start, stop):
                if (bits[i] & mask) >= threshold:
                    return np.int64(i)
    return np.int64(-1)


def _first_in(data: np.ndarray, n: int, *, infinite_ok: bool = False) -> int:
    """The lowest particle index with a non-finite component in ``data`` (NaN only when
    ``infinite_ok``), or -1."""
    if data.dtype not in _BITS:
        if data.dtype.kind != "f":  # ids, phases, flags
            return -1
        rows = data.reshape(-1, n)  # float16 and longdouble: not worth a kernel
        bad = np.isnan(rows) if infinite_ok else ~np.isfinite(rows)
        hits = np.flatnonzero(bad.any(axis=0))
        return int(hits[0]) if hits.size else -1
    view, mask, exponent = _BITS[data.dtype]
    threshold = exponent + view(1) if infinite_ok else exponent
    best = -1
    for row in data.reshape(-1, n):
        # Rows of a kind's (c, n) arrays are contiguous; a strided view is copied so
        # that the kernel has one layout per float type.
        found = first_at_least(np.ascontiguousarray(row).view(view), mask, threshold)
        if found >= 0 and (best < 0 or found < best):
            best = int(found)
            if best == 0:
                break
    return best


def first_non_finite(state: ParticleState) -> tuple[str, int] | None:
    """The first attribute holding NaN or infinity and the lowest such particle index.

    Velocities, positions and radius are scanned first, then the other float fields in
    order; integer fields are skipped, and attributes in :data:`INFINITE_OK` may be
    infinite (not NaN). ``None`` when every value is finite.
    """
    n = state.count
    if n == 0:
        return None
    names = [*_FIRST, *(name for name in state.names() if name not in (*_FIRST, "ids"))]
    for name in names:
        index = _first_in(np.asarray(state[name]), n, infinite_ok=name in INFINITE_OK)
        if index >= 0:
            return name, index
    return None


def check_finite(item, *, owner: str = "state", frame=None, time=None) -> None:
    """Raise :class:`NonFiniteError` if ``item``'s particles hold NaN or infinity.

    Parameters
    ----------
    item : ParticleState or object with ``particle_state()``
        A system, liquid, cloth, hair, rigid world, scene body or a state.
    owner : str
        Names it in the message, e.g. ``"system 'fire'"``.
    frame, time : int and float, optional
        When the check ran, for the message.

    Examples
    --------
    >>> import numpy as np
    >>> from motes.state import ParticleState
    >>> state = ParticleState(np.arange(2), np.zeros((3, 2)),
    ...                       np.array([[0.0, np.nan], [0, 0], [0, 0]]), np.ones(2))
    >>> check_finite(state, owner="system 'jet'", frame=3, time=0.1)
    Traceback (most recent call last):
    ...
    motes.finite.NonFiniteError: system 'jet': particle 1 has a non-finite velocity (nan, 0, 0) at frame 3, t = 0.10 s
    """  # noqa: E501
    state = as_state(item)
    found = first_non_finite(state)
    if found is None:
        return
    name, index = found
    data = np.asarray(state[name])
    value = tuple(float(v) for v in data.reshape(-1, state.count)[:, index])
    raise NonFiniteError(
        owner, int(state.ids[index]), _SINGULAR.get(name, name), value, frame, time
    )
