"""The one attribute map: what each motes attribute is called in each exported format.

A :class:`~motes.state.ParticleState` names its attributes the motes way (``positions``,
``velocities``, ``radius``, ``color``, ``ids``, ``age``, ``lifetime``, then whatever
else a kind has). Each ecosystem has its own names for the common ones, which its tools
recognise (Houdini draws ``pscale``, Blender reads PLY's ``red``, USD renderers
``widths`` and ``displayColor``):

=============  =======================  ===========================  ==========  ============
motes          Houdini ``.geo``         USD                          VTK         PLY
=============  =======================  ===========================  ==========  ============
positions      ``P`` (w = 1)            ``points``                   the points  ``x y z``
velocities     ``v``                    ``velocities``               velocities  ``vx vy vz``
radius         ``pscale``               ``widths`` = 2 × radius      radius      ``pscale``
color (RGBA)   ``Cd`` + ``Alpha``       ``displayColor`` +           color       ``red green
               (linear)                 ``displayOpacity`` (linear)  (linear)    blue alpha``
                                                                                 (uchar, sRGB)
ids            ``id``                   ``ids`` (points; a primvar   ids         ``id``
                                        on meshes and curves)
age            ``age``                  ``primvars:age``             age         ``age``
lifetime       ``life``                 ``primvars:life``            lifetime    ``life``
any other      its name                 ``primvars:NAME``            its name    its name
=============  =======================  ===========================  ==========  ============

VTK keeps the motes names: ParaView shows them as they are. A vector attribute other
than the ones above becomes ``NAME_0``, ``NAME_1``, ... in PLY, whose properties are
scalars. Colour is linear RGBA in motes, in Houdini, in USD and in VTK; PLY's bytes are
sRGB-encoded (what Blender and most viewers assume of PLY colours), alpha linear.
"""

from __future__ import annotations

import re

import numpy as np

#: Houdini ``.geo`` (and PLY) names of motes attributes that have a conventional one.
HOUDINI = {
    "positions": "P",
    "velocities": "v",
    "radius": "pscale",
    "color": "Cd",
    "ids": "id",
    "age": "age",
    "lifetime": "life",
}

#: USD names: schema attributes of ``UsdGeom.Points`` (or ``PointBased``), or primvars.
USD = {
    "positions": "points",
    "velocities": "velocities",
    "radius": "widths",
    "color": "displayColor",
    "ids": "ids",
    "lifetime": "life",
}

#: PLY property names of the vector attributes with a conventional layout.
PLY_VECTORS = {
    "positions": ("x", "y", "z"),
    "velocities": ("vx", "vy", "vz"),
    "color": ("red", "green", "blue", "alpha"),
}

#: Houdini's name for the colour's fourth channel (USD: ``displayOpacity``).
HOUDINI_ALPHA = "Alpha"
USD_OPACITY = "displayOpacity"

_PLAIN = re.compile(r"[^A-Za-z0-9_]")


def houdini_name(attribute: str) -> str:
    """The ``.geo`` point attribute (and PLY property) that holds ``attribute``."""
    return HOUDINI.get(attribute, attribute)


def usd_name(attribute: str) -> str:
    """The USD attribute, or primvar name (without ``primvars:``), of ``attribute``."""
    return USD.get(attribute, _PLAIN.sub("_", attribute))


def ply_names(attribute: str, components: int) -> tuple[str, ...]:
    """PLY property names of ``attribute`` with ``components`` values per particle."""
    if attribute in PLY_VECTORS and components <= len(PLY_VECTORS[attribute]):
        return PLY_VECTORS[attribute][:components]
    name = houdini_name(attribute)
    return (name,) if components == 1 else tuple(f"{name}_{k}" for k in range(components))


def srgb_bytes(linear: np.ndarray) -> np.ndarray:
    """Linear values in [0, 1] as sRGB-encoded bytes (IEC 61966-2-1), clipped."""
    from ...color import linear_to_srgb

    return np.rint(linear_to_srgb(linear) * 255.0).astype(np.uint8)


def linear_bytes(values: np.ndarray) -> np.ndarray:
    """Values in [0, 1] as bytes, linearly (alpha), clipped."""
    return np.rint(np.clip(values, 0.0, 1.0) * 255.0).astype(np.uint8)


def quaternions(rotations: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(x, y, z, w)`` of rotation matrices ``(b, 3, 3)``, shape (b, 4).

    Houdini's ``orient`` layout. Shepperd's method (1978): from the largest of the trace
    and the three diagonal terms, so the square root never comes near zero; the sign is
    chosen with ``w >= 0``.
    """
    r = np.asarray(rotations, dtype=np.float64).reshape(-1, 3, 3)
    m00, m11, m22 = r[:, 0, 0], r[:, 1, 1], r[:, 2, 2]
    trace = m00 + m11 + m22
    choice = np.argmax(np.stack([trace, m00, m11, m22], axis=1), axis=1)
    q = np.empty((len(r), 4))
    # w largest
    s = np.sqrt(np.maximum(1.0 + trace, 1e-300)) * 2.0
    qw = np.stack(
        [(r[:, 2, 1] - r[:, 1, 2]) / s, (r[:, 0, 2] - r[:, 2, 0]) / s,
         (r[:, 1, 0] - r[:, 0, 1]) / s, 0.25 * s], axis=1,
    )  # fmt: skip
    s = np.sqrt(np.maximum(1.0 + m00 - m11 - m22, 1e-300)) * 2.0
    qx = np.stack(
        [0.25 * s, (r[:, 0, 1] + r[:, 1, 0]) / s,
         (r[:, 0, 2] + r[:, 2, 0]) / s, (r[:, 2, 1] - r[:, 1, 2]) / s], axis=1,
    )  # fmt: skip
    s = np.sqrt(np.maximum(1.0 - m00 + m11 - m22, 1e-300)) * 2.0
    qy = np.stack(
        [(r[:, 0, 1] + r[:, 1, 0]) / s, 0.25 * s,
         (r[:, 1, 2] + r[:, 2, 1]) / s, (r[:, 0, 2] - r[:, 2, 0]) / s], axis=1,
    )  # fmt: skip
    s = np.sqrt(np.maximum(1.0 - m00 - m11 + m22, 1e-300)) * 2.0
    qz = np.stack(
        [(r[:, 0, 2] + r[:, 2, 0]) / s, (r[:, 1, 2] + r[:, 2, 1]) / s,
         0.25 * s, (r[:, 1, 0] - r[:, 0, 1]) / s], axis=1,
    )  # fmt: skip
    for k, candidate in enumerate((qw, qx, qy, qz)):
        q[choice == k] = candidate[choice == k]
    q *= np.where(q[:, 3:] < 0, -1.0, 1.0)
    return q / np.linalg.norm(q, axis=1, keepdims=True)
