"""How a scene looks: its render settings, opaque objects and each system's look.

Plain data read from a scene file by :mod:`.scene` and turned into renderer calls by
:mod:`.drawing`; both import it, and drawing needs nothing of the scene module.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class SurfaceLook:
    """A system drawn as one metaball surface (``[system.render] kind = "surface"``)."""

    radius: float = 0.1  # [m] of a lone particle's sphere
    sharpness: float = 1.5
    threshold: float = 1.0
    cell_size: float | None = None  # [m]; None: radius / 2
    specular: float = 0.6
    color: tuple | None = None  # None: the particles' mean colour


@dataclass
class SpheresLook:
    """A system drawn as shaded spheres of the particles' radius (``kind = "spheres"``)."""

    subdivisions: int = 1  # icosphere level per particle
    specular: float = 0.4
    color: tuple | None = None  # None: each particle's colour (grey without colours)


@dataclass
class WaterLook:
    """A system drawn as clear water in screen space (``kind = "water"``):
    :class:`~motes.render.water.Water` over its particles."""

    radius: float = 0.05  # [m] of each particle's sphere
    clarity: float = 1.0  # [m]: depth at which white light has taken the colour
    scatter: float = 0.1
    smoothing: float = 3.0  # in radii
    refraction: float = 0.25
    specular: float = 1.0
    color: tuple | None = None  # the tint; None: the particles' mean colour


@dataclass
class ParticleLook:
    """How one system's particles are drawn (the ``[system.render]`` table)."""

    kind: str = "sprite"  # "sprite", "point", "surface", "spheres" or "water"
    blend: str = "additive"  # "additive" or "alpha"
    softness: float = 0.0  # [m]; 0 = hard depth test
    shutter: float = 0.0  # [s]; > 0 draws motion-blur streaks
    intensity: float = 1.0
    texture: Path | None = None
    visible: bool = True
    lit: bool = False  # shaded by the lights through shadows (smoke), not emissive
    shadows: bool = False  # casts opacity shadows on geometry and lit particles
    light: float = 0.0  # lights the scene: render.emitted_light (0: no)
    surface: SurfaceLook | None = None  # kind "surface"
    spheres: SpheresLook | None = None  # kind "spheres"
    water: WaterLook | None = None  # kind "water"


@dataclass
class RenderSettings:
    """The ``[render]`` table."""

    background: tuple = ((0.0, 0.0, 0.0, 1.0), None)
    exposure: float = 1.0
    tonemap: str = "aces"
    supersample: int = 2
    bloom: object = None  # a render.bloom.Bloom, or None
    ambient_occlusion: object = None  # a render.occlusion.AmbientOcclusion, or None
    lights: list = field(default_factory=list)  # DirectionalLight and PointLight
    ambient: tuple | None = None  # (sky, ground) linear RGB; None: the default ambient


@dataclass
class SceneObject:
    """An opaque object to draw: ``kind`` is ground, sphere or box, ``params`` its sizes."""

    kind: str
    params: dict
    color: tuple
