"""What a rigid world's step changes, and what it is given.

- :class:`WorldState`: everything that changes from step to step and decides the next
  one (positions, previous positions, time, the last substep, the bodies' rotation warm
  start). Restoring a saved state reproduces the run from there bit for bit.
- :class:`WorldControl`: the inputs of the next step (velocities set or added from
  outside); the step consumes them.
- :class:`WorldWorkspace`: the step's outputs and scratch (contacts per particle, the
  positions before the relaxation), reusable from step to step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(eq=False)
class WorldState:
    """A rigid world at one instant: the whole position-Verlet state.

    Position Verlet carries the velocity as ``(x - x*)/h``, so positions, previous
    positions and the last substep length together are the kinematic state.
    """

    particle_position: np.ndarray
    """Particle positions [m], float64, shape (3, n)."""
    particle_previous: np.ndarray
    """Particle positions one substep ago [m], float64, shape (3, n)."""
    time: float = 0.0
    """Simulated time [s]."""
    last_substep: float | None = None
    """Length h of the last substep [s]; None before the first step (velocities 0)."""
    body_rotation: np.ndarray | None = None
    """Each body's rotation, rest frame to world, shape (b, 3, 3): the warm start the
    body contacts refine each iteration (Müller et al. 2016), so part of the state;
    None to start from the exact rotations (SVD) at the next step."""

    @property
    def particle_count(self) -> int:
        """Number of particles n."""
        return self.particle_position.shape[1]

    def copy(self) -> WorldState:
        """A deep copy (arrays copied): save one to rewind a world to it later."""
        return WorldState(
            self.particle_position.copy(),
            self.particle_previous.copy(),
            self.time,
            self.last_substep,
            None if self.body_rotation is None else self.body_rotation.copy(),
        )


@dataclass(eq=False)
class WorldControl:
    """Velocity changes given between steps, applied at the start of the next substep
    (velocities set first, then the changes added, each in the order given)."""

    particle_velocity_sets: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    """``(indices (k,) int64, velocity (k, 3) [m/s])``: velocities replaced."""
    particle_velocity_changes: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    """``(indices (k,) int64, change (k, 3) [m/s])``: velocities added to (an index may
    repeat: its changes add up)."""

    def clear(self) -> None:
        """Forget every pending change (the step calls it once it applied them)."""
        self.particle_velocity_sets.clear()
        self.particle_velocity_changes.clear()


@dataclass(eq=False)
class WorldWorkspace:
    """Buffers of a step: what it reports and what it needs between its stages."""

    particle_hits: np.ndarray
    """Contacts found per particle during the last step (colliders, bodies, spheres),
    int64, shape (n,)."""
    particle_before: np.ndarray
    """Positions after the move, before the relaxation [m], shape (3, n): the velocity
    pass measures the approach speed from them."""

    @classmethod
    def zeros(cls, particle_count: int) -> WorldWorkspace:
        """Buffers for ``particle_count`` particles."""
        return cls(np.zeros(particle_count, dtype=np.int64), np.zeros((3, particle_count)))
