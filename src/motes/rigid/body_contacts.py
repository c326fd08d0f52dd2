"""Body against body: particles projected out of other bodies' convex shapes.

Each solid body (a tetrahedron, a box, a convex hull of particles) carries its faces as
planes ``n · r <= d`` in its rest frame. Once per substep the body's transform (centre
of mass ``c``, rotation ``R``) and world inverse inertia are read from its particles;
then, in every relaxation iteration, each particle ``a`` of another body whose local
position ``R^T (x_a - c)`` lies within its radius ``r`` of inside every plane is pushed
out by the depth ``p`` (Jakobsen 2001, §4, "collision between rigid bodies").

The normal ``n`` is one per pair of bodies: the face, of either body, along which the
pair overlaps least (a separating-axis test over both bodies' faces). The particles of
the other body inside it are pushed out along ``n``, and the face's body's particles
inside the other along ``-n`` (a box lying across a narrower plank has no corner inside
the plank, but the plank has corners inside the box). Edges of either body that cross
the other with both ends outside it (two boxes crossed edge to edge) add contacts at
their deepest point (:func:`_edge_contacts`). The face of least
penetration of each particle on its own fails for a box resting on an equal one: its
corners lie on the side faces too, and once the stack's weight presses them deeper than
their radius they are pushed sideways. Bodies need a radius > 0 to stack: a corner
exactly on a rim is otherwise outside.

The correction moves both bodies rigidly, as in Müller et al. 2020 ("Detailed rigid
body simulation with extended position based dynamics", eq. 2–3 and 6–9): at a contact
point ``ρ`` from a body's centre its generalised inverse mass is
``w = 1/M + (ρ × n)^T I^{-1} (ρ × n)``; the multiplier ``Δλ = p / (w_A + w_B)`` moves
every particle ``k`` of a body by ``±Δλ (n / M + (I^{-1}(ρ × n)) × (x_k - c))`` (to
first order; the sticks absorb the second-order stretch). Moving only the intruding
particle, or spreading the correction over the other body's particles by affine weights
(Jakobsen's stick example generalised), deforms the bodies, which their sticks then
undo; in a stack of equal boxes that exchange grew a tilting mode that doubled every
step. The contacts of a pair are solved from one state and averaged (each applied with
``Δλ / count``, Jacobi style), for the same reason. Friction reduces the tangential
travel of the bodies' centres against each other by at most ``μ p_max``, moving them
as a whole. Pairs of bodies
in one ``group`` (the parts of a ragdoll) do not collide. The kernel is serial: bodies
are few, and the order of the pairs is fixed.
"""

from __future__ import annotations

import numpy as np

from .._jit import device, serial_kernel
from .rotation import matmul3, update_rotations


@device
def _move_body(
    px,
    py,
    pz,
    body_start,
    body_particles,
    b,
    cx,
    cy,
    cz,
    inv_mass_b,
    iinv,
    rx,
    ry,
    rz,
    nx,
    ny,
    nz,
    lam,
):
    """Move body b rigidly by the impulse -lam n applied at c + rho (first order)."""
    tx = ry * nz - rz * ny
    ty = rz * nx - rx * nz
    tz = rx * ny - ry * nx
    wx = -lam * (iinv[0, 0] * tx + iinv[0, 1] * ty + iinv[0, 2] * tz)
    wy = -lam * (iinv[1, 0] * tx + iinv[1, 1] * ty + iinv[1, 2] * tz)
    wz = -lam * (iinv[2, 0] * tx + iinv[2, 1] * ty + iinv[2, 2] * tz)
    vx, vy, vz = -lam * inv_mass_b * nx, -lam * inv_mass_b * ny, -lam * inv_mass_b * nz
    for e in range(body_start[b], body_start[b + 1]):
        k = body_particles[e]
        dx, dy, dz = px[k] - cx, py[k] - cy, pz[k] - cz
        px[k] += vx + wy * dz - wz * dy
        py[k] += vy + wz * dx - wx * dz
        pz[k] += vz + wx * dy - wy * dx


@device
def _push(
    px,
    py,
    pz,
    body_start,
    body_particles,
    centre,
    body_inv_mass,
    ia,
    ib,
    a,
    b,
    ax,
    ay,
    az,
    bx,
    by,
    bz,
    sx,
    sy,
    sz,
    rx,
    ry,
    rz,
    nx,
    ny,
    nz,
    lam,
):
    """Impulse +lam n on body a at centre + s, -lam n on body b at centre + r."""
    _move_body(
        px,
        py,
        pz,
        body_start,
        body_particles,
        a,
        ax,
        ay,
        az,
        body_inv_mass[a],
        ia,
        sx,
        sy,
        sz,
        -nx,
        -ny,
        -nz,
        lam,
    )
    _move_body(
        px,
        py,
        pz,
        body_start,
        body_particles,
        b,
        bx,
        by,
        bz,
        body_inv_mass[b],
        ib,
        rx,
        ry,
        rz,
        nx,
        ny,
        nz,
        lam,
    )
    centre[a, 0] += lam * body_inv_mass[a] * nx
    centre[a, 1] += lam * body_inv_mass[a] * ny
    centre[a, 2] += lam * body_inv_mass[a] * nz
    centre[b, 0] -= lam * body_inv_mass[b] * nx
    centre[b, 1] -= lam * body_inv_mass[b] * ny
    centre[b, 2] -= lam * body_inv_mass[b] * nz


@device
def body_weight(inv_mass_b, iinv, rx, ry, rz, nx, ny, nz):
    """Generalised inverse mass ``1/M + (ρ × n)ᵀ I⁻¹ (ρ × n)`` [1/kg] of a body at a
    point ``ρ`` from its centre along the unit ``n`` (Müller et al. 2020, eq. 2–3)."""
    tx = ry * nz - rz * ny
    ty = rz * nx - rx * nz
    tz = rx * ny - ry * nx
    return inv_mass_b + (
        tx * (iinv[0, 0] * tx + iinv[0, 1] * ty + iinv[0, 2] * tz)
        + ty * (iinv[1, 0] * tx + iinv[1, 1] * ty + iinv[1, 2] * tz)
        + tz * (iinv[2, 0] * tx + iinv[2, 1] * ty + iinv[2, 2] * tz)
    )


@device
def _overlap(
    px, py, pz, radius, body_start, body_particles, plane_start, planes, centre, rotation, a, b
):
    """Least overlap of body a's particles with b along b's faces, and that face."""
    rot = rotation[b]
    face = -1
    least = np.inf
    for f in range(plane_start[b], plane_start[b + 1]):
        nx = rot[0, 0] * planes[f, 0] + rot[0, 1] * planes[f, 1] + rot[0, 2] * planes[f, 2]
        ny = rot[1, 0] * planes[f, 0] + rot[1, 1] * planes[f, 1] + rot[1, 2] * planes[f, 2]
        nz = rot[2, 0] * planes[f, 0] + rot[2, 1] * planes[f, 1] + rot[2, 2] * planes[f, 2]
        deepest = -np.inf
        for ea in range(body_start[a], body_start[a + 1]):
            i = body_particles[ea]
            s = (px[i] - centre[b, 0]) * nx + (py[i] - centre[b, 1]) * ny
            s += (pz[i] - centre[b, 2]) * nz - planes[f, 3]
            deepest = max(deepest, radius[i] - s)
        if deepest < least:
            least = deepest
            face = f
    return least, face


@device
def _exit(planes, first, last, lx, ly, lz, ux, uy, uz, r):
    """Distance along unit u (host frame) from a point to the outside of the host's
    faces grown by r; -1 when the point is outside already."""
    t = np.inf
    for f in range(first, last):
        s = planes[f, 0] * lx + planes[f, 1] * ly + planes[f, 2] * lz - planes[f, 3]
        if s >= r:
            return -1.0
        along = planes[f, 0] * ux + planes[f, 1] * uy + planes[f, 2] * uz
        if along > 1e-9:
            t = min(t, (r - s) / along)
    return t if t < np.inf else -1.0


@serial_kernel
def _edge_contacts(
    px,
    py,
    pz,
    radius,
    edge_start,
    edges,
    plane_start,
    planes,
    centre,
    rotation,
    intruder,
    host,
    sign,
    nx,
    ny,
    nz,
    a,
    b,
    found,
    count,
):
    """Contacts of the intruder's edges that cross the host with both ends outside it.

    Vertex tests miss an edge lying across a face (a crate across a narrower plank).
    Each edge is clipped to the host's faces grown by the particle radius (Cyrus & Beck
    1978); the point of the clipped part deepest along ``sign * n`` (the intruder's way
    out), found among four samples, becomes a contact. Rows are written to ``found`` in
    the (depth, rho_a, rho_b) layout of the caller; returns the new count.
    """
    rot = rotation[host]
    cx, cy, cz = centre[host, 0], centre[host, 1], centre[host, 2]
    ux = sign * (rot[0, 0] * nx + rot[1, 0] * ny + rot[2, 0] * nz)
    uy = sign * (rot[0, 1] * nx + rot[1, 1] * ny + rot[2, 1] * nz)
    uz = sign * (rot[0, 2] * nx + rot[1, 2] * ny + rot[2, 2] * nz)
    first, last = plane_start[host], plane_start[host + 1]
    for e in range(edge_start[intruder], edge_start[intruder + 1]):
        i, j = edges[e, 0], edges[e, 1]
        r = 0.5 * (radius[i] + radius[j])
        dx, dy, dz = px[i] - cx, py[i] - cy, pz[i] - cz
        l0x = rot[0, 0] * dx + rot[1, 0] * dy + rot[2, 0] * dz
        l0y = rot[0, 1] * dx + rot[1, 1] * dy + rot[2, 1] * dz
        l0z = rot[0, 2] * dx + rot[1, 2] * dy + rot[2, 2] * dz
        dx, dy, dz = px[j] - cx, py[j] - cy, pz[j] - cz
        l1x = rot[0, 0] * dx + rot[1, 0] * dy + rot[2, 0] * dz
        l1y = rot[0, 1] * dx + rot[1, 1] * dy + rot[2, 1] * dz
        l1z = rot[0, 2] * dx + rot[1, 2] * dy + rot[2, 2] * dz
        t_in = 0.0
        t_out = 1.0
        ends_outside = False
        for f in range(first, last):
            s0 = planes[f, 0] * l0x + planes[f, 1] * l0y + planes[f, 2] * l0z - planes[f, 3] - r
            s1 = planes[f, 0] * l1x + planes[f, 1] * l1y + planes[f, 2] * l1z - planes[f, 3] - r
            if s0 >= 0.0 and s1 >= 0.0:
                t_in = 1.0  # wholly outside this face
                break
            if s0 >= 0.0:
                t_in = max(t_in, s0 / (s0 - s1))
                ends_outside = True
            elif s1 >= 0.0:
                t_out = min(t_out, s0 / (s0 - s1))
        if t_in >= t_out or t_in <= 0.0 or t_out >= 1.0 or not ends_outside:
            continue  # misses, or an end is inside (its vertex contact covers it)
        best = 0.0
        bt = 0.0
        for k in range(4):
            t = t_in + (k + 0.5) / 4.0 * (t_out - t_in)
            depth = _exit(
                planes,
                first,
                last,
                l0x + t * (l1x - l0x),
                l0y + t * (l1y - l0y),
                l0z + t * (l1z - l0z),
                ux,
                uy,
                uz,
                r,
            )
            if depth > best:
                best = depth
                bt = t
        if best <= 0.0:
            continue
        wx = px[i] + bt * (px[j] - px[i])
        wy = py[i] + bt * (py[j] - py[i])
        wz = pz[i] + bt * (pz[j] - pz[i])
        # The matching point on the host: moved out by the depth along the way out.
        hx, hy, hz = wx + sign * best * nx, wy + sign * best * ny, wz + sign * best * nz
        if sign > 0:  # intruder a, host b
            ax, ay, az, bx, by, bz = wx, wy, wz, hx, hy, hz
        else:  # intruder b, host a
            ax, ay, az, bx, by, bz = hx, hy, hz, wx, wy, wz
        found[count, 0] = best
        found[count, 1] = ax - centre[a, 0]
        found[count, 2] = ay - centre[a, 1]
        found[count, 3] = az - centre[a, 2]
        found[count, 4] = bx - centre[b, 0]
        found[count, 5] = by - centre[b, 1]
        found[count, 6] = bz - centre[b, 2]
        count += 1
    return count


@serial_kernel
def body_contacts(
    px,
    py,
    pz,
    qx,
    qy,
    qz,
    inv_mass,
    radius,
    body_start,
    body_particles,
    mass_fraction,
    rest,
    body_inv_mass,
    rest_inv_inertia,
    plane_start,
    planes,
    group,
    rotation,
    edge_start,
    edges,
    friction,
    hits,
):
    """Project particles out of other bodies' shapes (see the module docstring).

    ``edges`` (k, 2) are particle pairs, body ``i``'s in ``edge_start[i]:edge_start[i+1]``.

    ``rest`` (e, 3) are the body entries' rest positions about the centre of mass [m];
    ``body_inv_mass`` (b,) [1/kg] and ``rest_inv_inertia`` (b, 3, 3) [1/(kg m²)] (rest
    frame) are 0 for immovable bodies; ``rotation`` (b, 3, 3), rest to world, is
    refined here first (and kept: it warm-starts the next call).
    """
    nb = body_start.shape[0] - 1
    update_rotations(px, py, pz, body_start, body_particles, mass_fraction, rest, rotation, 4)
    inv_inertia = np.empty((nb, 3, 3))
    for b in range(nb):
        # R I⁻¹ Rᵀ by explicit loops: np.dot would need SciPy's BLAS at run time.
        tmp = np.empty((3, 3))
        matmul3(rotation[b], rest_inv_inertia[b], tmp)
        matmul3(tmp, rotation[b].T, inv_inertia[b])
    largest = 0
    for b in range(nb):
        largest = max(largest, body_start[b + 1] - body_start[b])
    most_edges = 0
    for b in range(nb):
        most_edges = max(most_edges, edge_start[b + 1] - edge_start[b])
    found = np.empty((2 * largest + 2 * most_edges, 7))
    box = np.empty((nb, 6))
    centre = np.zeros((nb, 3))
    before = np.zeros((nb, 3))
    for b in range(nb):
        box[b, :3] = np.inf
        box[b, 3:] = -np.inf
        for e in range(body_start[b], body_start[b + 1]):
            k = body_particles[e]
            r = radius[k]
            box[b, 0] = min(box[b, 0], px[k] - r)
            box[b, 1] = min(box[b, 1], py[k] - r)
            box[b, 2] = min(box[b, 2], pz[k] - r)
            box[b, 3] = max(box[b, 3], px[k] + r)
            box[b, 4] = max(box[b, 4], py[k] + r)
            box[b, 5] = max(box[b, 5], pz[k] + r)
            centre[b, 0] += mass_fraction[e] * px[k]
            centre[b, 1] += mass_fraction[e] * py[k]
            centre[b, 2] += mass_fraction[e] * pz[k]
            before[b, 0] += mass_fraction[e] * qx[k]
            before[b, 1] += mass_fraction[e] * qy[k]
            before[b, 2] += mass_fraction[e] * qz[k]
    for first in range(nb):
        for second in range(first + 1, nb):
            if group[first] == group[second]:
                continue
            if (
                box[first, 0] > box[second, 3]
                or box[second, 0] > box[first, 3]
                or box[first, 1] > box[second, 4]
                or box[second, 1] > box[first, 4]
                or box[first, 2] > box[second, 5]
                or box[second, 2] > box[first, 5]
            ):
                continue
            # Separating-axis test over both bodies' faces: the axis of least overlap
            # gives the normal and which body's particles are pushed out of which.
            ab, face_ab = _overlap(
                px,
                py,
                pz,
                radius,
                body_start,
                body_particles,
                plane_start,
                planes,
                centre,
                rotation,
                first,
                second,
            )
            ba, face_ba = _overlap(
                px,
                py,
                pz,
                radius,
                body_start,
                body_particles,
                plane_start,
                planes,
                centre,
                rotation,
                second,
                first,
            )
            if min(ab, ba) <= 0.0:
                continue
            if ab <= ba:
                a, b, face = first, second, face_ab
            else:
                a, b, face = second, first, face_ba
            rot = rotation[b]
            iinv = inv_inertia[b]
            fx, fy, fz = planes[face, 0], planes[face, 1], planes[face, 2]
            nx = rot[0, 0] * fx + rot[0, 1] * fy + rot[0, 2] * fz
            ny = rot[1, 0] * fx + rot[1, 1] * fy + rot[1, 2] * fz
            nz = rot[2, 0] * fx + rot[2, 1] * fy + rot[2, 2] * fz
            ia = inv_inertia[a]
            # Every contact of the pair is solved from the same state and applied with
            # 1/count of its multiplier (Jacobi averaging): solved one after another,
            # the rotation each one causes disturbs the next, and a resting stack tilts.
            count = 0
            for ea in range(body_start[a], body_start[a + 1]):
                i = body_particles[ea]
                r = radius[i]
                dx = px[i] - centre[b, 0]
                dy = py[i] - centre[b, 1]
                dz = pz[i] - centre[b, 2]
                lx = rot[0, 0] * dx + rot[1, 0] * dy + rot[2, 0] * dz
                ly = rot[0, 1] * dx + rot[1, 1] * dy + rot[2, 1] * dz
                lz = rot[0, 2] * dx + rot[1, 2] * dy + rot[2, 2] * dz
                inside = True
                for f in range(plane_start[b], plane_start[b + 1]):
                    s = planes[f, 0] * lx + planes[f, 1] * ly + planes[f, 2] * lz - planes[f, 3]
                    if s >= r:
                        inside = False
                        break
                if not inside:
                    continue
                gap = fx * lx + fy * ly + fz * lz - planes[face, 3]
                # Contact points: on b's face, and the particle itself on a.
                found[count, 0] = r - gap
                found[count, 1] = px[i] - centre[a, 0]
                found[count, 2] = py[i] - centre[a, 1]
                found[count, 3] = pz[i] - centre[a, 2]
                found[count, 4] = dx - gap * nx
                found[count, 5] = dy - gap * ny
                found[count, 6] = dz - gap * nz
                hits[i] += 1
                count += 1
            # And b's particles inside a, pushed out of a along -n (an edge of b across a
            # face of a has no particle of a inside b: without this it passes through).
            rot_a = rotation[a]
            ux = -(rot_a[0, 0] * nx + rot_a[1, 0] * ny + rot_a[2, 0] * nz)
            uy = -(rot_a[0, 1] * nx + rot_a[1, 1] * ny + rot_a[2, 1] * nz)
            uz = -(rot_a[0, 2] * nx + rot_a[1, 2] * ny + rot_a[2, 2] * nz)
            for eb in range(body_start[b], body_start[b + 1]):
                i = body_particles[eb]
                r = radius[i]
                dx = px[i] - centre[a, 0]
                dy = py[i] - centre[a, 1]
                dz = pz[i] - centre[a, 2]
                lx = rot_a[0, 0] * dx + rot_a[1, 0] * dy + rot_a[2, 0] * dz
                ly = rot_a[0, 1] * dx + rot_a[1, 1] * dy + rot_a[2, 1] * dz
                lz = rot_a[0, 2] * dx + rot_a[1, 2] * dy + rot_a[2, 2] * dz
                exit_t = np.inf
                for f in range(plane_start[a], plane_start[a + 1]):
                    s = planes[f, 0] * lx + planes[f, 1] * ly + planes[f, 2] * lz - planes[f, 3]
                    if s >= r:
                        exit_t = -1.0
                        break
                    along = planes[f, 0] * ux + planes[f, 1] * uy + planes[f, 2] * uz
                    if along > 1e-9:
                        exit_t = min(exit_t, (r - s) / along)
                if exit_t <= 0.0 or exit_t == np.inf or plane_start[a] == plane_start[a + 1]:
                    continue
                found[count, 0] = exit_t
                found[count, 1] = dx - exit_t * nx
                found[count, 2] = dy - exit_t * ny
                found[count, 3] = dz - exit_t * nz
                found[count, 4] = px[i] - centre[b, 0]
                found[count, 5] = py[i] - centre[b, 1]
                found[count, 6] = pz[i] - centre[b, 2]
                hits[i] += 1
                count += 1
            count = _edge_contacts(
                px,
                py,
                pz,
                radius,
                edge_start,
                edges,
                plane_start,
                planes,
                centre,
                rotation,
                a,
                b,
                1.0,
                nx,
                ny,
                nz,
                a,
                b,
                found,
                count,
            )
            count = _edge_contacts(
                px,
                py,
                pz,
                radius,
                edge_start,
                edges,
                plane_start,
                planes,
                centre,
                rotation,
                b,
                a,
                -1.0,
                nx,
                ny,
                nz,
                a,
                b,
                found,
                count,
            )
            if count == 0:
                continue
            deepest = 0.0
            for j in range(count):
                # Rotations turn about the current centres (momentum is then conserved).
                ax, ay, az = centre[a, 0], centre[a, 1], centre[a, 2]
                bx, by, bz = centre[b, 0], centre[b, 1], centre[b, 2]
                depth = found[j, 0]
                sx, sy, sz = found[j, 1], found[j, 2], found[j, 3]
                rx, ry, rz = found[j, 4], found[j, 5], found[j, 6]
                deepest = max(deepest, depth)
                total = body_weight(body_inv_mass[a], ia, sx, sy, sz, nx, ny, nz)
                total += body_weight(body_inv_mass[b], iinv, rx, ry, rz, nx, ny, nz)
                if total <= 0.0:
                    continue
                lam = depth / total / count
                _push(
                    px,
                    py,
                    pz,
                    body_start,
                    body_particles,
                    centre,
                    body_inv_mass,
                    ia,
                    iinv,
                    a,
                    b,
                    ax,
                    ay,
                    az,
                    bx,
                    by,
                    bz,
                    sx,
                    sy,
                    sz,
                    rx,
                    ry,
                    rz,
                    nx,
                    ny,
                    nz,
                    lam,
                )
            if friction <= 0.0:
                continue
            # Tangential travel of a's centre relative to b's centre over the step,
            # reduced by at most mu times the deepest contact's depth.
            ux = (centre[a, 0] - before[a, 0]) - (centre[b, 0] - before[b, 0])
            uy = (centre[a, 1] - before[a, 1]) - (centre[b, 1] - before[b, 1])
            uz = (centre[a, 2] - before[a, 2]) - (centre[b, 2] - before[b, 2])
            un = ux * nx + uy * ny + uz * nz
            tx, ty, tz = ux - un * nx, uy - un * ny, uz - un * nz
            t = np.sqrt(tx * tx + ty * ty + tz * tz)
            if t <= 0.0:
                continue
            tx, ty, tz = -tx / t, -ty / t, -tz / t
            total = body_inv_mass[a] + body_inv_mass[b]
            if total <= 0.0:
                continue
            lam = min(t, friction * deepest) / total
            ax, ay, az = centre[a, 0], centre[a, 1], centre[a, 2]
            bx, by, bz = centre[b, 0], centre[b, 1], centre[b, 2]
            _push(
                px,
                py,
                pz,
                body_start,
                body_particles,
                centre,
                body_inv_mass,
                ia,
                iinv,
                a,
                b,
                ax,
                ay,
                az,
                bx,
                by,
                bz,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                tx,
                ty,
                tz,
                lam,
            )
