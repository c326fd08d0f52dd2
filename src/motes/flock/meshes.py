"""Boids drawn as small animals: one triangle mesh of every boid, oriented and animated.

Each boid's mesh is placed in its own frame: forward ``f`` along its heading, right
``r = f × y`` (horizontal), up ``u = r × f``, rolled about ``f`` by its bank angle
(positive rolls the right side down). Two animals:

- **bird** (:data:`BIRD`, 15 vertices, 12 triangles): a flat body diamond, a forked
  tail, a thin keel below the body (so that a bird seen edge-on still shows), and two
  wings, each an inner panel to the elbow and a swept-back pointed hand to the tip (a
  starling's triangular wing). The wings beat with the boid's ``flap`` phase: the elbow
  rises and falls by 0.18 of the span, the tip by 0.35 a little later, so a wing bends
  through the beat instead of turning as a flat plate. Sized by the wingspan.
- **fish** (:data:`FISH`, 8 vertices, 9 triangles): a body of two four-sided pyramids
  (deeper than wide) meeting behind the head, and a forked tail fin. The ``flap`` phase
  is the tail beat: the tail root sways sideways by 0.04 of the length, the fin by 0.12
  a little later, a wave running down the body. Sized by the length.

The vertices are computed by one parallel kernel into a flat array the renderer draws as
one :class:`~motes.geometry.TriangleMesh`, faces fixed for a given count.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import prange

from .._jit import block_bounds, block_count, device, parallel_kernel


class Shape(NamedTuple):
    """A boid's rest mesh in units of its size: ``(forward, up, right)`` coordinates
    (v, 3) float32, the triangles (f, 3) int32, and its animated vertices."""

    rest: np.ndarray
    faces: np.ndarray
    #: Vertex -> 0 (rigid), 1 (first wave: elbows, tail root), 2 (second: tips, fin).
    wave: np.ndarray
    #: Axis the wave moves a vertex along: 1 up (wings), 2 right (a tail).
    axis: int
    #: Displacements of the two waves (a fraction of the size) and the second's lag [rad].
    first: float
    second: float
    lag: float


# Bird vertices: 0 nose, 1 tail root, 2 belly, 3 tail tip left, 4 tail tip right,
# 5.. left wing: shoulder front, shoulder back, elbow front, elbow back, tip,
# 10.. right wing: the same.
BIRD = Shape(
    rest=np.array(
        [
            [0.17, 0.0, 0.0], [-0.13, 0.0, 0.0], [0.0, -0.05, 0.0],
            [-0.30, 0.0, -0.08], [-0.30, 0.0, 0.08],
            [0.07, 0.0, -0.05], [-0.08, 0.0, -0.05], [0.03, 0.0, -0.27],
            [-0.10, 0.0, -0.25], [-0.16, 0.0, -0.5],
            [0.07, 0.0, 0.05], [-0.08, 0.0, 0.05], [0.03, 0.0, 0.27],
            [-0.10, 0.0, 0.25], [-0.16, 0.0, 0.5],
        ],
        dtype=np.float32,
    ),
    faces=np.array(
        [
            [0, 10, 11], [0, 11, 1], [0, 1, 6], [0, 6, 5],  # body
            [1, 3, 4],  # tail
            [0, 2, 1],  # keel
            [5, 6, 8], [5, 8, 7], [7, 8, 9],  # left wing
            [10, 12, 13], [10, 13, 11], [12, 14, 13],  # right wing
        ],
        dtype=np.int32,
    ),
    wave=np.array([0, 0, 0, 0, 0, 0, 0, 1, 1, 2, 0, 0, 1, 1, 2], np.int64),
    axis=1,
    first=0.18,
    second=0.35,
    lag=0.6,
)  # fmt: skip

# Fish vertices: 0 snout, 1 back, 2 belly, 3 right flank, 4 left flank, 5 tail root,
# 6 fin top, 7 fin bottom.
FISH = Shape(
    rest=np.array(
        [
            [0.5, 0.0, 0.0], [0.05, 0.14, 0.0], [0.05, -0.12, 0.0], [0.08, 0.0, 0.06],
            [0.08, 0.0, -0.06], [-0.32, 0.0, 0.0], [-0.5, 0.14, 0.0], [-0.5, -0.14, 0.0],
        ],
        dtype=np.float32,
    ),
    faces=np.array(
        [
            [0, 1, 3], [0, 3, 2], [0, 2, 4], [0, 4, 1],  # head
            [1, 5, 3], [3, 5, 2], [2, 5, 4], [4, 5, 1],  # body to the tail root
            [5, 6, 7],  # tail fin
        ],
        dtype=np.int32,
    ),
    wave=np.array([0, 0, 0, 0, 0, 1, 2, 2], np.int64),
    axis=2,
    first=0.04,
    second=0.12,
    lag=0.8,
)  # fmt: skip

#: Vertices and triangles of one bird (the default shape).
VERTICES = len(BIRD.rest)
TRIANGLES = len(BIRD.faces)


def faces(count: int, shape: Shape = BIRD) -> np.ndarray:
    """Triangles of ``count`` boids, (count · f, 3) int32."""
    base = (np.arange(count, dtype=np.int32) * len(shape.rest))[:, None, None]
    return (shape.faces[None] + base).reshape(-1, 3)


def vertices(pos, head, bank, flap, size: float, amplitude: float, shape: Shape = BIRD):
    """Every boid's vertices [m], (n · v, 3) float32, and its up vector at each vertex
    (flat shading uses the faces' own normals). ``pos``, ``head`` (3, n); ``bank``,
    ``flap`` (n,) [rad]; ``size`` the wingspan or length [m]; ``amplitude`` scales the
    beat (0: wings level, tail straight)."""
    n = pos.shape[1]
    out = np.empty((n * len(shape.rest), 3), np.float32)
    normals = np.empty_like(out)
    shape_vertices(
        pos, head, bank, flap, np.float32(size), np.float32(amplitude), shape.rest,
        shape.wave, shape.axis, np.float32(shape.first), np.float32(shape.second),
        np.float32(shape.lag), out, normals,
    )  # fmt: skip
    return out, normals


@device
def _frame(fx, fy, fz, bank):
    """Right and up of a boid heading ``f``, rolled by ``bank`` (right side down)."""
    # right = f × y, horizontal; a boid heading straight up keeps +z as its right.
    rx, rz = -fz, fx
    length = np.sqrt(rx * rx + rz * rz)
    if length < np.float32(1e-6):
        rx, rz, length = np.float32(0.0), np.float32(1.0), np.float32(1.0)
    rx /= length
    rz /= length
    ry = np.float32(0.0)
    ux, uy, uz = ry * fz - rz * fy, rz * fx - rx * fz, rx * fy - ry * fx
    c = np.cos(bank)
    s = np.sin(bank)
    return (
        c * rx - s * ux, c * ry - s * uy, c * rz - s * uz,
        s * rx + c * ux, s * ry + c * uy, s * rz + c * uz,
    )  # fmt: skip


@parallel_kernel
def shape_vertices(
    pos, head, bank, flap, size, amplitude, rest, wave, axis, first, second, lag, out, normals
):
    """World positions of every boid's vertices: ``rest`` (v, 3) (forward, up, right)
    in units of ``size`` [m], the vertices of ``wave`` 1 and 2 moved along ``axis`` by
    ``first · sin(flap)`` and ``second · sin(flap - lag)`` times ``amplitude``; outputs
    ``out`` and ``normals`` (n · v, 3)."""
    n = pos.shape[1]
    v = rest.shape[0]
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            fx, fy, fz = head[0, i], head[1, i], head[2, i]
            rx, ry, rz, ux, uy, uz = _frame(fx, fy, fz, bank[i])
            beat1 = first * amplitude * np.sin(flap[i])
            beat2 = second * amplitude * np.sin(flap[i] - lag)
            for k in range(v):
                a = rest[k, 0]
                b = rest[k, 1]
                side = rest[k, 2]
                shift = beat1 if wave[k] == 1 else (beat2 if wave[k] == 2 else np.float32(0.0))
                if wave[k] > 0:
                    if axis == 1:
                        b = shift
                    else:
                        side = shift
                a *= size
                b *= size
                side *= size
                o = i * v + k
                out[o, 0] = pos[0, i] + a * fx + b * ux + side * rx
                out[o, 1] = pos[1, i] + a * fy + b * uy + side * ry
                out[o, 2] = pos[2, i] + a * fz + b * uz + side * rz
                normals[o, 0] = ux
                normals[o, 1] = uy
                normals[o, 2] = uz
