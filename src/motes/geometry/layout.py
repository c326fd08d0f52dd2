"""The one collider row layout: shape kinds, columns and the packing function.

Every collider of every solver — a particle system's planes, spheres and boxes, a cloth's
or a rigid world's capsules and triangle meshes, a fluid's walls — is one row of
:data:`ROW` floats, and a set of them a table of shape (k, ROW). The columns:

====  ==================  ==========================================================
col   name                meaning
====  ==================  ==========================================================
0     ``KIND``            shape kind, a :class:`Kind` code
1     ``INSIDE``          1 keeps points *inside* the shape (a tank, a bowl): the
                          signed distance is negated; 0 keeps them outside the solid
2     ``RESPONSE``        what a particle does on contact, a
                          :class:`motes.collide.Response` code (particle systems)
3     ``FRICTION_MODEL``  0 scales the tangential velocity, 1 removes it in
                          proportion to the penetration depth (Coulomb)
4     ``RESTITUTION``     fraction of the normal speed kept on bounce [-]
5     ``FRICTION``        friction coefficient μ [-]
6     ``ADHESION``        adhesion strength β toward the wall (fluids; Akinci et
                          al. 2013) [-]
7     ``SWEPT``           1 when the path of a step is also swept against the shape
                          before the move (a-priori detection: rigid worlds, meshes)
8..   geometry            from column :data:`G`, by kind (below)
====  ==================  ==========================================================

Geometry, from ``G``, all lengths [m]:

- ``PLANE``: unit normal out of the solid (G..G+2), offset ``d`` (G+3): the solid is
  ``n · x < d``.
- ``SPHERE``: centre (G..G+2), radius (G+3).
- ``BOX`` (oriented): centre (G..G+2), half extents along its own axes (G+3..G+5), the
  axes u, v, w as unit rows (G+6..G+8, G+9..G+11, G+12..G+14).
- ``CAPSULE``: axis ends a (G..G+2) and b (G+3..G+5), radius (G+6).
- ``MESH``: grid origin (G..G+2), cell edge (G+3), cells per axis (G+4..G+6), index of
  the mesh's first cell in the concatenated grid of a table (G+7), shell half-thickness
  (G+8); its triangles and grid lists travel beside the table
  (:func:`motes.geometry.distance.mesh_distance`).

Tables are packed in float64 and cast to a solver's dtype where it needs one (the fused
particle step runs in the store's dtype).
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np


class Kind(IntEnum):
    """Shape kind of a collider row (selects the branch of the signed distance)."""

    PLANE = 0
    SPHERE = 1
    BOX = 2
    CAPSULE = 3
    MESH = 4


KIND, INSIDE, RESPONSE, FRICTION_MODEL, RESTITUTION, FRICTION, ADHESION, SWEPT = range(8)
#: First geometry column.
G = 8
#: Geometry floats of the widest kind (the oriented box).
GEOMETRY_WIDTH = 15
#: Columns of a row.
ROW = G + GEOMETRY_WIDTH

#: Geometry width of each kind (the rest of a row is zero).
_WIDTHS = {Kind.PLANE: 4, Kind.SPHERE: 4, Kind.BOX: 15, Kind.CAPSULE: 7, Kind.MESH: 9}


def pack_row(
    kind: Kind | int,
    geometry,
    *,
    inside: bool = False,
    response: int = 0,
    friction_model: int = 0,
    restitution: float = 0.0,
    friction: float = 0.0,
    adhesion: float = 0.0,
    swept: bool = False,
) -> np.ndarray:
    """One collider row, float64, shape (ROW,).

    Parameters
    ----------
    kind : Kind or int
        Shape kind.
    geometry : sequence of float
        The kind's geometry in the order of the module docstring [m].
    inside : bool
        Keep points inside the shape.
    response, friction_model : int
        Response and friction-model codes (see the module docstring).
    restitution, friction, adhesion : float
        Response coefficients [-].
    swept : bool
        Also detect a priori (before the move).
    """
    kind = Kind(kind)
    geometry = np.asarray(geometry, dtype=np.float64).ravel()
    if geometry.size != _WIDTHS[kind]:
        raise ValueError(
            f"a {kind.name} row takes {_WIDTHS[kind]} geometry floats, got {geometry.size}"
        )
    row = np.zeros(ROW)
    row[KIND] = kind
    row[INSIDE] = bool(inside)
    row[RESPONSE] = response
    row[FRICTION_MODEL] = friction_model
    row[RESTITUTION] = restitution
    row[FRICTION] = friction
    row[ADHESION] = adhesion
    row[SWEPT] = bool(swept)
    row[G : G + geometry.size] = geometry
    return row


def stack(rows) -> np.ndarray:
    """Rows as one table, float64, shape (k, ROW) (``(0, ROW)`` for none)."""
    rows = list(rows)
    return np.array(rows, dtype=np.float64).reshape(len(rows), ROW)


def grown(table: np.ndarray, amount: float) -> np.ndarray:
    """A copy of ``table`` with every shape's solid grown by ``amount`` [m].

    A point then collides with the grown shape when it comes within ``amount`` of the
    original (a cloth's or a strand's thickness): planes move out along their normal,
    radii, half extents and shell thicknesses grow; a tank (``INSIDE``) shrinks.
    """
    out = np.array(table, dtype=np.float64, copy=True)
    for row in out:
        grow = -amount if row[INSIDE] else amount
        kind = Kind(int(row[KIND]))
        if kind == Kind.PLANE:
            row[G + 3] += amount
        elif kind == Kind.SPHERE:
            row[G + 3] += grow
        elif kind == Kind.BOX:
            row[G + 3 : G + 6] += grow
        elif kind == Kind.CAPSULE:
            row[G + 6] += grow
        else:
            row[G + 8] += grow
    return out
