"""Jakobsen (2001), "Advanced Character Physics", as a short script: a ragdoll dropped
on a plane.

The paper's loop, once per time step: (1) Verlet integration moves every particle by
its velocity, the difference of its last two positions, and by gravity; (2) the
constraints (sticks for bones, rigid torso and pelvis, joint limits) and the
collisions (particles projected out of the ground) are satisfied by relaxation,
several iterations of projecting each one in turn. A ragdoll is nothing but particles
at its joints held by those constraints.
"""

import numpy as np

import motes as mo

world = mo.RigidWorld(iterations=10)  # (2) relaxation iterations per step
world.add_collider(mo.colliders.Plane((0, 1, 0), 0.0, friction=0.6, restitution=0.0))
doll = mo.add_ragdoll(world, (0.0, 0.5, 0.0), height=1.75, mass=70.0)  # 15 particles
world.set_velocity(doll.indices, (0.0, 0.0, 1.5))  # a push forward as it drops

if __name__ == "__main__":
    worst = 0.0
    for _ in range(5 * 60):  # five seconds at 60 Hz
        world.step(1 / 60)  # (1) Verlet, then (2) relaxation
        worst = max(worst, doll.limit_violation(world.position).max())
    speed = np.linalg.norm(world.velocity, axis=1).max()
    print(f"particles: {world.count}, constraints: {len(world.constraints)}")
    print(f"at rest: {speed < 0.05} (fastest particle {speed:.4f} m/s)")
    print(f"worst joint-limit violation: {np.degrees(worst):.1f} degrees")
