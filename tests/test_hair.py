"""Hair: strands rooted on a moving head, bending by skip springs, scalp collisions."""

import numpy as np
import pytest

from motes.cloth import Keyframes
from motes.hair import Hair, Head, euler_matrix, growth_directions, scalp_directions


def nodding_head():
    return Head(
        (0.0, 1.6, 0.0),
        0.1,
        translation=Keyframes([0.0, 1.0], [[0, 0, 0], [0.1, 0.0, 0.0]]),
        rotation=Keyframes([0.0, 0.5, 1.0], [[0, 0, 0], [45, 0, 0], [45, 25, 0]]),
    )


def test_roots_move_rigidly_with_the_head_and_strands_stay_outside_it():
    head = nodding_head()
    hair = Hair(head, strands=200, particles=8, length=0.2, seed=3)
    root_local = hair.strands()[:, :2] - head.center
    for _ in range(60):
        hair.step(1 / 60)
    r, c = head.pose(hair.time)
    np.testing.assert_allclose(hair.strands()[:, :2], root_local @ r.T + c, atol=1e-12)
    distance = np.linalg.norm(hair.position.T - c, axis=1)
    # Every free particle is pushed out to the scalp plus the hair's thickness.
    assert distance[hair.model.particle_free].min() >= head.radius + hair.thickness - 1e-12
    # Stretch limited to 2 % by the Provot passes (ordered from the roots, so one pass
    # limits a strand), then the scalp pushes particles out, which can stretch a
    # segment again (measured 0.03 %).
    assert hair.segment_lengths().max() <= 0.2 / 7 * 1.025
    assert hair.last_report.converged


def test_hair_falls_and_bending_stiffness_holds_it_up():
    def tip_height(bending):
        head = Head((0.0, 0.0, 0.0), 0.1)
        hair = Hair(
            head,
            strands=1,
            particles=12,
            length=0.3,
            directions=[[1.0, 0.0, 0.0]],
            comb=None,  # straight out from the scalp
            stretch=(2000.0, 0.05),
            bending=(bending, 0.0),
            air_damping=5.0,
        )
        for _ in range(120):
            hair.step(1 / 60)
        return hair.position[1, -1]

    limp, stiff = tip_height(0.0), tip_height(20.0)
    assert limp < -0.26  # hangs straight down (10 free segments: 0.273 m)
    assert stiff > -0.12  # held out from the head in a curve (measured -0.078 m)


def test_bending_force_is_proportional_to_the_joint_angle():
    # Two segments of length s at angle θ, bending only: the force on the end is
    # k_b (x_0 - 2 x_1 + x_2), of magnitude k_b 2 s sin(θ/2) ≈ k_b s θ.
    head = Head((0.0, 0.0, 0.0), 0.1)
    hair = Hair(
        head,
        strands=1,
        particles=3,
        length=0.2,
        directions=[[1.0, 0.0, 0.0]],
        comb=None,
        bending=(10.0, 0.0),
        stretch=(0.0, 0.0),
        gravity=(0, 0, 0),
    )
    s = 0.1
    for theta in (0.05, 0.2, 0.6):
        x = hair.position.copy()
        x[:, 2] = x[:, 1] + s * np.array([np.cos(theta), np.sin(theta), 0.0])
        f = np.zeros((3, 3))
        hair.springs.accumulate(None, np.ascontiguousarray(x), np.zeros((3, 3)), 0.0, f)
        stencil = x[:, 0] - 2 * x[:, 1] + x[:, 2]
        np.testing.assert_allclose(f[:, 2], -10.0 * stencil, atol=1e-12)
        np.testing.assert_allclose(f.sum(axis=1), 0.0, atol=1e-12)  # internal force
        assert np.linalg.norm(f[:, 2]) == pytest.approx(10.0 * 2 * s * np.sin(theta / 2))


def test_bending_springs_are_exactly_the_curvature_energy():
    from motes.hair.bending import StencilSprings, angle_bending

    rng = np.random.default_rng(2)
    x = rng.normal(size=(3, 7))
    triples = np.stack([np.arange(5), np.arange(1, 6), np.arange(2, 7)], 1)
    springs = StencilSprings(*angle_bending(triples, 3.0, 0.0))
    stencil = x[:, triples[:, 0]] - 2 * x[:, triples[:, 1]] + x[:, triples[:, 2]]
    assert springs.energy(x) == pytest.approx(0.5 * 3.0 * np.sum(stencil**2), rel=1e-12)
    with pytest.raises(ValueError, match="damping must be >= 0"):
        StencilSprings([[0, 1]], 0.0, -1.0, -1.0)


def test_euler_matrix_and_scalp_directions():
    r = euler_matrix((30, 20, 10))
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)
    np.testing.assert_allclose(euler_matrix((90, 0, 0)) @ [0, 0, 1], [1, 0, 0], atol=1e-12)
    d = scalp_directions(500, seed=1)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    assert d[:, 1].min() >= 1 - 2 * 0.55 - 1e-12
    # Inside the hairline: nothing on the face (front, below the forehead line).
    assert not ((d[:, 2] > 0.15) & (d[:, 1] < 0.5)).any()
    assert d[:, 2].max() < 0.55
    np.testing.assert_array_equal(d, scalp_directions(500, seed=1))


def test_strands_leave_the_scalp_combed_down_and_back():
    d = scalp_directions(300, seed=2)
    g = growth_directions(d, np.array([0.0, -1.0, -1.0]) / np.sqrt(2), 0.3)
    np.testing.assert_allclose(np.linalg.norm(g, axis=1), 1.0)
    # Tilted out of the tangent plane by atan(0.3) (no root here has the comb normal
    # to the scalp), and always backward, away from the face (measured max z -0.21;
    # strands at the front hairline go up and back over the crown).
    np.testing.assert_allclose(np.sum(g * d, axis=1), 0.3 / np.sqrt(1.09), atol=1e-12)
    assert g[:, 2].max() < -0.1


def test_hair_hangs_behind_the_face_under_gravity():
    # Default comb and hairline on a still head: after a second every strand has
    # fallen (tip below root), and no tip hangs in front of the face.
    head = Head((0.0, 1.6, 0.0), 0.1)
    hair = Hair(head, strands=300, particles=10, length=0.25, length_variation=0.25, seed=4)
    assert np.all((hair.lengths > 0.25 * 0.75) & (hair.lengths <= 0.25))
    for _ in range(60):
        hair.step(1 / 60)
    s = hair.strands()
    assert np.all(s[:, -1, 1] < s[:, 0, 1])
    assert s[:, -1, 2].max() < head.center[2] + 0.5 * head.radius


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"strands": 0}, "strands must be >= 1"),
        ({"particles": 2}, "particles must be >= 3"),
        ({"length": 0.0}, "length must be > 0"),
        ({"directions": [[0, 1, 0]]}, "one row per strand"),
        ({"stretch": (-1.0, 0.0)}, r"stretch\[0\] must be >= 0"),
        ({"stretch_limit": 0.0}, "stretch_limit must be > 0"),
    ],
)
def test_bad_hair_parameters(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Hair(Head(), strands=kwargs.pop("strands", 2), **kwargs)


def test_bad_head():
    with pytest.raises(ValueError, match="radius must be > 0"):
        Head(radius=0.0)
    with pytest.raises(TypeError, match="rotation must be Keyframes"):
        Head(rotation=[0, 1])
    with pytest.raises(TypeError, match="head must be a Head"):
        Hair(None)
