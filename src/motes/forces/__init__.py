"""Forces and fields: gravity, drag, wind, radial fields, vortices, curl noise, springs.

Every force acts on any kind: systems take them with ``add``, cloth, hair, liquids and
rigid worlds with ``add_force`` (evaluated by :func:`add_forces`).
"""

from .apply import add_forces
from .base import FieldForce, FieldTerms, Force, ForceJacobian
from .callback import CallbackForce
from .curl_noise import CurlNoise
from .fields import Drag, Gravity, QuadraticDrag, Wind
from .radial import RadialField
from .springs import Springs
from .vortex import Vortex

__all__ = [
    "CallbackForce",
    "CurlNoise",
    "Drag",
    "FieldForce",
    "FieldTerms",
    "Force",
    "ForceJacobian",
    "Gravity",
    "QuadraticDrag",
    "RadialField",
    "Springs",
    "Vortex",
    "Wind",
    "add_forces",
]
