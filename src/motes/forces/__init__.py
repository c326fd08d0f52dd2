"""Forces and fields: gravity, drag, wind, radial fields, vortices, curl noise, springs,
and pair forces between particles (n-body gravity, Coulomb, user pair potentials).

Every force acts on any kind: systems take them with ``add``, cloth, hair, liquids and
rigid worlds with ``add_force`` (evaluated by :func:`add_forces`).
"""

from .apply import add_forces
from .base import FieldForce, FieldTerms, Force, ForceJacobian
from .callback import CallbackForce
from .curl_noise import CurlNoise
from .fields import Drag, Gravity, QuadraticDrag, Wind
from .nbody import Coulomb, NBodyGravity
from .pair import PairForce, lennard_jones
from .radial import RadialField
from .springs import Springs
from .vortex import Vortex

__all__ = [
    "CallbackForce",
    "Coulomb",
    "CurlNoise",
    "Drag",
    "FieldForce",
    "FieldTerms",
    "Force",
    "ForceJacobian",
    "Gravity",
    "NBodyGravity",
    "PairForce",
    "QuadraticDrag",
    "RadialField",
    "Springs",
    "Vortex",
    "Wind",
    "add_forces",
    "lennard_jones",
]
