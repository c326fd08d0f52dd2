"""Boids as small birds: one triangle mesh of every boid, oriented, banked and flapping.

Each bird is 15 vertices and 12 triangles in its own frame: forward ``f`` along its
heading, right ``r = f × y`` (horizontal), up ``u = r × f``, rolled about ``f`` by its
bank angle (positive rolls the right wing down). A flat body diamond, a forked tail, a
thin keel below the body (so that a bird seen edge-on still shows), and two wings, each
an inner panel to the elbow and a swept-back pointed hand to the tip (a starling's
triangular wing). The wings beat with the boid's ``flap`` phase: the elbow rises and
falls by ``0.18`` of the span, the tip by ``0.35`` a little later, so a wing bends through
the beat instead of turning as a flat plate.

The vertices are computed by one parallel kernel into a flat array the renderer draws as
one :class:`~motes.geometry.TriangleMesh`, faces fixed for a given count.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit import block_bounds, block_count, parallel_kernel

#: Vertices and triangles of one bird.
VERTICES = 15
TRIANGLES = 12

# Vertex coordinates in units of the wingspan: (forward, up, right) of the rest pose;
# the wings' up coordinates are replaced by the beat. Index: name.
#   0 nose, 1 tail root, 2 belly, 3 tail tip left, 4 tail tip right,
#   5.. left wing: shoulder front, shoulder back, elbow front, elbow back, tip,
#   10.. right wing: the same.
_SHAPE = np.array(
    [
        [0.17, 0.0, 0.0], [-0.13, 0.0, 0.0], [0.0, -0.05, 0.0],
        [-0.30, 0.0, -0.08], [-0.30, 0.0, 0.08],
        [0.07, 0.0, -0.05], [-0.08, 0.0, -0.05], [0.03, 0.0, -0.27],
        [-0.10, 0.0, -0.25], [-0.16, 0.0, -0.5],
        [0.07, 0.0, 0.05], [-0.08, 0.0, 0.05], [0.03, 0.0, 0.27],
        [-0.10, 0.0, 0.25], [-0.16, 0.0, 0.5],
    ],
    dtype=np.float32,
)  # fmt: skip

_FACES = np.array(
    [
        [0, 10, 11], [0, 11, 1], [0, 1, 6], [0, 6, 5],  # body
        [1, 3, 4],  # tail
        [0, 2, 1],  # keel
        [5, 6, 8], [5, 8, 7], [7, 8, 9],  # left wing
        [10, 12, 13], [10, 13, 11], [12, 14, 13],  # right wing
    ],
    dtype=np.int32,
)  # fmt: skip


def faces(count: int) -> np.ndarray:
    """Triangles of ``count`` birds, (count · TRIANGLES, 3) int32."""
    base = (np.arange(count, dtype=np.int32) * VERTICES)[:, None, None]
    return (_FACES[None] + base).reshape(-1, 3)


@parallel_kernel
def bird_vertices(pos, head, bank, flap, span, amplitude, out, normals):
    """World positions of every bird's vertices.

    Parameters
    ----------
    pos, head : (3, n) float32
        Positions [m] and unit headings.
    bank, flap : (n,) float32
        Bank angle [rad] and wing-beat phase [rad].
    span : float
        Wingspan [m].
    amplitude : float
        Scale of the wing beat (1: the module's beat, 0: wings held level, a glide).
    out : (n · VERTICES, 3) float32
        Vertex positions [m].
    normals : (n · VERTICES, 3) float32
        The bird's up vector at each vertex (flat shading uses the faces' own normals).
    """
    n = pos.shape[1]
    shape = _SHAPE
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            fx, fy, fz = head[0, i], head[1, i], head[2, i]
            # right = f × y, horizontal; a bird flying straight up keeps +z as its right.
            rx, rz = -fz, fx
            length = np.sqrt(rx * rx + rz * rz)
            if length < np.float32(1e-6):
                rx, rz, length = np.float32(0.0), np.float32(1.0), np.float32(1.0)
            rx /= length
            rz /= length
            ry = np.float32(0.0)
            ux, uy, uz = ry * fz - rz * fy, rz * fx - rx * fz, rx * fy - ry * fx
            c = np.cos(bank[i])
            s = np.sin(bank[i])
            # Roll about f: the right wing goes down for a positive bank.
            rx, ry, rz, ux, uy, uz = (
                c * rx - s * ux, c * ry - s * uy, c * rz - s * uz,
                s * rx + c * ux, s * ry + c * uy, s * rz + c * uz,
            )  # fmt: skip
            elbow = np.float32(0.18) * amplitude * np.sin(flap[i])
            tip = np.float32(0.35) * amplitude * np.sin(flap[i] - np.float32(0.6))
            for k in range(VERTICES):
                a = shape[k, 0] * span
                b = shape[k, 1] * span
                side = shape[k, 2] * span
                wing = k % 5  # 2: elbow front, 3: elbow back, 4: tip (wing vertices)
                if k >= 5 and (wing == 2 or wing == 3):
                    b = elbow * span
                elif k >= 5 and wing == 4:
                    b = tip * span
                v = i * VERTICES + k
                out[v, 0] = pos[0, i] + a * fx + b * ux + side * rx
                out[v, 1] = pos[1, i] + a * fy + b * uy + side * ry
                out[v, 2] = pos[2, i] + a * fz + b * uz + side * rz
                normals[v, 0] = ux
                normals[v, 1] = uy
                normals[v, 2] = uz
