"""The one signed distance (motes.geometry) against its NumPy twin, for every kind, inside
and outside, in float64 and float32; and the same distance through every solver's path."""

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import naive_constraints
import naive_distance
from motes import fluids
from motes.collide import Box, Capsule, Plane, Sphere, TriangleMeshCollider
from motes.collide import colliders as particle_colliders
from motes.collide.contact import Detection, project_contacts
from motes.collide.contact import pack as pack_rigid
from motes.geometry.distance import collider_distance, signed_distance
from motes.geometry.layout import INSIDE, KIND, ROW, G, Kind, grown, pack_row
from motes.integrate.kernels import ONE, PARAM_COUNT, Scheme, step_kernel


def rotation(angle, axis):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


AXES = rotation(0.7, (1, -2, 0.5)).T  # rows: the box's axes
SHAPES = {
    "plane": (Kind.PLANE, [0.6, 0.8, 0.0, 0.25]),
    "sphere": (Kind.SPHERE, [0.1, -0.2, 0.3, 0.8]),
    "box": (Kind.BOX, [0.2, 0.1, -0.1, 0.7, 0.4, 0.9, *AXES.ravel()]),
    "capsule": (Kind.CAPSULE, [-0.5, -0.3, 0.1, 0.6, 0.4, -0.2, 0.35]),
    "ball_capsule": (Kind.CAPSULE, [0.3, 0.3, 0.3, 0.3, 0.3, 0.3, 0.5]),  # a = b
}


def points(rng, row):
    """Points around the shape, half inside; a sphere's centre and a capsule's end."""
    p = rng.uniform(-1.5, 1.5, (400, 3))
    p[0] = row[G : G + 3]
    return p


def evaluate(row, p, dtype):
    """The compiled function, called point by point, in ``dtype``; (d (m,), n (m, 3))."""
    table = row[None, :].astype(dtype)
    one = dtype(1)
    out = np.array(
        [
            signed_distance(int(row[KIND]), bool(row[INSIDE]), table, 0, *x, one)
            for x in p.astype(dtype)
        ]
    )
    return out[:, 0], out[:, 1:]


@pytest.mark.parametrize("inside", [False, True], ids=["solid", "inside"])
@pytest.mark.parametrize("shape", list(SHAPES))
def test_signed_distance_matches_the_twin_in_float64(shape, inside):
    kind, geometry = SHAPES[shape]
    row = pack_row(kind, geometry, inside=inside)
    p = points(np.random.default_rng(3), row)
    d, n = evaluate(row, p, np.float64)
    want_d, want_n = naive_distance.signed_distance(row, p)
    # Same formulas in the same precision: round-off of a few operations on O(1) values.
    assert_allclose(d, want_d, atol=1e-12)
    assert_allclose(n, want_n, atol=1e-12)
    assert np.any(d < 0) and np.any(d > 0)
    assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("inside", [False, True], ids=["solid", "inside"])
@pytest.mark.parametrize("shape", list(SHAPES))
def test_signed_distance_computes_in_float32(shape, inside):
    kind, geometry = SHAPES[shape]
    row = pack_row(kind, geometry, inside=inside)
    p = points(np.random.default_rng(4), row)
    d, n = evaluate(row, p, np.float32)
    # The twin in float64 on the same float32-rounded inputs: what is left is float32
    # round-off (eps 6e-8) through a dozen operations on values of order 1, and the
    # normal's division by distances >= 1e-2 (no point lies nearer a centre or an axis,
    # except the exact centre).
    want_d, want_n = naive_distance.signed_distance(
        row.astype(np.float32).astype(np.float64), p.astype(np.float32).astype(np.float64)
    )
    assert_allclose(d, want_d, atol=2e-6)
    assert_allclose(n, want_n, atol=2e-5)
    # Every result is float32: no literal promoted the arithmetic to float64 (which
    # would stop the fused particle step from vectorising).
    returns = [
        str(compiled.signature.return_type)
        for signature, compiled in signed_distance.overloads.items()
        if str(signature[2].dtype) == "float32"
    ]
    assert returns and set(returns) == {"UniTuple(float32 x 4)"}


def test_the_box_twin_distance_is_euclidean_outside_and_face_inside():
    row = pack_row(Kind.BOX, [0, 0, 0, 1, 2, 3, *np.eye(3).ravel()])
    p = np.array([[2.0, 3.0, 0.0], [0.0, 0.0, 2.5], [0.9, 0.0, 0.0], [0.0, 0.0, 0.0]])
    d, n = evaluate(row, p, np.float64)
    assert_allclose(d, [np.sqrt(2.0), -0.5, -0.1, -1.0], atol=1e-15)
    assert_allclose(n, [[np.sqrt(0.5), np.sqrt(0.5), 0], [0, 0, 1], [1, 0, 0], [1, 0, 0]])


def test_mesh_rows_match_a_brute_force_twin():
    from motes.render.geometry import icosphere

    vertices, faces = icosphere(2)
    collider = TriangleMeshCollider((0.6 * vertices, faces), thickness=0.05, cell_size=0.2)
    table, tri, start, cells = pack_rigid([collider], [Detection.POSTERIORI])
    assert table.shape == (1, ROW) and table[0, KIND] == Kind.MESH
    rng = np.random.default_rng(5)
    p = rng.uniform(-0.8, 0.8, (60, 3))
    for x in p:
        d, *n = collider_distance(table, 0, tri, start, cells, *x, *x, 2.0)
        want_d, want_n = naive_constraints.signed_distance(collider, x, x)
        assert_allclose(d, want_d, atol=1e-12)
        assert_allclose(n, want_n, atol=1e-9)


# -- one collider, three solvers -----------------------------------------------------------
_C, _S = np.cos(np.radians(30.0)), np.sin(np.radians(30.0))
#: 30 degrees about z, then 30 degrees about x.
TURN = np.array([[1, 0, 0], [0, _C, -_S], [0, _S, _C]]) @ np.array(
    [[_C, -_S, 0], [_S, _C, 0], [0, 0, 1]]
)
PAIRS = {
    "plane": (Plane((0, 0.6, 0.8), point=(0, 0.2, 0)), fluids.Plane((0, 0.6, 0.8), (0, 0.2, 0))),
    "sphere": (Sphere((0.2, -0.1, 0.3), 0.7), fluids.Sphere((0.2, -0.1, 0.3), 0.7)),
    "box": (Box((0.1, 0, -0.2), (1.0, 0.6, 1.4)), fluids.Box((0.1, 0, -0.2), (0.5, 0.3, 0.7))),
    "turned box": (
        Box((0.1, 0, -0.2), (1.0, 0.6, 1.4), rotation=TURN),
        fluids.Box((0.1, 0, -0.2), (0.5, 0.3, 0.7), rotation=TURN),
    ),
}


def particle_step(collider, p):
    """Push-out by the fused particle step (Scheme.NONE, no bounce, no friction)."""
    table, structure = particle_colliders.pack([collider])
    kernel = step_kernel(int(Scheme.NONE), structure, False, False, False, True)
    params = np.zeros(PARAM_COUNT)
    params[ONE] = 1.0
    pos = np.ascontiguousarray(p.T)
    n = len(p)
    keep = np.ones(n, dtype=bool)
    hits = np.zeros(n, dtype=np.int32)
    life = np.full(n, 10.0)
    vel = np.zeros((3, n))
    no_meshes = pack_rigid([])[1:]
    kernel(
        n,
        pos,
        vel,
        np.zeros(n),
        life,
        np.ones(1),
        np.zeros((3, 1)),
        params,
        table,
        *no_meshes,
        keep,
        hits,
    )
    return pos.T


def rigid_projection(collider, p):
    """Push-out by the rigid world's contact projection (radius 0, no friction)."""
    table, tri, start, cells = pack_rigid([collider], [Detection.POSTERIORI])
    x = np.ascontiguousarray(p.T)
    q = x.copy()
    n = len(p)
    hits = np.zeros(n, np.int64)
    project_contacts(*x, *q, np.zeros(n), np.ones(n), table, tri, start, cells, hits)
    return x.T


def fluid_projection(boundary, p):
    """Push-out by the fluid's boundary projection (radius 0)."""
    rows = fluids.boundaries.pack([boundary])
    x = np.ascontiguousarray(p.T)
    fluids.kernels.project(*x, rows, 0.0, np.zeros(len(p)))
    return x.T


# Slow tier: each case compiles a fused particle step of its own (15 s cold apiece).
@pytest.mark.slow
@pytest.mark.parametrize("shape", list(PAIRS))
def test_fluid_rigid_and_particle_paths_agree(shape):
    collider, boundary = PAIRS[shape]
    rows = [
        particle_colliders.pack([collider])[0][0],
        pack_rigid([collider], [Detection.POSTERIORI])[0][0],
        fluids.boundaries.pack([boundary])[0],
    ]
    for row in rows[1:]:
        assert_array_equal(row[[KIND, INSIDE]], rows[0][[KIND, INSIDE]])
        assert_allclose(row[G:], rows[0][G:], atol=1e-15)
    p = np.random.default_rng(6).uniform(-1, 1, (500, 3))
    d, _ = naive_distance.signed_distance(rows[0], p)
    assert np.count_nonzero(d < 0) > 50
    moved = [
        particle_step(collider, p),
        rigid_projection(collider, p),
        fluid_projection(boundary, p),
    ]
    for got in moved:
        # Every penetrating point lands on the surface: its distance there is zero.
        after, _ = naive_distance.signed_distance(rows[0], got)
        assert_allclose(after[d < 0], 0.0, atol=1e-12)
        assert_array_equal(got[d >= 0], p[d >= 0])
        assert_allclose(got, moved[0], atol=1e-12)


@pytest.mark.slow
def test_inside_sphere_agrees_between_the_particle_step_and_the_fluid():
    collider = Sphere((0.0, 0.1, 0.0), 0.8, inside=True)
    boundary = fluids.Sphere((0.0, 0.1, 0.0), 0.8, inside=True)
    p = np.random.default_rng(7).uniform(-1, 1, (500, 3))
    assert_allclose(particle_step(collider, p), fluid_projection(boundary, p), atol=1e-12)


def test_grown_moves_every_surface_out_by_the_amount():
    rows = np.array(
        [
            pack_row(*SHAPES[name], inside=inside)
            for name in ("plane", "sphere", "box", "capsule")
            for inside in (False, True)
            if not (name == "plane" and inside)
        ]
    )
    p = np.random.default_rng(8).uniform(-1.5, 1.5, (300, 3))
    for row, big in zip(rows, grown(rows, 0.05), strict=True):
        d, _ = naive_distance.signed_distance(row, p)
        d_big, _ = naive_distance.signed_distance(big, p)
        # Exact for planes, spheres and capsules; for a box, where the offset surface's
        # rounded edges would differ, only away from them (here: along the faces).
        if row[KIND] != Kind.BOX:
            assert_allclose(d_big, d - 0.05, atol=1e-12)
        else:
            assert np.all(d_big <= d - 0.05 + 1e-12)


def test_packing_rejects_a_wrong_geometry_width():
    with pytest.raises(ValueError, match="SPHERE row takes 4"):
        pack_row(Kind.SPHERE, [0, 0, 0])
    assert Capsule().packed()[KIND] == Kind.CAPSULE
