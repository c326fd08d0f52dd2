"""``[[body]] type = "clouds"``: a sky of procedural cumulus drifting with the wind
(keys in ``docs/scene-format.md``, section "Cloud bodies").

The density is made once (:func:`motes.clouds.procedural_cloud`) and drawn as a
ray-marched volume (:class:`motes.render.volume.Volume`) carried by the wind: over the
seconds of a shot clouds keep their shapes and drift.
"""

from __future__ import annotations

import numpy as np

from ..clouds import procedural_cloud
from ..render.volume import Volume
from .bodies import Body, BuildContext, register
from .schema import Table, array_of, build, integer, number, positive, vector


class CloudBody(Body):
    """Procedural clouds in a scene, drawn as a volume moving with the wind."""

    not_replayable = "clouds are not particles: a particle cache does not hold them"
    replayable = False

    def __init__(self, density: np.ndarray, *, cell_size: float, origin, wind, look: dict):
        self.density = density
        self.cell_size = cell_size
        self.origin = np.asarray(origin, np.float64)
        self.wind = np.asarray(wind, np.float64)
        self.look = look
        self.time = 0.0
        #: Distance [m] the wind has carried the clouds, (3,): summed per step, so a wind
        #: changed while the scene runs carries them on from where they are.
        self.drift = np.zeros(3)

    def step(self, dt: float) -> None:
        self.time += dt
        self.drift += self.wind * dt

    def take_values(self, fresh: CloudBody) -> None:
        """The wind of ``fresh`` (see ``LIVE_KEYS``), over these clouds' drift; their
        shape (the density's keys) waits for the restart, which makes it again."""
        self.wind = fresh.wind

    def drawables(self) -> list:
        origin = self.origin + self.drift
        return [Volume.from_zyx(self.density, cell_size=self.cell_size, origin=origin, **self.look)]

    def count(self) -> int:
        return int(self.density.size)


@register("clouds")
def build_clouds(table: Table, context: BuildContext) -> CloudBody:
    """Read a ``[[body]] type = "clouds"`` table."""
    resolution = table.get("resolution", array_of(integer(1, 4096), length=3))
    cell_size = table.get("cell_size", positive())
    origin = table.get("origin", vector(), (0.0, 0.0, 0.0))
    options = {
        "base_height": table.get("base_height", number()),
        "top_height": table.get("top_height", number()),
        "scale": table.get("scale", positive()),
        "coverage": table.get("coverage", number(0.0, 1.0), 0.5),
        "octaves": table.get("octaves", integer(1, 16), 5),
        "detail_octaves": table.get("detail_octaves", integer(1, 6), 4),
        "erosion": table.get("erosion", number(0.0, 1.0), 0.2),
        "density": table.get("density", positive(), 1.0),
        "seed": table.get("seed", integer(0), context.seed % 1_000_000),
    }
    wind = table.get("wind", vector(), (0.0, 0.0, 0.0))
    render = table.table("render", optional=True) or Table({}, table.key_path("render"))
    look = {
        "extinction": render.get("extinction", number(0.0), 0.05),
        "albedo": tuple(render.get("albedo", array_of(number(0.0, 1.0), length=3), [0.95] * 3)),
        "anisotropy": render.get("anisotropy", number(-0.99, 0.99), 0.3),
        "step": render.get("step", number(0.05, 8.0), 1.0),
        "shadows": True,
    }
    render.finish()
    density = build(table.path, procedural_cloud, resolution, cell_size, origin=origin, **options)
    return CloudBody(density, cell_size=cell_size, origin=origin, wind=wind, look=look)
