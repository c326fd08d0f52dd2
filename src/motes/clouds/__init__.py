"""Clouds as volumes: procedural cumulus, and particle clouds splatted into a grid.

Both give a density grid indexed ``[k, j, i]`` (nz, ny, nx), as a grid fluid keeps its
fields, for :meth:`motes.render.volume.Volume.from_zyx`. See ``docs/clouds.md``.
"""

from .procedural import procedural_cloud
from .splat import splat_particles

__all__ = ["procedural_cloud", "splat_particles"]
