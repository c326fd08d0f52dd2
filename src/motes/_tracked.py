"""Change tracking for parameter objects a step reads (colliders, field forces).

A system packs collider and field-force parameters into kernel arrays; rebuilding them
every step would dominate the cost of small systems, so it rebuilds only when an object
changed. Every attribute assignment bumps the object's ``version``; array attributes are
made read-only, so an in-place edit (``plane.normal[1] = 2``) raises instead of being
missed — assign a new value (``plane.normal = ...``) or call the object's setter.
"""

from __future__ import annotations

import numpy as np


class Tracked:
    """Mixin: ``version`` counts attribute assignments; stored arrays become read-only."""

    version = 0

    def __setattr__(self, name: str, value) -> None:
        if isinstance(value, np.ndarray):
            value = value.copy() if value.flags.writeable else value
            value.flags.writeable = False
        object.__setattr__(self, name, value)
        object.__setattr__(self, "version", self.version + 1)


def fingerprint(objects) -> tuple:
    """Identity and version of each object, in order: equal fingerprints, same parameters."""
    return tuple((id(o), o.version) for o in objects)
