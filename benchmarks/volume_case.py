"""Ray-marched volume benchmark case: a 128³ smoke plume drawn at 1280 × 720.

:func:`volume_render_figures` builds a noisy plume (:func:`plume`) lit by a directional
light with self-shadowing and an ambient sky, warms the kernels (the first call compiles
or loads them), then times the best of ``repeats`` frames of
:meth:`motes.render.renderer.Renderer.render_hdr` and, apart, of the light-transmittance
part (:func:`motes.render.volume.light_volume`).
"""

from __future__ import annotations

import time

import numpy as np

from motes.render.camera import Camera
from motes.render.renderer import Renderer
from motes.render.shading import AmbientLight, DirectionalLight
from motes.render.shadow_pass import prepare
from motes.render.volume import Volume, light_volume

WIDTH, HEIGHT = 1280, 720


def smooth_noise(n: int, *, scale: float, seed: int) -> np.ndarray:
    """A (n, n, n) Gaussian random field with unit standard deviation, smooth over about
    ``scale`` voxels (white noise filtered by a Gaussian in Fourier space)."""
    rng = np.random.default_rng(seed)
    white = rng.standard_normal((n, n, n))
    k = np.fft.fftfreq(n)
    k2 = k[:, None, None] ** 2 + k[None, :, None] ** 2 + k[None, None, :] ** 2
    field = np.fft.ifftn(np.fft.fftn(white) * np.exp(-2 * (np.pi * scale) ** 2 * k2)).real
    return field / field.std()


def plume(n: int = 128, *, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Density and temperature [K] (n, n, n) float32 of a rising smoke plume in the unit
    box: a column widening with height, its edge broken by two octaves of noise, denser
    low down, a hot core near the base; exactly 0 outside the smoke."""
    u = (np.arange(n) + 0.5) / n
    x, y, z = np.meshgrid(u - 0.5, u, u - 0.5, indexing="ij")
    noise = 0.7 * smooth_noise(n, scale=n / 14, seed=seed) + 0.3 * smooth_noise(
        n, scale=n / 40, seed=seed + 1
    )
    sway = 0.06 * np.sin(5.0 * y)
    radius = 0.1 + 0.22 * y
    r = np.sqrt((x - sway) ** 2 + z**2)
    edge = (radius - r) / radius + 0.35 * noise
    density = np.clip(edge * 2.5, 0.0, 1.0) * np.clip((0.95 - y) / 0.25, 0.0, 1.0)
    density *= np.clip(y / 0.05, 0.0, 1.0) * (1.2 - 0.7 * y)
    density = np.where(density > 0.02, density, 0.0)
    heat = np.clip(1.0 - r / 0.12 + 0.3 * noise, 0.0, 1.0) * np.clip(1.0 - y / 0.45, 0.0, 1.0)
    temperature = 300.0 + 1600.0 * heat
    return density.astype(np.float32), temperature.astype(np.float32)


def plume_volume(n: int = 128, **options) -> Volume:
    """The plume as a :class:`Volume` filling the box [-1, 1] × [0, 2] × [-1, 1] m."""
    density, _ = plume(n)
    settings = {"extinction": 8.0, "albedo": 0.85, "anisotropy": 0.2} | options
    return Volume(density, cell_size=2.0 / n, origin=(-1.0, 0.0, -1.0), **settings)


def scene_camera(width: int = WIDTH, height: int = HEIGHT) -> Camera:
    return Camera((0.0, 1.1, 4.2), (0.0, 0.95, 0.0), fov=40, resolution=(width, height))


def scene_lights() -> list:
    return [
        DirectionalLight((-1.0, -0.35, -0.25), color=(1.0, 0.95, 0.85), intensity=1.0),
        AmbientLight((0.25, 0.3, 0.38), ground=(0.12, 0.1, 0.08)),
    ]


def _best(call, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        best = min(best, time.perf_counter() - start)
    return best


def volume_render_figures(repeats: int = 3) -> dict:
    """Best-of-``repeats`` milliseconds per 1280 × 720 frame of the 128³ plume (after a
    warm-up frame): the whole frame and its light-transmittance part."""
    volume = plume_volume(128)
    camera = scene_camera()
    lights = scene_lights()
    renderer = Renderer(camera, background=(0.02, 0.02, 0.03), lights=lights)
    renderer.render_hdr([], [volume])  # compile or load the kernels
    shadowing = prepare(lights, [], camera)
    light = _best(lambda: light_volume(volume, shadowing), repeats)
    frame = _best(lambda: renderer.render_hdr([], [volume]), repeats)
    return {"volume_128_render_ms": 1e3 * frame, "volume_128_light_ms": 1e3 * light}


if __name__ == "__main__":
    print(volume_render_figures())
