"""Emitter particles against the bodies of a rigid world, momentum passing both ways
(debris that knocks a box over).

The world's boxes (bodies whose shape is a box, :meth:`motes.rigid.BodyShape.box_geometry`)
and balls (particles that collide as spheres, :meth:`motes.rigid.World.add_sphere_contacts`)
are packed at every exchange as collider rows (:mod:`motes.geometry.layout`) at their
poses now, grown by ``thickness``. After an emitter system moves, each particle's path
over the step, from ``x - v Δt`` to ``x``, is tested against every row in that body's
frame: the path starts where the body's rigid motion since the last exchange carried the
start, so that a body that moved onto a particle is entered through the face it came
with, not left through the nearest one. The test is the one of every swept detection
(:func:`~motes.geometry.sweep.first_hit`); the earliest entry is the contact, so
neither a fast particle nor a fast body passes the other. A path that starts inside a
grown shape and goes further in touches it at its start; a particle whose paths enter
nothing but that ends inside a shape is put out where the signed distance
(:func:`~motes.geometry.distance.row_signed_distance`) says.

The particle, put at ``s`` on the grown surface with outward normal ``n``, and the body
exchange an impulse ``J`` at ``s``. With ``ρ = s - c`` from the body's centre of mass, the
body's velocity there ``u = V + ω × ρ`` and its generalised inverse mass
``w(d) = 1/M + (ρ × d)ᵀ I⁻¹ (ρ × d)`` along a unit ``d``
(:func:`motes.rigid.body_contacts.body_weight`; Müller et al. 2020, eq. 2–3):

- normal: ``j_n = -(1 + e) v_n / (1/m_p + w(n))`` when approaching, where ``v_n`` is the
  normal velocity of the particle relative to ``u``;
- tangent: Coulomb friction along the relative sliding ``t``,
  ``j_t = min(v_t / (1/m_p + w(t)), μ j_n)``, never reversing the sliding;
- the particle gets ``+J / m_p`` and is put at ``s`` (plus a micrometre,
  :data:`motes.collide.swept.GAP`); the body gets ``-J`` through its centre and
  ``-ρ × J`` about it (:meth:`motes.rigid.World.add_impulse`), which changes its
  particles' momentum by exactly ``-J`` and their angular momentum about any fixed point
  ``o`` by ``-(s - o) × J`` (:mod:`motes.rigid.motion`).

So momentum is exchanged exactly. Angular momentum is too when the body has not moved
since the last exchange (``s`` then lies on the particle's own path, and a particle
carries no spin), but for the stand-off GAP; against a body that moved by ``δ``, putting
the particle back on the body where the body is now shifts the particle's line by at
most ``|δ|``.

Impulses are applied serially in particle order, each against the body's velocity as the
impulses before it left it (thread-count independent); detection runs in parallel
blocks. The world is taken at its state at the start of the exchange and integrates the
impulses at its next step: a scene steps its emitter systems before its bodies
(``docs/architecture.md``), so that is the same substep.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .. import _validate as check
from .._jit import block_bounds, block_count, device, parallel_kernel, serial_kernel
from ..collide.between import KindContact
from ..collide.swept import GAP
from ..geometry.distance import row_signed_distance
from ..geometry.layout import KIND, G, Kind, grown, pack_row, stack
from ..geometry.sweep import first_hit
from ..rigid.body_contacts import body_weight

RESPONSES = ("bounce", "kill")

_BOX = int(Kind.BOX)


@device
def _carried(before, rows, r, px, py, pz):
    """Point ``p`` moved with shape ``r`` from its pose at the last exchange (``before``)
    to its pose now (``rows``): a rigid motion for a box, a translation for a ball."""
    ox, oy, oz = px - before[r, G], py - before[r, G + 1], pz - before[r, G + 2]
    qx, qy, qz = rows[r, G], rows[r, G + 1], rows[r, G + 2]
    if int(rows[r, KIND]) != _BOX:
        return qx + ox, qy + oy, qz + oz
    for a in range(3):
        c = G + 6 + 3 * a
        local = ox * before[r, c] + oy * before[r, c + 1] + oz * before[r, c + 2]
        qx += local * rows[r, c]
        qy += local * rows[r, c + 1]
        qz += local * rows[r, c + 2]
    return qx, qy, qz


@parallel_kernel
def _detect(n, x, v, dt, rows, before, out_row, out_p, out_n):
    """Per particle: the row touched (or -1), the contact point on the grown surface and
    the outward normal there. The path of a particle against row ``r`` starts where its
    start ``x - v dt`` is carried by the shape's motion since ``before``."""
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            px, py, pz = float(x[0, i]), float(x[1, i]), float(x[2, i])
            bx = px - float(v[0, i]) * dt
            by = py - float(v[1, i]) * dt
            bz = pz - float(v[2, i]) * dt
            best = np.inf
            best_r = -1
            hx = hy = hz = fx = fy = fz = 0.0
            for r in range(rows.shape[0]):
                ax, ay, az = _carried(before, rows, r, bx, by, bz)
                dx, dy, dz = px - ax, py - ay, pz - az
                kind = int(rows[r, KIND])
                enter, nx, ny, nz = first_hit(
                    kind, False, rows, r, ax, ay, az, dx, dy, dz, 0.0, 0.0, 0.0, 0.0, 1.0
                )
                if enter <= 1.0:
                    if enter < best:
                        best, best_r = enter, r
                        hx, hy, hz = ax + enter * dx, ay + enter * dy, az + enter * dz
                        fx, fy, fz = nx, ny, nz
                    continue
                # A path that starts inside the grown shape enters nothing: it touches at
                # its start if it goes further in (else it is leaving, or sliding along).
                dist, nx, ny, nz = row_signed_distance(rows, r, ax, ay, az, 1.0)
                if dist < 0.0 and best > 0.0 and dx * nx + dy * ny + dz * nz < 0.0:
                    best, best_r = 0.0, r
                    hx, hy, hz = ax - dist * nx, ay - dist * ny, az - dist * nz
                    fx, fy, fz = nx, ny, nz
            if best_r < 0:
                # No entry along any path: the end inside a shape (round-off, a path
                # that started inside).
                deepest = 0.0
                for r in range(rows.shape[0]):
                    dist, nx, ny, nz = row_signed_distance(rows, r, px, py, pz, 1.0)
                    if dist < deepest:
                        deepest, best_r = dist, r
                        hx, hy, hz = px - dist * nx, py - dist * ny, pz - dist * nz
                        fx, fy, fz = nx, ny, nz
            out_row[i] = best_r
            out_p[0, i], out_p[1, i], out_p[2, i] = hx, hy, hz
            out_n[0, i], out_n[1, i], out_n[2, i] = fx, fy, fz


@serial_kernel
def _respond(
    n, x, v, mass, mass_stride, hit_row, hit_p, hit_n, owner, centre, linear, angular,
    inv_mass, inv_inertia, restitution, friction, kill, keep, hits, track, hit_index,
    impulse, angular_impulse,
):  # fmt: skip
    """Exchange impulses in particle order; returns the number of particles killed.

    ``linear`` and ``angular`` (k, 3), the bodies' velocities, are updated as impulses
    land; ``impulse`` and ``angular_impulse`` (k, 3) sum what each body received [N s],
    [N m s] (about its centre)."""
    killed = 0
    for i in range(n):
        r = hit_row[i]
        if r < 0:
            continue
        b = owner[r]
        sx, sy, sz = hit_p[0, i], hit_p[1, i], hit_p[2, i]
        nx, ny, nz = hit_n[0, i], hit_n[1, i], hit_n[2, i]
        rx, ry, rz = sx - centre[b, 0], sy - centre[b, 1], sz - centre[b, 2]
        wx, wy, wz = angular[b, 0], angular[b, 1], angular[b, 2]
        ux = linear[b, 0] + wy * rz - wz * ry
        uy = linear[b, 1] + wz * rx - wx * rz
        uz = linear[b, 2] + wx * ry - wy * rx
        qx, qy, qz = float(v[0, i]) - ux, float(v[1, i]) - uy, float(v[2, i]) - uz
        vn = qx * nx + qy * ny + qz * nz
        inv_p = 1.0 / float(mass[i * mass_stride])
        iinv = inv_inertia[b]
        e = 0.0 if kill else restitution
        jn = 0.0
        if vn < 0.0:
            jn = -(1.0 + e) * vn / (inv_p + body_weight(inv_mass[b], iinv, rx, ry, rz, nx, ny, nz))
        tx, ty, tz = qx - vn * nx, qy - vn * ny, qz - vn * nz
        vt = np.sqrt(tx * tx + ty * ty + tz * tz)
        jt = 0.0
        if vt > 0.0 and jn > 0.0:
            tx, ty, tz = tx / vt, ty / vt, tz / vt
            w = inv_p + body_weight(inv_mass[b], iinv, rx, ry, rz, tx, ty, tz)
            jt = min(vt / w, friction * jn)
        jx, jy, jz = jn * nx - jt * tx, jn * ny - jt * ty, jn * nz - jt * tz
        v[0, i] += jx * inv_p
        v[1, i] += jy * inv_p
        v[2, i] += jz * inv_p
        # The body takes -J at s: -J through its centre and -rho x J about it.
        cx, cy, cz = ry * jz - rz * jy, rz * jx - rx * jz, rx * jy - ry * jx
        impulse[b, 0] -= jx
        impulse[b, 1] -= jy
        impulse[b, 2] -= jz
        angular_impulse[b, 0] -= cx
        angular_impulse[b, 1] -= cy
        angular_impulse[b, 2] -= cz
        linear[b, 0] -= jx * inv_mass[b]
        linear[b, 1] -= jy * inv_mass[b]
        linear[b, 2] -= jz * inv_mass[b]
        for a in range(3):
            angular[b, a] -= iinv[a, 0] * cx + iinv[a, 1] * cy + iinv[a, 2] * cz
        x[0, i] = sx + GAP * nx
        x[1, i] = sy + GAP * ny
        x[2, i] = sz + GAP * nz
        if kill:
            keep[i] = False
            killed += 1
        if track:
            hits[i] = hit_index
    return killed


class RigidContact(KindContact):
    """The boxes and balls of a rigid world that an emitter system's particles hit, and
    push.

    Parameters
    ----------
    world : motes.rigid.World
        The world (its bodies' poses, velocities and masses now are used; its particles
        receive the reactions through :meth:`~motes.rigid.World.add_impulse`).
    bodies : sequence of Body or int, optional
        The box bodies the particles hit; by default every box the world has now.
    spheres : sequence of int, optional
        Particles of the world hit as balls of their radius; by default every particle
        that collides as a sphere now (:meth:`~motes.rigid.World.add_sphere_contacts`).
        Pass ``()`` for none.
    restitution : float
        Fraction of the relative normal speed kept on bounce, in [0, 1].
    friction : float
        Coulomb coefficient μ >= 0 of the tangential impulse.
    thickness : float
        Distance > 0 [m] kept between the particles' centres and the bodies' surfaces.
    response : str
        ``"bounce"`` or ``"kill"`` (the particle gives up its normal momentum relative to
        the body, as with restitution 0, and dies: debris that shatters).
    particle_mass : float, optional
        Mass of every particle [kg]; by default each particle's ``mass`` attribute.
    """

    def __init__(
        self,
        world,
        *,
        bodies=None,
        spheres=None,
        restitution: float = 0.0,
        friction: float = 0.0,
        thickness: float = 0.01,
        response: str = "bounce",
        particle_mass: float | None = None,
    ):
        for name in ("boxes", "motion", "add_impulse", "spheres"):
            if not hasattr(world, name):
                raise TypeError(f"world must be a motes rigid World, got {type(world).__name__}")
        self.world = world
        self.restitution = check.unit_interval("restitution", restitution)
        self.friction = check.non_negative("friction", friction)
        self.thickness = check.positive("thickness", thickness)
        self.response = check.choice("response", response, RESPONSES)
        self.particle_mass = (
            None if particle_mass is None else check.positive("particle_mass", particle_mass)
        )
        self.reads = () if particle_mass is not None else ("mass",)
        boxes = world.boxes()[0].tolist()
        if bodies is None:
            self.bodies = boxes
        else:
            self.bodies = [int(getattr(b, "index", b)) for b in bodies]
            for b in self.bodies:
                if b not in boxes:
                    kind = "not a body" if not 0 <= b < len(world.bodies) else "not a box"
                    raise ValueError(
                        f"bodies: body {b} of the world is {kind}; particles hit boxes "
                        f"(the world's: {boxes})"
                    )
        balls = world.spheres.tolist()
        if spheres is None:
            self.spheres = balls
        else:
            self.spheres = [int(p) for p in np.atleast_1d(np.asarray(spheres, dtype=np.int64))]
            for p in self.spheres:
                if not 0 <= p < world.count or world.radius[p] <= 0:
                    raise ValueError(
                        f"spheres: particle {p} of the world is not a ball of radius > 0"
                    )
        if not self.bodies and not self.spheres:
            raise ValueError(
                "world: a rigid world without boxes or balls (sphere contacts) has nothing "
                "emitter particles can hit"
            )
        #: Impulse [N s] and angular impulse about the centre [N m s] each box, then each
        #: ball, received in the last exchange, (bodies + spheres, 3).
        self.impulse = np.zeros((len(self.bodies) + len(self.spheres), 3))
        self.angular_impulse = np.zeros_like(self.impulse)
        self._buffers: tuple | None = None
        self._no_hits = np.empty(1, np.int32)
        self._before: np.ndarray | None = None  # the rows at the last exchange

    def _scratch(self, capacity: int) -> tuple:
        if self._buffers is None or self._buffers[0].shape[0] < capacity:
            self._buffers = (
                np.empty(capacity, np.int64),
                np.empty((3, capacity)),
                np.empty((3, capacity)),
            )
        return self._buffers

    def _groups(self) -> list:
        bodies = self.world.bodies
        particles = [bodies[b].particles for b in self.bodies]
        return particles + [np.array([p]) for p in self.spheres]

    def _rows(self) -> np.ndarray:
        """The boxes and balls now, one row each, grown by the thickness."""
        index, centre, half, axes = self.world.boxes()
        where = {int(b): k for k, b in enumerate(index)}
        rows = [
            pack_row(Kind.BOX, [*centre[k], *half[k], *axes[k].ravel()])
            for k in (where[b] for b in self.bodies)
        ]
        position, radius = self.world.position, self.world.radius
        rows += [pack_row(Kind.SPHERE, [*position[p], radius[p]]) for p in self.spheres]
        return grown(stack(rows), self.thickness)

    def resolve(self, store, n, dt, hits, hit_index) -> int:
        self.impulse[:] = 0.0
        self.angular_impulse[:] = 0.0
        # The poses now, and at the last exchange (where the paths' starts were).
        rows = self._rows()
        before = self._before
        if before is None or before.shape != rows.shape:
            before = rows
        self._before = rows
        if n == 0:
            return 0
        hit_row, hit_p, hit_n = self._scratch(store.capacity)
        x, v = store.raw("position"), store.raw("velocity")
        _detect(n, x, v, float(dt), rows, before, hit_row, hit_p, hit_n)
        if not (hit_row[:n] >= 0).any():
            return 0
        if self.particle_mass is None:
            mass, stride = store.raw("mass"), 1
        else:
            mass, stride = np.full(1, self.particle_mass), 0
        groups = self._groups()
        motion = self.world.motion(groups)
        track = hits is not None
        if not track:
            hits = self._no_hits
        killed = _respond(
            n, x, v, mass, stride, hit_row, hit_p, hit_n, np.arange(len(rows)),
            motion.centre, motion.velocity.copy(), motion.angular_velocity.copy(),
            motion.inverse_mass, np.ascontiguousarray(motion.inverse_inertia),
            self.restitution, self.friction, self.response == "kill", store.keep, hits,
            track, hit_index, self.impulse, self.angular_impulse,
        )  # fmt: skip
        touched = np.flatnonzero(np.abs(self.impulse).sum(axis=1) > 0)
        if len(touched):
            self.world.add_impulse(
                [groups[k] for k in touched], self.impulse[touched], self.angular_impulse[touched]
            )
        return int(killed)
