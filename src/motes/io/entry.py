"""One named entry of a frame: a particle state and the shapes built on its particles.

The particle cache and the exporters (:mod:`motes.io.export`) record what every kind
shows as its :class:`~motes.state.ParticleState`. Some kinds are more than points, and
an :class:`Entry` carries that too, for formats that can hold it:

- a cloth is a triangle mesh over its particles (``faces``);
- hair is curves through its particles, strand by strand, root first (``curves``);
- a rigid world moves bodies as wholes (``transforms``: centre and rotation of each);
- a liquid drawn as a surface has a mesh of its own vertices (``surface``), not its
  particles.

Anything with ``particle_state()`` is an entry without shapes (:func:`as_entry`); the
scene's bodies make theirs with ``Body.entry()``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..state import ParticleState, as_state

__all__ = ["Entry", "as_entry"]


def _index_array(name: str, value, columns: int | None) -> np.ndarray:
    array = np.asarray(value)
    shape_ok = array.ndim == 2 and array.shape[1] == columns if columns else array.ndim == 1
    if not shape_ok or (array.size and array.dtype.kind not in "iu"):
        want = f"(m, {columns})" if columns else "(s,)"
        raise ValueError(f"{name} must be an integer array of shape {want}, got {array.shape}")
    return array.astype(np.int64, copy=False)


@dataclass(frozen=True)
class Entry:
    """A :class:`~motes.state.ParticleState` and, optionally, the shapes on it.

    Parameters
    ----------
    state : ParticleState
        The particles.
    faces : (m, 3) int array, optional
        Triangles over the state's particles (indices into them): a cloth's mesh.
    curves : (s,) int array, optional
        Particles in each curve, in order (summing to the particle count): hair
        strands, root first.
    transforms : tuple of ((b, 3), (b, 3, 3)) float arrays, optional
        Centre of mass [m] and rotation (a body's local axes as columns) of each body
        of a rigid world.
    surface : tuple of ((v, 3) float, (f, 3) int) arrays, optional
        A triangle mesh of its own vertices [m] (a liquid's surface).
    """

    state: ParticleState
    faces: np.ndarray | None = None
    curves: np.ndarray | None = None
    transforms: tuple[np.ndarray, np.ndarray] | None = None
    surface: tuple[np.ndarray, np.ndarray] | None = None

    def __post_init__(self):
        if not isinstance(self.state, ParticleState):
            raise TypeError(f"state must be a ParticleState, got {type(self.state).__name__}")
        n = self.state.count
        if self.faces is not None:
            faces = _index_array("faces", self.faces, 3)
            if faces.size and (faces.min() < 0 or faces.max() >= n):
                raise ValueError(f"faces must index the {n} particles")
            object.__setattr__(self, "faces", faces)
        if self.curves is not None:
            curves = _index_array("curves", self.curves, None)
            if np.any(curves < 1) or int(curves.sum()) != n:
                raise ValueError(f"curves must be counts >= 1 that sum to the {n} particles")
            object.__setattr__(self, "curves", curves)
        if self.transforms is not None:
            centers, rotations = (np.asarray(a, dtype=float) for a in self.transforms)
            b = len(centers)
            if centers.shape != (b, 3) or rotations.shape != (b, 3, 3):
                raise ValueError(
                    "transforms must be centres (b, 3) and rotations (b, 3, 3), got "
                    f"{centers.shape} and {rotations.shape}"
                )
            object.__setattr__(self, "transforms", (centers, rotations))
        if self.surface is not None:
            vertices = np.asarray(self.surface[0], dtype=float)
            if vertices.ndim != 2 or vertices.shape[1] != 3:
                raise ValueError(f"surface vertices must have shape (v, 3), got {vertices.shape}")
            faces = _index_array("surface faces", self.surface[1], 3)
            if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
                raise ValueError("surface faces must index the surface's vertices")
            object.__setattr__(self, "surface", (vertices, faces))


def as_entry(item) -> Entry:
    """``item`` itself if it is an :class:`Entry`, ``item.entry()`` if it has that method
    (a scene body), else an entry of ``item``'s particle state alone."""
    if isinstance(item, Entry):
        return item
    method = getattr(item, "entry", None)
    if callable(method):
        entry = method()
        if not isinstance(entry, Entry):
            raise TypeError(f"{type(item).__name__}.entry() returned {type(entry).__name__}")
        return entry
    return Entry(as_state(item))
