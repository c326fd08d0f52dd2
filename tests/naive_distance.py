"""NumPy twin of the one signed distance (:mod:`motes.geometry.distance`), read from a
packed collider row (:mod:`motes.geometry.layout`); points are (m, 3) float64."""

from __future__ import annotations

import numpy as np

from motes.geometry.layout import INSIDE, KIND, G, Kind


def closest_on_segment(p, a, b):
    """Closest points (m, 3) of segment a-b to points p (m, 3)."""
    ab = b - a
    t = np.clip((p - a) @ ab / max(ab @ ab, 1e-300), 0.0, 1.0)
    return a + t[:, None] * ab


def ball(p, centre, radius):
    """Distance to balls of centres (m, 3) and the outward normal (+y at the centre)."""
    d = p - centre
    dist = np.linalg.norm(d, axis=1)
    at_centre = dist == 0
    n = d / np.where(at_centre, 1.0, dist)[:, None]
    n[at_centre] = (0.0, 1.0, 0.0)
    return dist - radius, n


def box(p, centre, half, axes):
    """Oriented box (axes as rows): Euclidean outside, least-penetration face inside."""
    local = (p - centre) @ axes.T
    q = np.abs(local) - half
    sign = np.where(local >= 0, 1.0, -1.0)
    outside = np.maximum(q, 0.0) * sign
    dist_out = np.linalg.norm(outside, axis=1)
    is_out = dist_out > 0
    face = np.argmax(q, axis=1)  # the first of equal maxima: u before v before w
    rows = np.arange(len(p))
    n_in = np.zeros_like(p)
    n_in[rows, face] = sign[rows, face]
    n_local = np.where(is_out[:, None], outside / np.where(is_out, dist_out, 1.0)[:, None], n_in)
    return np.where(is_out, dist_out, q[rows, face]), n_local @ axes


def signed_distance(row, p):
    """(distance (m,), outward normal (m, 3)) of points p to one packed row."""
    kind, g = Kind(int(row[KIND])), row[G:]
    p = np.asarray(p, dtype=np.float64)
    if kind == Kind.PLANE:
        d, n = p @ g[:3] - g[3], np.broadcast_to(g[:3], p.shape).copy()
    elif kind == Kind.SPHERE:
        d, n = ball(p, g[:3], g[3])
    elif kind == Kind.CAPSULE:
        d, n = ball(p, closest_on_segment(p, g[:3], g[3:6]), g[6])
    elif kind == Kind.BOX:
        d, n = box(p, g[:3], g[3:6], g[6:15].reshape(3, 3))
    else:
        raise ValueError("meshes: see naive_constraints.signed_distance")
    if row[INSIDE]:
        return -d, -n
    return d, n
