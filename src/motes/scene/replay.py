"""Drawing a scene again from a particle cache, without simulating it (``motes render``).

A cache written by ``motes run --export CACHE.h5`` records, with the particles of every
frame, the scene it came from, the seed and the values set over the scene file. The scene
is built again from them (its camera, lights, looks, objects and colliders), and each
cached frame is drawn by the scene's own renderer: systems from the cached states, bodies
after :meth:`~motes.scene.bodies.Body.show` has put the cached particles where they draw
from. A frame is therefore the frame ``motes run`` drew, pixel for pixel.

Rigid worlds and ragdolls draw from their cached particles (their bodies' transforms
follow from them), boxes floating in a liquid from the transforms cached with it. Trails
(a rigid world's or a flock's path over its last steps, which a cache does not hold)
cannot be drawn from a cache: a scene with one is refused before any frame is drawn
(:class:`ReplayError`).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from ..io.cache import Cache


class ReplayError(ValueError):
    """A cache that cannot be drawn with its scene (the message says why)."""


class Replay:
    """A scene and a cache of it: :meth:`frames` draws the cached frames.

    Parameters
    ----------
    scene : Scene
        The scene the cache was made from, freshly loaded (with the cache's seed and
        overrides: :func:`load_for`).
    cache : Cache
        Its cache; every system the scene draws and every body must be in it.
    """

    def __init__(self, scene, cache: Cache):
        self.scene = scene
        self.cache = cache
        names = set(cache.systems)
        drawn = [name for name, look in scene.looks.items() if look.visible]
        wanted = {f"system {name!r}": name for name in drawn}
        wanted |= {f"body {name!r}": name for name in scene.bodies}
        missing = [label for label, name in wanted.items() if name not in names]
        if missing:
            raise ReplayError(
                f"the cache holds {sorted(names)}; scene {scene.name!r} draws "
                f"{', '.join(missing)}, which it does not (was it exported from this scene?)"
            )
        unsupported = [
            f"{name!r} ({type(body).__name__}: {body.not_replayable})"
            for name, body in scene.bodies.items()
            if not body.replayable
        ]
        if unsupported:
            raise ReplayError(
                f"scene {scene.name!r} has bodies that cannot be drawn from a cache yet: "
                f"{', '.join(unsupported)}; run the scene again instead"
            )
        self._drawn = drawn

    def frame_of(self, index: int) -> int:
        """The scene frame number of cached frame ``index`` (by its time)."""
        return round(float(self.cache.times[index]) * self.scene.fps)

    def render(self, index: int, resolution=None) -> np.ndarray:
        """Cached frame ``index`` as a (height, width, 3) uint8 sRGB image."""
        self.place(index)
        renderer = self.scene.renderer(resolution)
        return renderer.render_scene(self.scene, self.states(index))

    def states(self, index: int) -> dict:
        """The drawn systems' particles of cached frame ``index``, by name."""
        return {name: self.cache.state(index, name) for name in self._drawn}

    def place(self, index: int) -> None:
        """Put the scene at cached frame ``index``: its frame number, and every body
        showing the cached particles (:meth:`~motes.scene.bodies.Body.show`)."""
        scene, cache = self.scene, self.cache
        scene.frame = self.frame_of(index)
        time = float(cache.times[index]) + scene.preroll  # the bodies' own clocks
        for name, body in scene.bodies.items():
            try:
                body.show(cache.entry(index, name), time)
            except ValueError as error:  # a cache of another scene under the same names
                raise ReplayError(
                    f"frame {index} of the cache cannot be drawn as body {name!r}: {error}"
                ) from None

    def frames(self, indices=None, resolution=None) -> Iterator[np.ndarray]:
        """Draw cached frames ``indices`` (default: all) in order."""
        for index in range(self.cache.frame_count) if indices is None else indices:
            yield self.render(index, resolution)


#: The top-level tables whose keys change how a cache is drawn, not what it holds.
LOOK_TABLES = ("camera", "render", "light")


def look_overrides(overrides: dict) -> dict:
    """``overrides`` (key path -> value), checked to change only how frames are drawn:
    keys under ``camera``, ``render`` or ``light``. Raises :class:`ReplayError` naming a
    key that would change the simulation, which a cache cannot."""
    from .overrides import split_key

    for key in overrides:
        if split_key(key)[0] not in LOOK_TABLES:
            raise ReplayError(
                f"--set {key}: a cache is drawn as it was simulated; only camera.*, "
                "render.* and light.* keys change how it is drawn (simulate again with "
                "motes run --set to change the rest)"
            )
    return dict(overrides)


def load_for(cache: Cache, scene=None, overrides=None):
    """The scene ``cache`` was made from, loaded with its seed and overrides.

    ``scene`` (a built-in name or a scene file) replaces the name the cache records:
    needed for a scene file, whose path the cache does not hold. ``overrides`` (key path
    -> value, :func:`look_overrides`: camera, render and light keys) are set over the
    cache's own: another camera, exposure or light for the same particles.
    """
    from .scene import load_scene

    source = scene if scene is not None else cache.scene
    if not source:
        raise ReplayError(
            "the cache records no scene (it was not written by motes run): give the scene"
        )
    seed = cache.seed
    values = {**cache.overrides, **look_overrides(overrides or {})}
    return load_scene(source, seed=seed, overrides=values)
