"""Transforms of particle bodies: centre of mass and best-fit rotation (Kabsch, polar).

A body's rest particles ``r_k`` (relative to the rest centre of mass) and current
particles ``x_k`` give the centre of mass ``c = Σ f_k x_k`` (mass fractions ``f_k``) and
the rotation that best maps one onto the other in the mass-weighted least-squares sense:
the rotation factor of the polar decomposition of ``A = Σ f_k (x_k - c) r_k^T`` (Kabsch
1976; Müller et al. 2005, "Meshless deformations based on shape matching", eq. 5–7),
from the SVD ``A = U Σ V^T`` as ``R = U diag(1, 1, det(U V^T)) V^T`` so reflections are
excluded. A mesh modelled around the rest centre is drawn at ``c + R v``.
"""

from __future__ import annotations

import numpy as np


def body_transforms(position, body_start, body_particles, mass_fraction, rest):
    """Centres ``(b, 3)`` [m] and rotations ``(b, 3, 3)`` of every body.

    Parameters
    ----------
    position : (3, n) float64
        Particle positions [m].
    body_start : (b + 1,) int64
        Body ``i`` owns entries ``body_start[i]:body_start[i + 1]``.
    body_particles : (e,) int64
        Particle of each entry.
    mass_fraction : (e,) float64
        Mass of the entry's particle in the body over the body's mass.
    rest : (e, 3) float64
        Rest position of the entry relative to the body's rest centre of mass [m].
    """
    x = position[:, body_particles].T  # (e, 3)
    starts = body_start[:-1]
    if len(starts) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3, 3))
    centre = np.add.reduceat(mass_fraction[:, None] * x, starts, axis=0)
    owner = np.repeat(np.arange(len(starts)), np.diff(body_start))
    rel = x - centre[owner]
    outer = mass_fraction[:, None, None] * rel[:, :, None] * rest[:, None, :]
    a = np.add.reduceat(outer, starts, axis=0)
    u, _, vt = np.linalg.svd(a)
    flip = np.sign(np.linalg.det(u @ vt))
    flip[flip == 0] = 1.0
    u[:, :, 2] *= flip[:, None]
    return centre, u @ vt
