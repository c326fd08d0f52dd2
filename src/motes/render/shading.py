"""Lights, materials and surface rows of opaque geometry, packed for the kernels.

Lights: :class:`DirectionalLight` (optionally casting shadows), :class:`PointLight`,
:class:`AmbientLight`; :func:`pack_lights` turns them into the rows the shading kernels
read. The shading model itself is in :mod:`motes.render.lighting`.
"""

from __future__ import annotations

import numpy as np

from .. import _validate as check
from .._jit import device
from ..color import parse_color

# Layout of one surface row (float64) that the rasteriser reads per object: Blinn-Phong
# strength and exponent, emission, flat-shading flag, checker colour and checker cells
# per metre (0: no checker; stored inverted to spare a division per pixel).
SPECULAR, SHININESS, EMISSION, FLAT, CHECKER_COLOR, CHECKER_DENSITY = 0, 1, 2, 5, 6, 9
SURFACE_SIZE = 10

# Layout of one packed light: unit direction toward the light (directional), radiance,
# position (point), a point-light flag (1: point, 0: directional), whether a point light
# falls off with the square of the distance, and the index of the light's shadow map (-1:
# none; :mod:`motes.render.shadows`) and of its particles' opacity map (-1: none;
# :mod:`motes.render.opacity`).
LIGHT_DIRECTION, LIGHT_RADIANCE, LIGHT_POSITION, LIGHT_POINT, LIGHT_FALLOFF = 0, 3, 6, 9, 10
LIGHT_SHADOW, LIGHT_OPACITY = 11, 12
LIGHT_SIZE = 13


def rgb(name: str, value) -> np.ndarray:
    """A linear RGB colour (3,) float64 from a hex string or 3 or 4 non-negative floats.

    The alpha of an RGBA value is ignored: geometry is opaque.
    """
    try:
        return parse_color(value)[:3]
    except (TypeError, ValueError):
        raise ValueError(
            f"{name} must be a colour ('#rrggbb' or 3 non-negative floats), got {value!r}"
        ) from None


class Material:
    """How a surface reflects light, apart from its colour (which each object carries).

    Parameters
    ----------
    specular : float
        Strength ``k_s`` of the white Blinn-Phong highlight, >= 0 (0: matte).
    shininess : float
        Blinn-Phong exponent ``s`` >= 1; larger is a smaller, sharper highlight.
    emission : colour
        Radiance added regardless of lighting (linear RGB). A black object with an
        emission is drawn in exactly that colour: the way to draw unlit geometry.
    """

    def __init__(self, *, specular: float = 0.0, shininess: float = 32.0, emission=(0, 0, 0)):
        self.specular = check.non_negative("specular", specular)
        self.shininess = check.real("shininess", shininess, low=1.0)
        self.emission = rgb("emission", emission)

    def __repr__(self) -> str:
        return (
            f"Material(specular={self.specular}, shininess={self.shininess}, "
            f"emission={tuple(self.emission.tolist())})"
        )


def surface_row(material: Material | None, *, flat: bool, checker=None) -> np.ndarray:
    """The (SURFACE_SIZE,) float64 row of one object.

    ``checker`` is ``None`` or ``(colour (3,), cell size [m])``.
    """
    material = Material() if material is None else material
    if not isinstance(material, Material):
        raise TypeError(f"material must be a Material, got {material!r}")
    row = np.zeros(SURFACE_SIZE)
    row[SPECULAR] = material.specular
    row[SHININESS] = material.shininess
    row[EMISSION : EMISSION + 3] = material.emission
    row[FLAT] = float(flat)
    if checker is not None:
        row[CHECKER_COLOR : CHECKER_COLOR + 3] = checker[0]
        row[CHECKER_DENSITY] = 1.0 / checker[1]
    return row


class DirectionalLight:
    """Light from a very distant source (the sun): parallel rays of one radiance.

    Parameters
    ----------
    direction : (3,) array_like
        The way the light travels, from the source into the scene (any non-zero length):
        ``(0, -1, 0)`` falls straight down.
    color : colour
        Linear RGB of the light.
    intensity : float
        Multiplies ``color`` (>= 0): a white surface facing the light reflects
        ``color * intensity``.
    shadows : bool
        Opaque geometry casts shadows from this light onto itself and the ground (a
        shadow map filtered by percentage-closer filtering, :mod:`motes.render.shadows`).
    """

    def __init__(self, direction=(-0.35, -1.0, -0.55), *, color=(1, 1, 1), intensity=1.0,
                 shadows: bool = False):  # fmt: skip
        self.direction = check.unit_vector("direction", direction)
        self.color = rgb("color", color)
        self.intensity = check.non_negative("intensity", intensity)
        if not isinstance(shadows, bool):
            raise TypeError(f"shadows must be True or False, got {shadows!r}")
        self.shadows = shadows

    def __repr__(self) -> str:
        return f"DirectionalLight({tuple(self.direction.round(4).tolist())}, ...)"


class PointLight:
    """Light from a point (a star among its planets, a lamp): rays from ``position``.

    Parameters
    ----------
    position : (3,) array_like
        Where the light is [m].
    color : colour
        Linear RGB of the light.
    intensity : float
        Multiplies ``color`` (>= 0): a white surface facing the light ``d`` metres away
        reflects ``color * intensity / d²`` (or ``color * intensity`` without falloff).
    falloff : bool
        Inverse-square falloff with distance (True, physical) or none.
    """

    def __init__(self, position=(0.0, 0.0, 0.0), *, color=(1, 1, 1), intensity=1.0,
                 falloff: bool = True):  # fmt: skip
        self.position = check.vector("position", position)
        self.color = rgb("color", color)
        self.intensity = check.non_negative("intensity", intensity)
        if not isinstance(falloff, bool):
            raise TypeError(f"falloff must be True or False, got {falloff!r}")
        self.falloff = falloff

    def __repr__(self) -> str:
        return f"PointLight({tuple(self.position.round(4).tolist())}, ...)"


class AmbientLight:
    """Light from everywhere: uniform, or a sky/ground hemisphere blend.

    Parameters
    ----------
    color : colour
        Linear RGB from the sky (from every direction when ``ground`` is None).
    ground : colour, optional
        Linear RGB from below; a normal pointing up sees ``color``, one pointing down
        sees ``ground``, in between a blend linear in the normal's y component.
    intensity : float
        Multiplies both colours (>= 0).
    """

    def __init__(self, color=(0.3, 0.3, 0.3), *, ground=None, intensity=1.0):
        self.color = rgb("color", color)
        self.ground = self.color if ground is None else rgb("ground", ground)
        self.intensity = check.non_negative("intensity", intensity)


def default_lights() -> list:
    """A warm key light from above-left-front and a cool sky/warm ground ambient."""
    return [
        DirectionalLight((-0.35, -1.0, -0.55), color=(1.0, 0.95, 0.88), intensity=1.0),
        AmbientLight((0.30, 0.34, 0.40), ground=(0.14, 0.12, 0.10)),
    ]


def pack_lights(lights) -> tuple[np.ndarray, np.ndarray]:
    """Directional and point lights as an (L, LIGHT_SIZE) float64 array and ambient
    (sky, ground) (6,).

    ``lights`` is a sequence of :class:`DirectionalLight`, :class:`PointLight` and at most
    one :class:`AmbientLight` (none: no ambient light); ``None`` means
    :func:`default_lights`.
    """
    if lights is None:
        lights = default_lights()
    if isinstance(lights, (DirectionalLight, PointLight, AmbientLight)):
        lights = [lights]
    directional = []
    ambient = np.zeros(6)
    ambients = 0
    for i, light in enumerate(lights):
        if isinstance(light, (DirectionalLight, PointLight)):
            row = np.zeros(LIGHT_SIZE)
            row[LIGHT_SHADOW] = row[LIGHT_OPACITY] = -1.0
            row[LIGHT_RADIANCE : LIGHT_RADIANCE + 3] = light.color * light.intensity
            if isinstance(light, DirectionalLight):
                row[LIGHT_DIRECTION : LIGHT_DIRECTION + 3] = -light.direction
            else:
                row[LIGHT_POSITION : LIGHT_POSITION + 3] = light.position
                row[LIGHT_POINT] = 1.0
                row[LIGHT_FALLOFF] = float(light.falloff)
            directional.append(row)
        elif isinstance(light, AmbientLight):
            ambients += 1
            ambient[:3] = light.color * light.intensity
            ambient[3:] = light.ground * light.intensity
        else:
            raise TypeError(
                f"lights[{i}] must be a DirectionalLight, PointLight or AmbientLight, got {light!r}"
            )
    if ambients > 1:
        raise ValueError(f"lights may hold at most one AmbientLight, got {ambients}")
    packed = np.array(directional, dtype=np.float64).reshape(len(directional), LIGHT_SIZE)
    return packed, ambient


@device
def _checker_integral(x):
    """Integral of the ±1 square wave of period 2 (a triangle wave)."""
    f = x * 0.5 - np.floor(x * 0.5)  # np.floor stays in floating point
    return abs(f - 0.5)


@device
def checker_fraction(u, w, size):
    """Fraction of the second checker colour in a sample's footprint.

    ``(u, w)`` is the position in cells (world x and z divided by the cell size) and
    ``size`` the side of the footprint in cells. The checker has colour 2 where
    ``floor(u) + floor(w)`` is odd; it is box-filtered over the footprint (Quilez,
    "filtering checkerboards"): the average of the square wave over the box is the
    difference of its integral at the two ends, so distant cells fade to the mean instead
    of aliasing.
    """
    size += 1e-4
    scale = 2.0 / size
    iu = (_checker_integral(u - 0.5 * size) - _checker_integral(u + 0.5 * size)) * scale
    iw = (_checker_integral(w - 0.5 * size) - _checker_integral(w + 0.5 * size)) * scale
    return 0.5 - 0.5 * iu * iw
