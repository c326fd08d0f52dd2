"""Light that glowing particles and hot volumes cast on the scene, as point lights.

A system of emissive particles (fire, sparks) or a volume glowing by its temperature (a
fireball) lights what is around it when asked to (``SpriteStyle(light=k)``,
``Volume(light=k)``): each becomes one :class:`~motes.render.shading.PointLight` for the
frame, at the centre of its light (positions weighted by each emitter's luminance), of
colour and intensity ``k`` times the summed light of its emitters:

- a particle is a glowing disc facing the viewer, of radiance ``colour × alpha ×
  intensity`` (what an additive sprite adds) and area ``π r²``: intensity ``radiance ×
  π r²``;
- a voxel emits ``e ρ B(T)`` radiance per metre in every direction
  (:class:`~motes.render.volume.Volume`): intensity ``e ρ B(T) × voxel volume``.

At ``k = 1`` the light is what the emitters give off when nothing of them is hidden by
the rest (a thick fireball hides much of itself: ``k`` below 1). One point for the whole
emitter is a far-field approximation: near a large one, surfaces are lit as if by its
centre. The lights cast no shadows.
"""

from __future__ import annotations

import numpy as np

from .shading import PointLight

#: Luminance weights of linear sRGB (Rec. 709).
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def particle_light(state, style) -> PointLight | None:
    """The point light of ``state``'s particles drawn with ``style`` (None when
    ``style.light`` is 0 or they give no light)."""
    gain = float(getattr(style, "light", 0.0))
    if gain <= 0.0 or state.count == 0:
        return None
    # without a colour field particles are drawn white, so they glow white
    white = np.ones((4, state.count))
    rgba = np.asarray(state["color"], np.float64) if "color" in state else white
    radius = np.asarray(state.radius, np.float64)
    power = rgba[:3] * (rgba[3] * float(style.intensity) * np.pi * radius**2)  # (3, n)
    return _light(np.asarray(state.positions, np.float64), power, gain)


def volume_light(volume) -> PointLight | None:
    """The point light of ``volume``'s glow (None when its ``light`` or emission is 0
    or nothing is hot enough to glow)."""
    gain = float(getattr(volume, "light", 0.0))
    if gain <= 0.0 or volume.emission <= 0.0 or volume.temperature is None:
        return None
    from .volume_blackbody import BLACKBODY_MIN_K, blackbody_rgb

    temperature, density = volume.temperature.ravel(), volume.density.ravel()
    hot = np.flatnonzero((temperature >= BLACKBODY_MIN_K) & (density > 0))
    if hot.size == 0:
        return None
    glow = blackbody_rgb(temperature[hot]).astype(np.float64)  # (m, 3)
    power = (glow * (volume.emission * volume.cell_size**3 * density[hot])[:, None]).T
    ijk = np.stack(np.unravel_index(hot, volume.density.shape))  # (3, m)
    positions = volume.origin[:, None] + (ijk + 0.5) * volume.cell_size
    return _light(positions, power, gain)


def _light(positions: np.ndarray, power: np.ndarray, gain: float) -> PointLight | None:
    """One light for emitters at ``positions`` (3, n) of intensity ``power`` (3, n)."""
    weight = LUMINANCE @ power
    total = float(weight.sum())
    if not np.isfinite(total) or total <= 0.0:
        return None
    centre = positions @ weight / total
    rgb = gain * power.sum(axis=1)
    peak = float(rgb.max())
    return PointLight(centre, color=rgb / peak, intensity=peak)


def emitted_lights(items, volumes) -> list[PointLight]:
    """The point lights of the frame's glowing systems (``(owner, state, style)``
    items) and volumes."""
    found = [particle_light(state, style) for _, state, style in items]
    found += [volume_light(volume) for volume in volumes]
    return [light for light in found if light is not None]
