"""What changes as hair steps (its state) and what holds it (its control)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..cloth.state import MassSpringState
from ..integrate.implicit import ConstraintFilter
from .model import HairModel


@dataclass(eq=False)
class HairState(MassSpringState):
    """Hair's positions [m] and velocities [m/s] (float64 (3, n); strand ``j`` is
    particles ``j · per_strand`` to ``(j + 1) · per_strand - 1``, root first), time [s]
    and the implicit solve's warm start (see
    :class:`~motes.cloth.state.MassSpringState`)."""

    @classmethod
    def at_rest(cls, model: HairModel) -> HairState:
        """Straight strands on the head where it is at time 0, at rest."""
        r, c = model.head.pose(0.0)
        positions = np.ascontiguousarray((model.particle_rest_local @ r.T + c).T)
        return cls(positions, np.zeros((3, model.particle_count)))


@dataclass(eq=False)
class HairControl:
    """The follicles, held by the head."""

    constraints: ConstraintFilter
    """Constraint filter of the implicit solve: the follicle particles, whose target
    velocities [m/s] are set from the head's motion at the start of each step."""

    @classmethod
    def follicles(cls, model: HairModel) -> HairControl:
        """The model's follicles held."""
        constraints = ConstraintFilter(model.particle_count)
        constraints.pin(model.root_indices)
        return cls(constraints)
