"""Geometry below the physics, io and render layers: triangle meshes, the one collider
row layout and the one signed distance.

Nothing here imports a motes module above ``_jit`` and ``_validate``: colliders, cloth,
fluids, rigid worlds, the mesh readers and the renderer all import from here.
"""

from .mesh import TriangleMesh

__all__ = ["TriangleMesh"]
