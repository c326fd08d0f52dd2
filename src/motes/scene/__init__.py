"""Scene files (TOML): systems, colliders, objects, camera and render settings.

The format is documented key by key in ``docs/scene-format.md``.
"""

from .looks import ParticleLook, RenderSettings, SceneObject
from .scene import Scene, builtin_scenes, load_scene
from .schema import SceneError

__all__ = [
    "ParticleLook",
    "RenderSettings",
    "Scene",
    "SceneError",
    "SceneObject",
    "builtin_scenes",
    "load_scene",
]
