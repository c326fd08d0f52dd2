"""Forces and fields: gravity, drag, wind, radial fields, vortices, curl noise, springs."""

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
]
