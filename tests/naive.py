"""Slow, obviously correct NumPy twins of the compiled kernels (arrays are (n, 3))."""

from __future__ import annotations

import numpy as np

import naive_distance
from motes.collide.colliders import Friction, Response


def field_acceleration(v, w, gravity, k_lin, k_wind, k_quad, q_wind):
    """a = g [w>0] + w (k·wind_sum - k v - c |v - u| (v - u))."""
    u = v - q_wind
    speed = np.linalg.norm(u, axis=1, keepdims=True)
    force = k_wind - k_lin * v - k_quad * speed * u
    return (w > 0)[:, None] * gravity + w[:, None] * force


def penetration(collider, p):
    """(depth (n,), normal (n, 3)) of points p against one collider: minus the signed
    distance of its packed row (the twin in :mod:`naive_distance`)."""
    d, n = naive_distance.signed_distance(collider.packed(), p)
    return -d, n


def respond(collider, p, v, depth, n, dt):
    """(p, v, hit, kill) after push-out and response."""
    hit = depth > 0
    if collider.response == Response.EVENT:
        return p, v, hit, np.zeros_like(hit)
    p = p + np.where(hit, depth, 0)[:, None] * n
    if collider.response == Response.KILL:
        return p, v, hit, hit
    if collider.response == Response.STICK:
        return p, np.where(hit[:, None], 0.0, v), hit, np.zeros_like(hit)
    vn = np.sum(v * n, axis=1)
    t = v - vn[:, None] * n
    vn_out = np.where(hit & (vn < 0), -collider.restitution * vn, vn)
    if collider.friction_model == Friction.DEPTH:
        vt = np.linalg.norm(t, axis=1)
        slow = collider.friction * np.where(hit, depth, 0) / dt
        scale = np.where(vt > slow, (vt - slow) / np.where(vt > 0, vt, 1), 0.0)
    else:
        scale = np.full(len(p), 1 - collider.friction)
    scale = np.where(hit, scale, 1.0)
    return p, t * scale[:, None] + vn_out[:, None] * n, hit, np.zeros_like(hit)


def step(scheme, p, v, age, life, w, force, fields, colliders, dt, damping=0.0):
    """One fused step. ``scheme`` in {"explicit", "semi", "verlet", "none"}.

    Returns (p, v, age, keep, last_hit).
    """
    p, v = p.copy(), v.copy()
    if scheme != "none":
        a = field_acceleration(v, w, *fields) + w[:, None] * force
    if scheme == "explicit":
        p, v = p + dt * v, v + dt * a
    elif scheme == "semi":
        v = v + dt * a
        p = p + dt * v
    elif scheme == "verlet":
        prev = p - v * dt  # the velocity stands for (x - x_prev) / dt
        new = p + (p - prev) * (1 - damping) + a * dt * dt
        v = (new - p) / dt
        p = new
    killed = np.zeros(len(p), dtype=bool)
    last = np.full(len(p), -1)
    for c, collider in enumerate(colliders):
        depth, n = penetration(collider, p)
        p, v, hit, kill = respond(collider, p, v, depth, n, dt)
        killed |= kill
        last = np.where(hit, c, last)
    age = age + dt
    keep = ~(killed | (age >= life))
    return p, v, age, keep, last


def compact(arrays, keep):
    """Stable compaction of every array (first axis)."""
    return [a[keep] for a in arrays]


def curve(t, times, values):
    """Piecewise-linear interpolation of each column of ``values`` at ``t``."""
    return np.stack([np.interp(t, times, values[:, c]) for c in range(values.shape[1])], axis=1)


def first_non_finite(values, *, infinite_ok=False):
    """Index of the first column of ``values`` ((c, n) or (n,)) holding NaN or infinity
    (NaN only with ``infinite_ok``), or -1: the twin of ``finite.first_at_least``
    over an attribute's rows."""
    rows = np.asarray(values).reshape(-1, np.asarray(values).shape[-1])
    bad = np.isnan(rows) if infinite_ok else ~np.isfinite(rows)
    hits = np.flatnonzero(bad.any(axis=0))
    return int(hits[0]) if hits.size else -1
