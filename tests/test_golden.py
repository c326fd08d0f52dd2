"""Golden images: small renders compared with stored PNGs, within a tolerance.

Regenerate them (after an intended change to how things look; inspect the new files
before committing) with::

    MOTES_REGENERATE_GOLDEN=1 python -m pytest tests/test_golden.py

The tolerance allows for floating-point differences between machines (fused multiply-add,
vector widths, ``fastmath``) and nothing more: a mean difference of 1.5 levels of 255,
and 99.5 % of the pixels within 24 levels.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import motes as mo
from motes.io.frames import read_image, save_image
from motes.render import geometry
from motes.scene import load_scene

GOLDEN = Path(__file__).with_name("golden")
REGENERATE = os.environ.get("MOTES_REGENERATE_GOLDEN") == "1"


def composite() -> np.ndarray:
    """Every layer at once: gradient, ground with checker, a sphere, a box, lines, and
    additive, alpha, soft, streaked and point particles."""
    rng = np.random.default_rng(7)
    camera = mo.Camera((0, 1.5, 4), (0, 0.5, 0), fov=50, resolution=(128, 72))
    renderer = mo.Renderer(camera, background=mo.Background("#203050", "#000000"))

    def particles(n, center, spread, colors, sizes, velocity=(0, 0, 0)):
        system = mo.ParticleSystem(n, attributes=("color", "size"))
        system.store.spawn(n)
        system["position"] = rng.normal(center, spread, (n, 3))
        system["velocity"] = velocity
        system["color"] = colors
        system["size"] = sizes
        system["lifetime"] = np.inf
        return system

    glow = particles(400, (-0.8, 0.8, 0), 0.25, (1.0, 0.5, 0.1, 0.5), 0.04)
    smoke = particles(60, (0.6, 0.4, 0.3), 0.2, (0.5, 0.5, 0.55, 0.4), 0.2)
    streaks = particles(50, (0, 1.4, 0), 0.3, (0.4, 0.8, 1.0, 1.0), 0.01, velocity=(3, 0, 0))
    points = particles(200, (0, 0.2, 1.0), 0.4, (1.0, 1.0, 1.0, 1.0), 0.0)
    objects = [
        geometry.Ground(0.0, color=(0.3, 0.3, 0.3), checker=((0.15, 0.15, 0.15), 0.5)),
        geometry.Sphere((0.6, 0.35, 0.0), 0.35, color=(0.7, 0.2, 0.1)),
        geometry.Box((-0.2, 0.2, -0.6), (0.4, 0.4, 0.4), color=(0.3, 0.5, 0.3)),
        geometry.Lines(
            np.array([[-1.5, 0, 0.5], [-1.2, 1.0, 0.5], [-0.9, 0.0, 0.5]]),
            color=(1.0, 1.0, 0.2),
            width=1.5,
        ),
    ]
    systems = [
        (glow, mo.SpriteStyle(blend="additive")),
        (smoke, mo.SpriteStyle(blend="alpha", softness=0.3)),
        (streaks, mo.SpriteStyle(blend="additive", shutter=0.1)),
        (points, mo.SpriteStyle(kind="point", intensity=2.0)),
    ]
    return renderer.render(systems, objects)


def scene_still(name: str, frames: int, size=(128, 72)):
    """A built-in scene's frame after ``frames`` frames, drawn small."""

    def make() -> np.ndarray:
        scene = load_scene(name)
        for _ in range(frames):
            scene.advance()
        return scene.render(size)

    return make


# What each built-in still guards beyond the composite: `fire` sprites streaked by
# motion, bloom, emitted light on the ground, a shadow map of capsules; `dam_break`
# water in screen space with foam and spray, glass walls; `hair` Kajiya-Kay curves with
# self-shadowing; `smoke` lit particles through their opacity shadow map, the shadow on
# the ground; `campfire` a ray-marched volume glowing by temperature, lighting the logs.
STILLS = {
    "fire": scene_still("fire", 15),
    "dam_break": scene_still("dam_break", 10, (160, 90)),
    "hair": scene_still("hair", 20),
    "smoke": scene_still("smoke", 60),
    "campfire": scene_still("campfire", 20),
}


@pytest.mark.parametrize("name", ["composite", *STILLS])
def test_render_matches_its_golden_image(name):
    image = STILLS[name]() if name in STILLS else composite()
    path = GOLDEN / f"{name}.png"
    if REGENERATE or not path.exists():
        if not REGENERATE:
            pytest.fail(f"{path} is missing; see this module's docstring to create it")
        save_image(path, image)
    expected = read_image(path)
    assert image.shape == expected.shape
    diff = np.abs(image.astype(np.int16) - expected.astype(np.int16))
    assert diff.mean() <= 1.5, f"mean difference {diff.mean():.2f} levels"
    assert np.quantile(diff, 0.995) <= 24, "more than 0.5 % of pixels differ by > 24 levels"
