"""A ragdoll of 15 particles and 31 constraints (Jakobsen 2001, §5, the Hitman ragdoll).

Particles sit at the joints; sticks make the bones; the torso is a rigid tetrahedron
(neck, both shoulders, a chest point in front of the spine) and the pelvis a rigid
triangle (chest, both hips), joined at the chest by a ball joint (the spine). Joint
limits are angle limits (dot-product constraints enforced by temporary rods), with
ranges from the normal human ranges of motion (e.g. Norkin & White, *Measurement of
Joint Motion*): the inner angle at the knee and elbow stays above 30° and 25° (full
flexion), the hip keeps its thigh out of the belly and within abduction/adduction
limits, the neck and spine bend forward by at most about 70°, the arm cannot pass
through the shoulder.

Lengths come from Drillis & Contini's segment fractions of the body height and masses
from Dempster's segment fractions (as tabulated by Winter, *Biomechanics and Motor
Control of Human Movement*, table 4.1). The limits are unsigned angles: a knee is kept
from folding completely, but it may bend either way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _validate as check
from .shapes import BodyShape

NAMES = (
    "head",
    "neck",
    "shoulder_l",
    "shoulder_r",
    "elbow_l",
    "elbow_r",
    "wrist_l",
    "wrist_r",
    "chest",
    "hip_l",
    "hip_r",
    "knee_l",
    "knee_r",
    "ankle_l",
    "ankle_r",
)

#: Bones drawn as lines (the torso and pelvis edges included).
SEGMENTS = (
    ("neck", "head"),
    ("neck", "shoulder_l"),
    ("neck", "shoulder_r"),
    ("shoulder_l", "shoulder_r"),
    ("shoulder_l", "chest"),
    ("shoulder_r", "chest"),
    ("neck", "chest"),
    ("chest", "hip_l"),
    ("chest", "hip_r"),
    ("hip_l", "hip_r"),
    ("shoulder_l", "elbow_l"),
    ("elbow_l", "wrist_l"),
    ("shoulder_r", "elbow_r"),
    ("elbow_r", "wrist_r"),
    ("hip_l", "knee_l"),
    ("knee_l", "ankle_l"),
    ("hip_r", "knee_r"),
    ("knee_r", "ankle_r"),
)

#: (pivot, i, j, min, max) angle limits [degrees].
LIMITS = (
    ("neck", "chest", "head", 110, 180),
    ("chest", "neck", "hip_l", 110, 180),
    ("chest", "neck", "hip_r", 110, 180),
    ("elbow_l", "shoulder_l", "wrist_l", 25, 180),
    ("elbow_r", "shoulder_r", "wrist_r", 25, 180),
    ("knee_l", "hip_l", "ankle_l", 30, 180),
    ("knee_r", "hip_r", "ankle_r", 30, 180),
    ("hip_l", "chest", "knee_l", 50, 180),
    ("hip_r", "chest", "knee_r", 50, 180),
    ("hip_l", "hip_r", "knee_l", 60, 140),
    ("hip_r", "hip_l", "knee_r", 60, 140),
    ("shoulder_l", "neck", "elbow_l", 30, 180),
    ("shoulder_r", "neck", "elbow_r", 30, 180),
)


@dataclass(frozen=True)
class RagdollProportions:
    """Body proportions as fractions of the height (Drillis & Contini 1966).

    Attributes
    ----------
    shoulder_width, hip_width : float
        Distance between the shoulder joints and between the hip joints.
    upper_arm, forearm, thigh, shin : float
        Segment lengths (forearm: elbow to wrist; shin: knee to ankle).
    head_radius : float
        Contact radius of the head particle.
    """

    shoulder_width: float = 0.259
    hip_width: float = 0.191
    upper_arm: float = 0.186
    forearm: float = 0.146
    thigh: float = 0.245
    shin: float = 0.246
    head_radius: float = 0.06

    def __post_init__(self):
        for name in (
            "shoulder_width",
            "hip_width",
            "upper_arm",
            "forearm",
            "thigh",
            "shin",
            "head_radius",
        ):
            check.real(name, getattr(self, name), low=0.01, high=0.5)


class Ragdoll:
    """Handle of a ragdoll in a world: particle indices by joint name, bones, limits."""

    def __init__(self, particles: dict, limits: np.ndarray, limit_range: np.ndarray, torso, pelvis):
        self.particles = particles
        self.limits = limits
        self.limit_range = limit_range
        self.torso = torso
        self.pelvis = pelvis
        self.segments = np.array([[particles[a], particles[b]] for a, b in SEGMENTS])
        self.hinges: np.ndarray | None = None  # (4, 5) rows (i, k, l, r, j)
        self.hinge_sign = np.zeros(0)

    @property
    def indices(self) -> np.ndarray:
        return np.array([self.particles[n] for n in NAMES])

    def limit_violation(self, position: np.ndarray) -> np.ndarray:
        """How far [rad] each joint is outside its range (0 when inside).

        The 13 angle limits, then the 4 hinge sides (the angle by which the lower limb
        has crossed its hinge plane, where the plane is defined: the upper bone more
        than 30° from the hip or shoulder axis, as the limit itself). ``position`` is
        the world's (n, 3) positions.
        """
        pivot, i, j = (position[self.limits[:, c]] for c in range(3))
        a, b = i - pivot, j - pivot
        cos = np.einsum("ij,ij->i", a, b) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
        angle = np.arccos(np.clip(cos, -1.0, 1.0))
        lo, hi = self.limit_range.T
        angles = np.maximum(lo - angle, 0.0) + np.maximum(angle - hi, 0.0)
        if self.hinges is None:
            return angles
        side = _hinge_side(position, self.hinges, self.hinge_sign)
        limb = np.linalg.norm(position[self.hinges[:, 4]] - position[self.hinges[:, 1]], axis=1)
        crossed = np.arcsin(np.clip(np.maximum(side, 0.0) / limb, 0.0, 1.0))
        i, k, left, right = (position[self.hinges[:, c]] for c in range(4))
        bone, axis = k - i, right - left
        sin = np.linalg.norm(np.cross(bone, axis), axis=1)
        sin /= np.linalg.norm(bone, axis=1) * np.linalg.norm(axis, axis=1)
        return np.concatenate([angles, np.where(sin > 0.5, crossed, 0.0)])


def _layout(height, p: RagdollProportions) -> dict:
    """Standing pose, feet at y = 0, facing +z, in metres."""
    h = height
    ankle, knee = 0.039 * h, 0.039 * h + p.shin * h
    hip = knee + p.thigh * h
    shoulder = 0.818 * h
    s, w = p.shoulder_width * h / 2, p.hip_width * h / 2
    return {
        "head": (0.0, 0.936 * h, 0.0),
        "neck": (0.0, 0.85 * h, 0.0),
        "shoulder_l": (s, shoulder, 0.0),
        "shoulder_r": (-s, shoulder, 0.0),
        "elbow_l": (s + 0.02 * h, shoulder - p.upper_arm * h, 0.0),
        "elbow_r": (-s - 0.02 * h, shoulder - p.upper_arm * h, 0.0),
        "wrist_l": (s + 0.03 * h, shoulder - (p.upper_arm + p.forearm) * h, 0.02 * h),
        "wrist_r": (-s - 0.03 * h, shoulder - (p.upper_arm + p.forearm) * h, 0.02 * h),
        "chest": (0.0, 0.5 * (shoulder + hip), 0.07 * h),
        "hip_l": (w, hip, 0.0),
        "hip_r": (-w, hip, 0.0),
        "knee_l": (w, knee, 0.01 * h),
        "knee_r": (-w, knee, 0.01 * h),
        "ankle_l": (w, ankle, 0.0),
        "ankle_r": (-w, ankle, 0.0),
    }


# Dempster's segment mass fractions (Winter, table 4.1), shared between the segment's
# end particles; the torso's (thorax and abdomen) over its four particles, the pelvis's
# over its three.
_SEGMENT_MASS = (
    (("head",), 0.081),
    (("neck", "shoulder_l", "shoulder_r", "chest"), 0.355),
    (("chest", "hip_l", "hip_r"), 0.142),
    (("shoulder_l", "elbow_l"), 0.028),
    (("shoulder_r", "elbow_r"), 0.028),
    (("elbow_l", "wrist_l"), 0.022),
    (("elbow_r", "wrist_r"), 0.022),
    (("hip_l", "knee_l"), 0.100),
    (("hip_r", "knee_r"), 0.100),
    (("knee_l", "ankle_l"), 0.061),
    (("knee_r", "ankle_r"), 0.061),
)


def add_ragdoll(
    world,
    position=(0.0, 0.0, 0.0),
    *,
    height: float = 1.8,
    mass: float = 75.0,
    proportions: RagdollProportions | None = None,
    rotation=None,
    radius: float | None = None,
    compliance: float = 0.0,
    hinge_sides: bool = False,
) -> Ragdoll:
    """Add a standing ragdoll to ``world``, its feet around ``position``.

    Parameters
    ----------
    world : World
    position : (3,) array_like
        Point on the ground between the feet [m].
    height : float
        Standing height [m], > 0.
    mass : float
        Total mass [kg], > 0.
    proportions : RagdollProportions, optional
    rotation : (3, 3) array_like, optional
        Orientation (columns: the ragdoll's left, up and forward axes in the world).
    radius : float, optional
        Contact radius of every particle but the head [m]; default 0.025 × height.
    compliance : float
        XPBD compliance of the joint limits [m/N] (0: hard limits).
    hinge_sides : bool
        Add four hinge side limits so knees and elbows bend one way only (the angle
        limits are unsigned). Off by default: in eight trial throws down six steps they
        cut the time a knee or elbow spent bent backwards by more than 5° from up to
        88 % of the run to at most 1.7 % with no particle faster than without them, but
        a knee left slightly past its plane on the ground can keep a resting ragdoll
        creeping (0.08 m/s after 4 s in a fall on flat ground; see docs/rigid.md).
    """
    height = check.positive("height", height)
    mass = check.positive("mass", mass)
    p = proportions or RagdollProportions()
    radius = 0.025 * height if radius is None else check.non_negative("radius", radius)
    layout = _layout(height, p)
    local = np.array([layout[n] for n in NAMES])
    pos = check.vector("position", position)
    rot = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
    if (
        rot.shape != (3, 3)
        or not np.allclose(rot @ rot.T, np.eye(3), atol=1e-6)
        or np.linalg.det(rot) < 0
    ):
        raise ValueError("rotation must be a (3, 3) rotation matrix (det +1)")
    world_pos = pos + local @ rot.T
    masses = dict.fromkeys(NAMES, 0.0)
    for names, fraction in _SEGMENT_MASS:
        for n in names:
            masses[n] += fraction * mass / len(names)
    where = {n: i for i, n in enumerate(NAMES)}
    radii = np.full(len(NAMES), radius)
    radii[where["head"]] = p.head_radius * height
    # Limbs and head as loose particles; torso and pelvis as rigid bodies sharing them.
    index = world.add_particles(world_pos, [masses[n] for n in NAMES], radii)
    ids = {n: int(index[where[n]]) for n in NAMES}
    group = int(index[0])  # the parts of one ragdoll never collide with each other
    torso_names = ("neck", "shoulder_l", "shoulder_r", "chest")
    pelvis_names = ("chest", "hip_l", "hip_r")
    torso = _part(world, world_pos, where, ids, torso_names, True, group)
    pelvis = _part(world, world_pos, where, ids, pelvis_names, False, group)
    bones = [
        ("neck", "head"),
        ("shoulder_l", "elbow_l"),
        ("elbow_l", "wrist_l"),
        ("shoulder_r", "elbow_r"),
        ("elbow_r", "wrist_r"),
        ("hip_l", "knee_l"),
        ("knee_l", "ankle_l"),
        ("hip_r", "knee_r"),
        ("knee_r", "ankle_r"),
    ]
    world.add_sticks([[ids[a], ids[b]] for a, b in bones])
    triples = np.array([[ids[a], ids[b], ids[c]] for a, b, c, _, _ in LIMITS])
    ranges = np.radians([[lo, hi] for *_, lo, hi in LIMITS])
    world.add_angle_limits(triples, ranges[:, 0], ranges[:, 1], compliance=compliance)
    # Optional: knees and elbows bend one way, the side the (slightly bent) pose has.
    hinges = [
        (f"{upper}_{side}", f"{joint}_{side}", f"{upper}_l", f"{upper}_r", f"{end}_{side}")
        for upper, joint, end in (("hip", "knee", "ankle"), ("shoulder", "elbow", "wrist"))
        for side in ("l", "r")
    ]
    doll = Ragdoll(ids, triples, ranges, torso, pelvis)
    if hinge_sides:
        rows = np.array([[ids[n] for n in row] for row in hinges])
        world.add_hinge_sides(rows)
        doll.hinges = rows
        doll.hinge_sign = -np.sign(_hinge_side(world.position, rows, np.ones(len(rows))))
    return doll


def _hinge_side(position, rows, sign):
    """Signed distance [m] of each hinge's end past its plane (see add_hinge_sides)."""
    i, k, left, right, j = (position[rows[:, c]] for c in range(5))
    n = sign[:, None] * np.cross(k - i, right - left)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return np.einsum("ij,ij->i", j - k, n)


def _part(world, positions, where, ids, names, solid, group):
    pts = positions[[where[n] for n in names]]
    shape = BodyShape.from_points(pts, 1.0, solid=solid)
    # The masses already sit on the particles: the shape adds none.
    shape = BodyShape(shape.positions, np.zeros(len(names)), shape.sticks, shape.planes)
    share = {k: ids[n] for k, n in enumerate(names)}
    return world.add_body(shape, share=share, group=group)
