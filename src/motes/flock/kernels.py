"""Compiled kernels of a flock: the fused boid step, passes against other flocks, and
neighbour lists.

The flock keeps its boids in the order of a :class:`motes.spatial.UniformGrid` built
over their positions at the start of each step (cell edge = the largest rule radius),
so a boid's neighbours are in the 27 cells around its own, nine runs of consecutive
slots, read from nearby memory. Kernels run ``prange`` over fixed blocks of boids
(:mod:`motes._jit`), the step over rows of cells; each boid writes only its own outputs,
reads the state at the start of the step and sums over its neighbours in a fixed order
(elementwise loops alone vectorise), so results do not depend on the thread count.

A neighbour ``j`` of boid ``i`` under a rule of radius ``r`` and half field of view
``θ`` is ``j != i`` with ``|d| <= r`` and ``d · h_i >= cos θ · |d|``, where
``d = x_j - x_i`` and ``h_i`` is ``i``'s unit heading.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit import block_bounds, block_count, called, device, fma, parallel_kernel
from ..geometry.distance import mesh_distance, row_signed_distance
from ..geometry.layout import KIND, Kind
from ..geometry.sweep import mesh_first_hit
from ..spatial.kernels import cell_coordinate

# Indices into the float64 parameter vector of :func:`step`.
(
    SEP_R2, ALI_R2, COH_R2, SEP_COS, ALI_COS, COH_COS, SEP_W, ALI_W, COH_W, MAX_R2,
    MIN_SPEED, MAX_SPEED, MAX_ACCEL, MAX_TURN, DT, RADIUS,
    AVOID_LOOKAHEAD, AVOID_MARGIN, AVOID_W, GRAVITY, BANK_TIME, FLAP_FREQUENCY, SEED, STEP,
    PARAMS,
) = range(25)  # fmt: skip

#: Initial capacity of the step's neighbourhood scratch, per work item (it grows as needed).
SCRATCH = 512

_SEEK, _FLEE, _ARRIVE, _WANDER, _CONTAIN, _PATH = range(6)
_AVOID, _EVADE, _PURSUE, _FOLLOW = range(4)


@device
def _mix(x):
    """splitmix64 finaliser: a well-mixed 64-bit value from a counter."""
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@device
def _uniform(seed, boid, step, k):
    """A uniform float32 in [-1, 1) from (seed, boid id, step, k): counter-based, so the
    same on any thread count and in any order."""
    x = _mix(np.uint64(seed) ^ _mix(np.uint64(boid) * np.uint64(0x9E3779B97F4A7C15)))
    x = _mix(x ^ (np.uint64(step) * np.uint64(4) + np.uint64(k)))
    return np.float32(np.int64(x >> np.uint64(40)) * (2.0**-23)) - np.float32(1.0)


#: atan(x) / x as a polynomial in x² on [0, 1] (degree 7, least squares on Chebyshev
#: nodes: ``np.polynomial.polynomial.polyfit(u, arctan(√u) / √u, 7)``), rounded to float32.
_ATAN = (
    0.9999998807907104, -0.33331960439682007, 0.19969235360622406, -0.14016585052013397,
    0.09906096756458282, -0.0593671016395092, 0.02416618913412094, -0.004668773151934147,
)  # fmt: skip


@device
def _atan(x):
    """arctan(x) [rad] of a float32, within 2e-7 rad of the exact value (a polynomial
    on [-1, 1], atan(x) = ±π/2 - atan(1/x) beyond): five times faster than the library
    call, which costs as much as the rest of a boid's bank and wing beat."""
    a = abs(x)
    far = a > np.float32(1.0)
    t = np.float32(1.0) / a if far else a
    u = t * t
    c = _ATAN
    p = fma(np.float32(c[7]), u, np.float32(c[6]))
    p = fma(p, u, np.float32(c[5]))
    p = fma(p, u, np.float32(c[4]))
    p = fma(p, u, np.float32(c[3]))
    p = fma(p, u, np.float32(c[2]))
    p = fma(p, u, np.float32(c[1]))
    p = fma(p, u, np.float32(c[0]))
    r = t * p
    if far:
        r = np.float32(0.5 * np.pi) - r
    return -r if x < np.float32(0.0) else r


@device
def _perpendicular(hx, hy, hz):
    """A unit vector perpendicular to unit ``h`` (horizontal where possible)."""
    # h × y, or h × x when h is near vertical.
    if abs(hy) < np.float32(0.9):
        px, py, pz = -hz, np.float32(0.0), hx
    else:
        px, py, pz = np.float32(0.0), hz, -hy
    inv = np.float32(1.0) / np.sqrt(px * px + py * py + pz * pz)
    return px * inv, py * inv, pz * inv


@device
def _toward(dx, dy, dz, speed):
    """``d`` scaled to length ``speed`` (zero for a zero ``d``)."""
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    s = speed / length if length > np.float32(0.0) else np.float32(0.0)
    return dx * s, dy * s, dz * s


@called
def _targets(i, x, y, z, vx, vy, vz, hx, hy, hz, ident, table, path, wander, p, max_speed):
    """Steering acceleration [m/s²] of the target rows for boid ``i``; updates its
    wander direction."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    ax = ay = az = zero
    for k in range(table.shape[0]):
        code = int(table[k, 0])
        w = np.float32(table[k, 1])
        t0 = np.float32(table[k, 2])
        t1 = np.float32(table[k, 3])
        t2 = np.float32(table[k, 4])
        if code == _SEEK:
            ux, uy, uz = _toward(t0 - x, t1 - y, t2 - z, max_speed)
            ax += w * (ux - vx)
            ay += w * (uy - vy)
            az += w * (uz - vz)
        elif code == _FLEE:
            dx, dy, dz = x - t0, y - t1, z - t2
            dist = np.sqrt(dx * dx + dy * dy + dz * dz)
            r = np.float32(table[k, 5])
            if dist < r:
                ux, uy, uz = _toward(dx, dy, dz, w * max_speed * (one - dist / r))
                ax += ux
                ay += uy
                az += uz
        elif code == _ARRIVE:
            dx, dy, dz = t0 - x, t1 - y, t2 - z
            dist = np.sqrt(dx * dx + dy * dy + dz * dz)
            speed = max_speed * min(one, dist / np.float32(table[k, 5]))
            ux, uy, uz = _toward(dx, dy, dz, speed)
            ax += w * (ux - vx)
            ay += w * (uy - vy)
            az += w * (uz - vz)
        elif code == _WANDER:
            kick = t2 * np.float32(np.sqrt(p[DT]))
            step = np.int64(p[STEP])
            seed = np.int64(p[SEED])
            wx = wander[0, i] + kick * _uniform(seed, ident, step, 0)
            wy = wander[1, i] + kick * _uniform(seed, ident, step, 1)
            wz = wander[2, i] + kick * _uniform(seed, ident, step, 2)
            wx, wy, wz = _toward(wx, wy, wz, one)
            if wx == zero and wy == zero and wz == zero:
                wx, wy, wz = hx, hy, hz
            wander[0, i] = wx
            wander[1, i] = wy
            wander[2, i] = wz
            ux, uy, uz = _toward(hx * t1 + wx * t0, hy * t1 + wy * t0, hz * t1 + wz * t0, max_speed)
            ax += w * (ux - vx)
            ay += w * (uy - vy)
            az += w * (uz - vz)
        elif code == _CONTAIN:
            margin = np.float32(table[k, 8])
            push = w * max_speed / margin
            ax += push * (
                max(t0 + margin - x, zero) - max(x - np.float32(table[k, 5]) + margin, zero)
            )
            ay += push * (
                max(t1 + margin - y, zero) - max(y - np.float32(table[k, 6]) + margin, zero)
            )
            az += push * (
                max(t2 + margin - z, zero) - max(z - np.float32(table[k, 7]) + margin, zero)
            )
        else:  # _PATH
            ax, ay, az = _follow_path(ax, ay, az, x, y, z, vx, vy, vz, w, table, k, path, max_speed)
    return ax, ay, az


@called
def _follow_path(ax, ay, az, x, y, z, vx, vy, vz, w, table, k, path, max_speed):
    """Path following (Reynolds 1999) against polyline ``path[:, base:base + m]``."""
    base = int(table[k, 2])
    m = int(table[k, 3])
    radius = np.float32(table[k, 4])
    ahead = np.float32(table[k, 5])
    lead = np.float32(table[k, 6])
    fx, fy, fz = x + vx * ahead, y + vy * ahead, z + vz * ahead
    best = np.float32(np.inf)
    cx = cy = cz = tx = ty = tz = np.float32(0.0)
    for s in range(base, base + m - 1):
        sx, sy, sz = path[0, s], path[1, s], path[2, s]
        ex, ey, ez = path[0, s + 1] - sx, path[1, s + 1] - sy, path[2, s + 1] - sz
        ee = ex * ex + ey * ey + ez * ez
        t = ((fx - sx) * ex + (fy - sy) * ey + (fz - sz) * ez) / max(ee, np.float32(1e-12))
        t = min(max(t, np.float32(0.0)), np.float32(1.0))
        qx, qy, qz = sx + t * ex, sy + t * ey, sz + t * ez
        d2 = (fx - qx) ** 2 + (fy - qy) ** 2 + (fz - qz) ** 2
        if d2 < best:
            best = d2
            cx, cy, cz = qx, qy, qz
            tx, ty, tz = _toward(ex, ey, ez, np.float32(1.0))
    if best > radius * radius:
        ux, uy, uz = _toward(cx + tx * lead - x, cy + ty * lead - y, cz + tz * lead - z, max_speed)
    else:
        ux, uy, uz = tx * max_speed, ty * max_speed, tz * max_speed
    return ax + w * (ux - vx), ay + w * (uy - vy), az + w * (uz - vz)


@called
def _avoid(
    x, y, z, vx, vy, vz, hx, hy, hz, colliders, active, n_active, every, mesh, p, max_speed
):  # fmt: skip
    """Obstacle avoidance acceleration [m/s²]: probe ahead, steer sideways; push out
    when already within the margin. Also whether a collider is near enough that the
    step's move may bring the boid within its radius (then the keep-out runs).

    Only the colliders ``active[:n_active]`` are read (:func:`_colliders_near`: the
    others are too far to do either), or all of them with ``every`` (a boid faster
    than the limit, which the cull does not cover)."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    ax = ay = az = zero
    ahead = np.float32(p[AVOID_LOOKAHEAD])
    margin = np.float32(p[AVOID_MARGIN])
    gain = np.float32(p[AVOID_W]) * max_speed / margin
    # Signed distances change at most as fast as the point moves (they are
    # 1-Lipschitz), so a probe ``|v| · lookahead`` away cannot be within the margin of
    # a shape this far, nor a move of ``max_speed · dt`` reach within the radius.
    reach = margin + np.sqrt(vx * vx + vy * vy + vz * vz) * ahead
    near_by = np.float32(p[RADIUS] + p[MAX_SPEED] * p[DT])
    near = False
    qx, qy, qz = x + vx * ahead, y + vy * ahead, z + vz * ahead
    for k in range(colliders.shape[0] if every else n_active):
        c = k if every else active[k]
        d, nx, ny, nz = _distance(colliders, c, mesh, x, y, z, x, y, z, reach + near_by)
        near |= d < near_by
        if d >= reach:
            continue
        if d < margin:
            s = gain * (margin - d)
            ax += s * nx
            ay += s * ny
            az += s * nz
        d, nx, ny, nz = _distance(colliders, c, mesh, qx, qy, qz, x, y, z, margin)
        if d < margin:
            along = nx * hx + ny * hy + nz * hz
            lx, ly, lz = nx - along * hx, ny - along * hy, nz - along * hz
            length = np.sqrt(lx * lx + ly * ly + lz * lz)
            if length < np.float32(1e-3):  # head-on: any side will do, the same each time
                lx, ly, lz = _perpendicular(hx, hy, hz)
                length = one
            s = gain * (margin - d) / length
            ax += s * lx
            ay += s * ly
            az += s * lz
    return ax, ay, az, near


@called
def _colliders_near(colliders, mesh, origin, cell, cx0, cx1, cy, cz, p, active):
    """Write into ``active`` the colliders :func:`_avoid` may need for any boid of cells
    ``cx0..cx1`` of row ``(cy, cz)``; return their count.

    Signed distances are 1-Lipschitz, so no point of the cells' box is nearer a shape
    than its distance from the box's centre less the half-diagonal; a collider further
    than the largest reach of :func:`_avoid` (margin, lookahead at full speed, and one
    step's move within the radius) from every point is left out. The result is the
    same as visiting all of them, for a tenth of the distance evaluations in open air.
    """
    half_x = 0.5 * cell * (cx1 - cx0 + 1)
    half = 0.5 * cell
    mx = origin[0] + cell * cx0 + half_x
    my = origin[1] + cell * cy + half
    mz = origin[2] + cell * cz + half
    # The bound is exact; its float32 rounding is not: a generous allowance for it.
    slack = 1e-3 * cell + 1e-5 * (abs(mx) + abs(my) + abs(mz))
    diagonal = np.float32(np.sqrt(half_x * half_x + 2.0 * half * half) + slack)
    mx, my, mz = np.float32(mx), np.float32(my), np.float32(mz)
    fastest = CULL_SPEED * p[MAX_SPEED]
    reach = np.float32(p[AVOID_MARGIN] + fastest * p[AVOID_LOOKAHEAD] + p[RADIUS] + fastest * p[DT])
    count = 0
    for c in range(colliders.shape[0]):
        d = _distance(colliders, c, mesh, mx, my, mz, mx, my, mz, reach + diagonal)[0]
        if d - diagonal < reach:
            active[count] = c
            count += 1
    return count


#: Cells of a row whose colliders :func:`_colliders_near` culls at once.
CULL_CELLS = 4
#: The cull covers boids up to this times the speed limit (a velocity clamped to the
#: limit may round a little above it); faster ones visit every collider.
CULL_SPEED = 1.01

#: Kind code of a triangle-mesh row.
MESH = int(Kind.MESH)


@device
def _distance(colliders, c, mesh, x, y, z, sx, sy, sz, reach):
    """Signed distance [m] and unit normal (float32) from a boid at (x, y, z) to collider
    row ``c``: analytic for shapes; for a triangle mesh (a thin two-sided shell) through
    its grid, on the side of (sx, sy, sz), and +inf beyond ``reach`` [m]."""
    if int(colliders[c, KIND]) == MESH:
        tri, cell_start, cell_tris = mesh
        d, nx, ny, nz = mesh_distance(
            colliders[c], tri, cell_start, cell_tris, np.float64(x), np.float64(y),
            np.float64(z), np.float64(sx), np.float64(sy), np.float64(sz), np.float64(reach),
        )  # fmt: skip
        return np.float32(min(d, 1e30)), np.float32(nx), np.float32(ny), np.float32(nz)
    return row_signed_distance(colliders, c, x, y, z, np.float32(1.0))


@called
def _keep_out(x0, y0, z0, x, y, z, vx, vy, vz, colliders, mesh, radius):
    """The position put back on each collider's surface grown by ``radius`` and the
    velocity into it removed. A triangle mesh is a shell a boid could cross within one
    step: the move from (x0, y0, z0) is swept against it first, and stops where it
    comes within ``radius``."""
    tri, cell_start, cell_tris = mesh
    for c in range(colliders.shape[0]):
        if int(colliders[c, KIND]) != MESH:
            continue
        dx, dy, dz = x - x0, y - y0, z - z0
        f, nx, ny, nz, _ = mesh_first_hit(
            colliders[c], tri, cell_start, cell_tris, np.float64(x0), np.float64(y0),
            np.float64(z0), np.float64(dx), np.float64(dy), np.float64(dz), np.float64(radius),
        )  # fmt: skip
        if f < 1.0:
            f32 = np.float32(max(f, 0.0))
            x, y, z = x0 + f32 * dx, y0 + f32 * dy, z0 + f32 * dz
            gx, gy, gz = np.float32(nx), np.float32(ny), np.float32(nz)
            vn = min(vx * gx + vy * gy + vz * gz, np.float32(0.0))
            vx -= vn * gx
            vy -= vn * gy
            vz -= vn * gz
    for _ in range(2):  # a second pass settles a boid pushed out of one shape into another
        for c in range(colliders.shape[0]):
            d, nx, ny, nz = _distance(colliders, c, mesh, x, y, z, x0, y0, z0, radius)
            if d < radius:
                depth = radius - d
                x += nx * depth
                y += ny * depth
                z += nz * depth
                vn = min(vx * nx + vy * ny + vz * nz, np.float32(0.0))
                vx -= vn * nx
                vy -= vn * ny
                vz -= vn * nz
    return x, y, z, vx, vy, vz


@parallel_kernel
def step(
    pos, vel, head, ident, cell_start, origin, inv_cell, dims, p, extra, table, path,
    colliders, mesh_tri, mesh_cell_start, mesh_cell_tris, wander, bank, flap, pos_out, vel_out,
    head_out, neighbors,
):  # fmt: skip
    """One step of every boid: rules, behaviours, limits, move, colliders.

    Parameters
    ----------
    pos, vel, head : (3, n) float32
        Positions [m], velocities [m/s] and unit headings, in grid order.
    ident : (n,) int64
        Boid ids (the wander's random counter).
    cell_start, origin, inv_cell, dims
        The grid (:class:`motes.spatial.UniformGrid`), cell edge >= every rule radius.
    p : (PARAMS,) float64
        The scalar parameters (indices at the top of this module).
    extra : (3, n) float32
        Acceleration [m/s²] from the passes against other flocks.
    table, path : (k, WIDTH) float64, (3, m) float32
        Target rows and path points (:mod:`motes.flock.behaviors`).
    colliders : (c, ROW) float32
        Collider rows to avoid and keep out of.
    mesh_tri, mesh_cell_start, mesh_cell_tris
        The triangles and grid lists of the mesh rows
        (:func:`motes.collide.contact.pack`).
    wander : (3, n) float32
        Wander directions, read and written.
    bank, flap : (n,) float32
        Bank angle [rad] and wing-beat phase [rad], read and written.
    pos_out, vel_out, head_out : (3, n) float32
        The new state.
    neighbors : (n,) int32
        Boids each one saw (the largest of the three rules' neighbour counts).
    """
    zero = np.float32(0.0)
    one = np.float32(1.0)
    mesh = (mesh_tri, mesh_cell_start, mesh_cell_tris)
    nx_, ny_, nz_ = dims[0], dims[1], dims[2]
    sep_r2, ali_r2, coh_r2 = np.float32(p[SEP_R2]), np.float32(p[ALI_R2]), np.float32(p[COH_R2])
    sep_cos, ali_cos, coh_cos = (
        np.float32(p[SEP_COS]),
        np.float32(p[ALI_COS]),
        np.float32(p[COH_COS]),
    )
    sep_w, ali_w, coh_w = np.float32(p[SEP_W]), np.float32(p[ALI_W]), np.float32(p[COH_W])
    max_r2 = np.float32(p[MAX_R2])
    inv_sep_r = one / np.sqrt(sep_r2)
    tiny = np.float32(1e-30)
    coh_r = np.sqrt(coh_r2)
    min_speed, max_speed = np.float32(p[MIN_SPEED]), np.float32(p[MAX_SPEED])
    max_accel = np.float32(p[MAX_ACCEL])
    dt = np.float32(p[DT])
    cos_turn = np.float32(np.cos(min(p[MAX_TURN] * p[DT], np.pi)))
    sin_turn = np.float32(np.sin(min(p[MAX_TURN] * p[DT], np.pi)))
    radius = np.float32(p[RADIUS])
    bank_rate = np.float32(min(1.0, p[DT] / p[BANK_TIME]))
    gravity = np.float32(p[GRAVITY])
    flap_step = np.float32(2.0 * np.pi * p[FLAP_FREQUENCY] * p[DT]) / max_speed
    # Rows as 1-D arrays: the inner loop then indexes without the 2-D stride.
    qx_, qy_, qz_ = pos[0], pos[1], pos[2]
    wx_, wy_, wz_ = vel[0], vel[1], vel[2]
    # One work item per row of cells along x. The boids of a cell share their 27-cell
    # neighbourhood: it is copied once into contiguous scratch (nine runs, in the order
    # a boid visits them), then each boid's distances to all of it are one loop that
    # vectorises. Per boid the candidates, their order and the arithmetic are those of
    # a search from the boid itself, so results do not depend on this grouping.
    cell = 1.0 / inv_cell
    cull_speed2 = np.float32((CULL_SPEED * p[MAX_SPEED]) ** 2)
    for r in prange(ny_ * nz_):
        cy = r % ny_
        cz = r // ny_
        active = np.empty(colliders.shape[0], np.int64)
        n_active = 0
        cap = SCRATCH
        cand = np.empty(cap, np.int64)
        cxs = np.empty(cap, np.float32)
        cys = np.empty(cap, np.float32)
        czs = np.empty(cap, np.float32)
        d2s = np.empty(cap, np.float32)
        hits = np.empty(cap, np.int64)
        for cx in range(nx_):
            s0 = cell_start[cx + nx_ * r]
            s1 = cell_start[cx + nx_ * r + 1]
            if cx % CULL_CELLS == 0 and colliders.shape[0] > 0:
                n_active = _colliders_near(
                    colliders, mesh, origin, cell, cx, min(cx + CULL_CELLS, nx_) - 1, cy, cz,
                    p, active,
                )  # fmt: skip
            if s0 == s1:
                continue
            x0, x1 = max(cx - 1, 0), min(cx + 1, nx_ - 1)
            z0, z1 = max(cz - 1, 0), min(cz + 1, nz_ - 1)
            y0, y1 = max(cy - 1, 0), min(cy + 1, ny_ - 1)
            need = 0
            for gz in range(z0, z1 + 1):
                for gy in range(y0, y1 + 1):
                    row = nx_ * (gy + ny_ * gz)
                    need += cell_start[row + x1 + 1] - cell_start[row + x0]
            if need > cap:
                cap = need + need // 2
                cand = np.empty(cap, np.int64)
                cxs = np.empty(cap, np.float32)
                cys = np.empty(cap, np.float32)
                czs = np.empty(cap, np.float32)
                d2s = np.empty(cap, np.float32)
                hits = np.empty(cap, np.int64)
            m = 0
            for gz in range(z0, z1 + 1):
                for gy in range(y0, y1 + 1):
                    row = nx_ * (gy + ny_ * gz)
                    for j in range(cell_start[row + x0], cell_start[row + x1 + 1]):
                        cand[m] = j
                        cxs[m] = qx_[j]
                        cys[m] = qy_[j]
                        czs[m] = qz_[j]
                        m += 1
            for i in range(s0, s1):
                x, y, z = qx_[i], qy_[i], qz_[i]
                vx, vy, vz = wx_[i], wy_[i], wz_[i]
                hx, hy, hz = head[0, i], head[1, i], head[2, i]
                sx = sy = sz = zero
                avx = avy = avz = zero
                cdx = cdy = cdz = zero
                ns = na = nc = zero
                # Distances to the whole neighbourhood (a loop that vectorises), the ones
                # in range appended without a branch, then the rules over those alone.
                for t in range(m):
                    dx = cxs[t] - x
                    dy = cys[t] - y
                    dz = czs[t] - z
                    d2s[t] = dx * dx + dy * dy + dz * dz
                found = 0
                for t in range(m):
                    hits[found] = t
                    found += d2s[t] <= max_r2
                for k in range(found):
                    t = hits[k]
                    j = cand[t]
                    if j == i:
                        continue
                    dx = cxs[t] - x
                    dy = cys[t] - y
                    dz = czs[t] - z
                    d2 = dx * dx + dy * dy + dz * dz
                    d = np.sqrt(d2)
                    ahead = dx * hx + dy * hy + dz * hz
                    # Masks as 0/1 factors rather than branches: which rules a
                    # neighbour counts for changes from one to the next, and the
                    # mispredicted branches cost more than the arithmetic.
                    ms = np.float32((d2 <= sep_r2) & (ahead >= sep_cos * d) & (d > zero))
                    ma = np.float32((d2 <= ali_r2) & (ahead >= ali_cos * d))
                    mc = np.float32((d2 <= coh_r2) & (ahead >= coh_cos * d))
                    # Reynolds' push away, falling linearly to 0 at the radius:
                    # (1 - d / r) / d along -d.
                    s = ms * (one / max(d, tiny) - inv_sep_r)
                    sx -= dx * s
                    sy -= dy * s
                    sz -= dz * s
                    ns += ms
                    avx += ma * wx_[j]
                    avy += ma * wy_[j]
                    avz += ma * wz_[j]
                    na += ma
                    cdx += mc * dx
                    cdy += mc * dy
                    cdz += mc * dz
                    nc += mc
                neighbors[i] = np.int32(max(ns, max(na, nc)))
                ax, ay, az = extra[0, i], extra[1, i], extra[2, i]
                if ns > zero:
                    g = sep_w * max_speed
                    ax += g * sx
                    ay += g * sy
                    az += g * sz
                if na > zero:
                    # Reynolds' alignment steers to the neighbours' mean direction (at full
                    # speed): matching the mean velocity itself would slow a boid among
                    # neighbours flying every way, and the order would never form.
                    ux, uy, uz = _toward(avx, avy, avz, max_speed)
                    ax += ali_w * (ux - vx)
                    ay += ali_w * (uy - vy)
                    az += ali_w * (uz - vz)
                if nc > zero:
                    inv = one / nc
                    cdx *= inv
                    cdy *= inv
                    cdz *= inv
                    dist = np.sqrt(cdx * cdx + cdy * cdy + cdz * cdz)
                    ux, uy, uz = _toward(cdx, cdy, cdz, max_speed * min(one, dist / coh_r))
                    ax += coh_w * (ux - vx)
                    ay += coh_w * (uy - vy)
                    az += coh_w * (uz - vz)
                if table.shape[0] > 0:
                    tx, ty, tz = _targets(
                        i, x, y, z, vx, vy, vz, hx, hy, hz, ident[i], table, path, wander, p,
                        max_speed,
                    )  # fmt: skip
                    ax += tx
                    ay += ty
                    az += tz
                near = False
                every = vx * vx + vy * vy + vz * vz > cull_speed2
                if n_active > 0 or (every and colliders.shape[0] > 0):
                    tx, ty, tz, near = _avoid(
                        x, y, z, vx, vy, vz, hx, hy, hz, colliders, active, n_active, every,
                        mesh, p, max_speed,
                    )  # fmt: skip
                    ax += tx
                    ay += ty
                    az += tz
                # Limits: acceleration, then turning rate, then speed.
                amag = np.sqrt(ax * ax + ay * ay + az * az)
                if amag > max_accel:
                    s = max_accel / amag
                    ax *= s
                    ay *= s
                    az *= s
                wx, wy, wz = vx + ax * dt, vy + ay * dt, vz + az * dt
                speed = np.sqrt(wx * wx + wy * wy + wz * wz)
                if speed > np.float32(1e-6):
                    ux, uy, uz = wx / speed, wy / speed, wz / speed
                else:
                    ux, uy, uz = hx, hy, hz
                c = ux * hx + uy * hy + uz * hz
                if c < cos_turn:
                    qx, qy, qz = ux - c * hx, uy - c * hy, uz - c * hz
                    q = np.sqrt(qx * qx + qy * qy + qz * qz)
                    if q < np.float32(1e-6):  # straight back: turn to a fixed side
                        qx, qy, qz = _perpendicular(hx, hy, hz)
                    else:
                        qx, qy, qz = qx / q, qy / q, qz / q
                    ux = cos_turn * hx + sin_turn * qx
                    uy = cos_turn * hy + sin_turn * qy
                    uz = cos_turn * hz + sin_turn * qz
                    u = np.sqrt(ux * ux + uy * uy + uz * uz)
                    ux, uy, uz = ux / u, uy / u, uz / u
                speed = min(max(speed, min_speed), max_speed)
                wx, wy, wz = ux * speed, uy * speed, uz * speed
                nx, ny, nz = x + wx * dt, y + wy * dt, z + wz * dt
                if near:
                    nx, ny, nz, wx, wy, wz = _keep_out(
                        x, y, z, nx, ny, nz, wx, wy, wz, colliders, mesh, radius
                    )
                    s2 = wx * wx + wy * wy + wz * wz
                    if s2 > np.float32(1e-12):
                        s = one / np.sqrt(s2)
                        ux, uy, uz = wx * s, wy * s, wz * s
                pos_out[0, i], pos_out[1, i], pos_out[2, i] = nx, ny, nz
                vel_out[0, i], vel_out[1, i], vel_out[2, i] = wx, wy, wz
                head_out[0, i], head_out[1, i], head_out[2, i] = ux, uy, uz
                # Bank into the turn: tan(bank) = lateral acceleration / g, the lateral
                # acceleration being speed × yaw rate, the yaw rate positive turning right
                # (clockwise seen from above: the right being heading × y).
                yaw = (hx * uz - hz * ux) / dt
                target = _atan(speed * yaw / gravity)
                bank[i] += (target - bank[i]) * bank_rate
                phase = flap[i] + flap_step * speed
                flap[i] = phase - np.float32(2.0 * np.pi) * np.floor(
                    phase / np.float32(2.0 * np.pi)
                )


@parallel_kernel
def interact(
    pos, vel, other_pos, other_vel, cell_start, origin, inv_cell, dims, mode, r2, weight,
    extra_param, max_speed, acc,
):  # fmt: skip
    """Add to ``acc`` (3, n) [m/s²] what each boid does about another flock's boids.

    ``other_pos`` and ``other_vel`` (3, m) are in the order of the other flock's grid
    (``cell_start`` ...), whose cell edge is at least ``sqrt(r2)``. ``mode`` is a
    :class:`motes.flock.behaviors.Mode`; ``extra_param`` the leader-following distance
    behind the leader [m].
    """
    n = pos.shape[1]
    zero = np.float32(0.0)
    one = np.float32(1.0)
    r = np.float32(np.sqrt(r2))
    r2 = np.float32(r2)
    w = np.float32(weight)
    max_speed = np.float32(max_speed)
    nx_, ny_, nz_ = dims[0], dims[1], dims[2]
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            x, y, z = pos[0, i], pos[1, i], pos[2, i]
            vx, vy, vz = vel[0, i], vel[1, i], vel[2, i]
            cx = cell_coordinate(x, origin[0], inv_cell, nx_)
            cy = cell_coordinate(y, origin[1], inv_cell, ny_)
            cz = cell_coordinate(z, origin[2], inv_cell, nz_)
            x0, x1 = max(cx - 1, 0), min(cx + 1, nx_ - 1)
            px = py = pz = zero
            best = r2
            nearest = -1
            for gz in range(max(cz - 1, 0), min(cz + 1, nz_ - 1) + 1):
                for gy in range(max(cy - 1, 0), min(cy + 1, ny_ - 1) + 1):
                    row = nx_ * (gy + ny_ * gz)
                    first = np.uint64(cell_start[row + x0])
                    end = np.uint64(cell_start[row + x1 + 1])
                    for j in range(first, end):
                        dx = other_pos[0, j] - x
                        dy = other_pos[1, j] - y
                        dz = other_pos[2, j] - z
                        d2 = dx * dx + dy * dy + dz * dz
                        if d2 > r2:
                            continue
                        if mode <= _EVADE:  # _AVOID or _EVADE
                            d = np.sqrt(d2)
                            if mode == _EVADE:
                                # Flee where the predator will be when it could reach us.
                                t = d / max(max_speed, np.float32(1e-6))
                                dx += other_vel[0, j] * t
                                dy += other_vel[1, j] * t
                                dz += other_vel[2, j] * t
                            ux, uy, uz = _toward(dx, dy, dz, one - d / r)
                            px -= ux
                            py -= uy
                            pz -= uz
                        elif d2 < best or nearest < 0:
                            best = d2
                            nearest = np.int64(j)
            if mode <= _EVADE:  # _AVOID or _EVADE
                s = w * max_speed
                acc[0, i] += s * px
                acc[1, i] += s * py
                acc[2, i] += s * pz
            elif nearest >= 0:
                ox, oy, oz = other_pos[0, nearest], other_pos[1, nearest], other_pos[2, nearest]
                ovx, ovy, ovz = other_vel[0, nearest], other_vel[1, nearest], other_vel[2, nearest]
                if mode == _PURSUE:
                    t = np.sqrt(best) / max(max_speed, np.float32(1e-6))
                    ux, uy, uz = _toward(
                        ox + ovx * t - x, oy + ovy * t - y, oz + ovz * t - z, max_speed
                    )
                else:  # _FOLLOW: arrive at a point behind the leader
                    bx, by, bz = _toward(ovx, ovy, ovz, np.float32(extra_param))
                    dx, dy, dz = ox - bx - x, oy - by - y, oz - bz - z
                    dist = np.sqrt(dx * dx + dy * dy + dz * dz)
                    # Slowing over the following distance (at least 0.5 m) as arrive does.
                    ramp = max(np.float32(extra_param), np.float32(0.5))
                    ux, uy, uz = _toward(dx, dy, dz, max_speed * min(one, dist / ramp))
                acc[0, i] += w * (ux - vx)
                acc[1, i] += w * (uy - vy)
                acc[2, i] += w * (uz - vz)


@parallel_kernel
def neighbor_lists(pos, head, cell_start, origin, inv_cell, dims, r2, cos_half, out, count):
    """Slots of each boid's neighbours under one rule, in the order :func:`step` visits
    them; ``out`` (n, capacity + 1) int32, ``count`` (n,) int64 the true counts (the
    caller grows ``out`` when one exceeds the capacity)."""
    n = pos.shape[1]
    last = out.shape[1] - 1
    r2 = np.float32(r2)
    cos_half = np.float32(cos_half)
    nx_, ny_, nz_ = dims[0], dims[1], dims[2]
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            x, y, z = pos[0, i], pos[1, i], pos[2, i]
            hx, hy, hz = head[0, i], head[1, i], head[2, i]
            cx = cell_coordinate(x, origin[0], inv_cell, nx_)
            cy = cell_coordinate(y, origin[1], inv_cell, ny_)
            cz = cell_coordinate(z, origin[2], inv_cell, nz_)
            x0, x1 = max(cx - 1, 0), min(cx + 1, nx_ - 1)
            found = 0
            for gz in range(max(cz - 1, 0), min(cz + 1, nz_ - 1) + 1):
                for gy in range(max(cy - 1, 0), min(cy + 1, ny_ - 1) + 1):
                    row = nx_ * (gy + ny_ * gz)
                    for j in range(cell_start[row + x0], cell_start[row + x1 + 1]):
                        dx = pos[0, j] - x
                        dy = pos[1, j] - y
                        dz = pos[2, j] - z
                        d2 = dx * dx + dy * dy + dz * dz
                        if d2 > r2 or j == i:
                            continue
                        if dx * hx + dy * hy + dz * hz >= cos_half * np.sqrt(d2):
                            out[i, min(found, last)] = j
                            found += 1
            count[i] = found
