"""Lights and surface shading of opaque geometry, in linear light.

The shading model, per sample with unit normal ``n`` (turned toward the viewer), unit
direction to the viewer ``v``, albedo ``c`` and, for each light, unit direction toward
the light ``l`` and radiance ``L`` (a directional light's is constant; a point light's
``l`` points from the sample to the light and its ``L`` falls off as ``1/d²`` with the
distance ``d``, unless it is made not to):

.. math::

    C = E + c \\odot \\Big(A(n) + \\sum_l L \\max(0, n \\cdot l)\\Big)
          + k_s \\sum_l L \\max(0, n \\cdot h)^{s} [n \\cdot l > 0],
    \\qquad h = \\frac{l + v}{\\lVert l + v \\rVert}

Lambert diffuse without the 1/π (a white surface facing a light of intensity 1 reflects
1), a hemisphere ambient :math:`A(n) = G + (S - G)(1 + n_y)/2` between a ground colour
``G`` and a sky colour ``S`` (Lambert-weighted sky light, as in three.js'
``HemisphereLight``), and Blinn-Phong highlights (Blinn 1977) with strength ``k_s`` and
exponent ``s``, white, not tinted by the albedo. ``E`` is the emission.
"""

from __future__ import annotations

import math

import numpy as np

from .. import _validate as check
from .._jit import device
from ..color import parse_color
from .shadows import visibility

# Layout of one surface row (float64) that the rasteriser reads per object: Blinn-Phong
# strength and exponent, emission, flat-shading flag, checker colour and checker cells
# per metre (0: no checker; stored inverted to spare a division per pixel).
SPECULAR, SHININESS, EMISSION, FLAT, CHECKER_COLOR, CHECKER_DENSITY = 0, 1, 2, 5, 6, 9
SURFACE_SIZE = 10

# Layout of one packed light: unit direction toward the light (directional), radiance,
# position (point), a point-light flag (1: point, 0: directional), whether a point light
# falls off with the square of the distance, and the index of the light's shadow map (-1:
# none; :mod:`motes.render.shadows`).
LIGHT_DIRECTION, LIGHT_RADIANCE, LIGHT_POSITION, LIGHT_POINT, LIGHT_FALLOFF = 0, 3, 6, 9, 10
LIGHT_SHADOW = 11
LIGHT_SIZE = 12


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
            row[LIGHT_SHADOW] = -1.0
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


@device
def shade(
    nx, ny, nz, vx, vy, vz, wx, wy, wz, r, g, b, surfaces, s, lights, ambient, shadow_cams,
    shadow_maps,
):  # fmt: skip
    """Outgoing radiance (r, g, b) of a surface sample (see the module docstring).

    ``(nx, ny, nz)`` and ``(vx, vy, vz)`` are the unit normal and unit direction to the
    viewer, ``(wx, wy, wz)`` the sample's world position [m] (for point lights),
    ``(r, g, b)`` the albedo, ``surfaces[s]`` the surface row (passed as table and
    index: slicing a row out would cost a reference-count update per sample), ``lights``
    the packed lights, ``ambient`` the packed (sky, ground) ambient, and
    ``shadow_cams``/``shadow_maps`` the packed light cameras and depth maps of the lights
    that cast shadows (:mod:`motes.render.shadows`).
    """
    up = 0.5 * (1.0 + ny)
    dr = ambient[3] + (ambient[0] - ambient[3]) * up
    dg = ambient[4] + (ambient[1] - ambient[4]) * up
    db = ambient[5] + (ambient[2] - ambient[5]) * up
    sr = 0.0
    sg = 0.0
    sb = 0.0
    ks = surfaces[s, SPECULAR]
    for k in range(lights.shape[0]):
        lx = lights[k, LIGHT_DIRECTION]
        ly = lights[k, LIGHT_DIRECTION + 1]
        lz = lights[k, LIGHT_DIRECTION + 2]
        scale = 1.0
        if lights[k, LIGHT_POINT] > 0.5:
            lx = lights[k, LIGHT_POSITION] - wx
            ly = lights[k, LIGHT_POSITION + 1] - wy
            lz = lights[k, LIGHT_POSITION + 2] - wz
            d2 = max(lx * lx + ly * ly + lz * lz, 1e-12)
            inv = 1.0 / math.sqrt(d2)
            lx *= inv
            ly *= inv
            lz *= inv
            if lights[k, LIGHT_FALLOFF] > 0.5:
                scale = 1.0 / d2
        cos_l = (nx * lx + ny * ly + nz * lz) * scale
        if cos_l <= 0.0:
            continue
        shadow = int(lights[k, LIGHT_SHADOW])
        if shadow >= 0:
            seen = visibility(shadow_cams, shadow_maps, shadow, nx, ny, nz, wx, wy, wz)
            if seen <= 0.0:
                continue
            scale *= seen
            cos_l *= seen
        dr += lights[k, LIGHT_RADIANCE] * cos_l
        dg += lights[k, LIGHT_RADIANCE + 1] * cos_l
        db += lights[k, LIGHT_RADIANCE + 2] * cos_l
        if ks > 0.0:
            hx = lx + vx
            hy = ly + vy
            hz = lz + vz
            h = math.sqrt(hx * hx + hy * hy + hz * hz)
            cos_h = (nx * hx + ny * hy + nz * hz) / max(h, 1e-12)
            if cos_h > 0.0:
                spec = ks * scale * cos_h ** surfaces[s, SHININESS]
                sr += lights[k, LIGHT_RADIANCE] * spec
                sg += lights[k, LIGHT_RADIANCE + 1] * spec
                sb += lights[k, LIGHT_RADIANCE + 2] * spec
    return (
        surfaces[s, EMISSION] + r * dr + sr,
        surfaces[s, EMISSION + 1] + g * dg + sg,
        surfaces[s, EMISSION + 2] + b * db + sb,
    )
