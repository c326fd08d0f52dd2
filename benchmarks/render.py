"""Particle rasteriser benchmarks: 1M additive sprites, 100k depth-sorted alpha sprites.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.render           # full sizes, about a minute
    PYTHONPATH=src python -m benchmarks.render --quick   # shrunk sizes, seconds

It prints a table, then one line of JSON with the figures. Every figure is a ratio
against a baseline measured in the same run:

- **additive**: 1,000,000 smooth sprites of about 3 px across (radius 1.25-1.9 px) in a
  1280 × 720 frame, drawn by :class:`motes.render.sprites.SpriteRasterizer`, against
  :func:`numpy_additive`: projection in NumPy and ``np.add.at`` splatting of the same
  footprint (each sprite's 4 × 4 pixel window, the smooth profile normalised to its
  energy, the depth test), which produces the same image;
- **alpha**: 100,000 sprites of about 6 px across (they overlap about three deep) drawn
  back to front with alpha-over, against :func:`numpy_alpha`, a per-particle NumPy loop
  (sort, then one vectorised composite of each sprite's pixel box) timed on a subset and
  scaled by the particle count;
- **metaballs**: ``benchmarks/metaballs_case.py``'s case when that module is present;
- **bloom**: :class:`motes.render.bloom.Bloom` (the defaults) on a 1280 × 720 HDR frame
  with 2,000 sparks above white, against :func:`scipy_bloom`, the same four Gaussians
  by ``scipy.ndimage.gaussian_filter`` at full size (``bloom_720p_ms``,
  ``bloom_speedup_vs_scipy``);
- **ambient occlusion**: :class:`motes.render.occlusion.AmbientOcclusion` (the
  defaults) on the 1280 × 720 depth of a ground, a sphere and a box
  (``occlusion_720p_ms``; no baseline: a figure to watch, not a ratio);
- **fire with shadows**: the built-in ``fire`` at 1280 × 720 after 2 s (logs on a
  ground under its moonlight), rendered with the flame casting opacity shadows and the
  light casting shadow maps, against the same frame with both off:
  ``fire_shadow_cost_ratio`` (target <= 1.5), ``fire_shadows_ms``,
  ``fire_no_shadows_ms``;
- **water**: the built-in ``dam_break`` at 1280 × 720 after 0.67 s (the surge meeting
  the far wall), its liquid drawn as clear water in screen space
  (:class:`motes.render.water.Water`, with foam and spray), against the same frame with
  the metaball surface it had before: ``water_frame_ms``, ``surface_frame_ms``,
  ``water_over_surface``.

Timings are the best of several calls after warm-up calls (the first call of a kernel
loads or compiles it), with the median beside it. The cores other processes kept busy
are reported too: on a small shared machine they inflate parallel timings.
"""

from __future__ import annotations

import datetime
import inspect
from dataclasses import dataclass

import numba
import numpy as np

from motes.render.bloom import LEVELS, Bloom
from motes.render.camera import Camera
from motes.render.frame import Frame
from motes.render.sprites import SpriteRasterizer, SpriteStyle

from ._common import Timing, benchmark_main, machine, table, time_calls

WIDTH, HEIGHT = 1280, 720
ADDITIVE_KEY = "additive_1m"
ALPHA_KEY = "alpha_100k"


@dataclass(frozen=True)
class Sizes:
    """Problem sizes and repetitions of one run."""

    additive: int
    alpha: int
    alpha_numpy_subset: int  # particles the NumPy alpha loop is timed on
    repeat: int
    numpy_repeat: int
    metaballs: dict  # keyword arguments of metaballs_case.run

    @staticmethod
    def full() -> Sizes:
        return Sizes(1_000_000, 100_000, 2_000, 10, 2, {})

    @staticmethod
    def quick() -> Sizes:
        return Sizes(20_000, 5_000, 500, 3, 1, {"n": 5_000, "grid": 48, "repeats": 1})


# -- scenes -----------------------------------------------------------------------------
def camera() -> Camera:
    """A 1280 × 720 camera 10 m from the origin, 45° vertical field of view."""
    return Camera((0.0, 0.0, 10.0), (0.0, 0.0, 0.0), resolution=(WIDTH, HEIGHT))


def sprite_cloud(n: int, diameter_px: float, *, seed: int = 0):
    """``n`` float32 sprites filling the view, ``diameter_px`` across at 10 m.

    Positions fill a 12 × 7 × 4 m box around the origin (depths 8-12 m, so the sprites
    are 0.83-1.25 × ``diameter_px`` across), stored as ``(3, n)`` rows viewed as
    ``(n, 3)``, as a particle store keeps them. Colours are random linear RGBA.
    """
    rng = np.random.default_rng(seed)
    rows = np.empty((3, n), np.float32)
    rows[0] = rng.uniform(-6.0, 6.0, n)
    rows[1] = rng.uniform(-3.5, 3.5, n)
    rows[2] = rng.uniform(-2.0, 2.0, n)
    colors = rng.uniform(0.05, 1.0, (n, 4)).astype(np.float32)
    radius = 0.5 * diameter_px * 10.0 / camera().scale  # [m]
    return rows.T, colors, np.full(n, radius, np.float32)


# -- NumPy baselines --------------------------------------------------------------------
def numpy_project(cam: Camera, positions: np.ndarray, radii: np.ndarray):
    """Screen x, y [px], depth [m] and pixel radius of particles, in NumPy (float32).

    Projected in float64 and rounded, as motes does: float32 screen coordinates near
    1280 px are only good to 1e-4 px.
    """
    view = cam.to_view(positions)
    depth = view[:, 2]
    factor = cam.scale / depth
    sx = 0.5 * cam.width + factor * view[:, 0]
    sy = 0.5 * cam.height_px - factor * view[:, 1]
    f32 = np.float32
    return sx.astype(f32), sy.astype(f32), depth.astype(f32), (radii * factor).astype(f32)


def numpy_additive(frame: Frame, cam: Camera, positions, colors, radii) -> None:
    """Additive smooth sprites of radius <= 2 px, projected and splatted in NumPy.

    The footprint motes draws for such sprites: the 4 × 4 window of pixels starting at
    the first column and row within reach, weights ``(1 - d²/R_f²)²`` with ``R_f =
    max(R, 1 px)``, normalised so that each sprite deposits ``rgb · a · πR²/3``, and the
    depth test against ``frame.depth``. The 16 fragments of every sprite are added with
    ``np.add.at`` (unbuffered, so overlapping sprites accumulate).
    """
    sx, sy, depth, r = numpy_project(cam, positions, radii)
    keep = (depth >= cam.near) & (depth <= cam.far)
    sx, sy, depth, r, colors = sx[keep], sy[keep], depth[keep], r[keep], colors[keep]
    rf = np.maximum(r, np.float32(1.0))
    if rf.max(initial=0.0) > 2.0:
        raise ValueError("numpy_additive draws sprites of radius <= 2 px only")
    col0 = np.floor(sx - rf - 0.5).astype(np.int64) + 1
    row0 = np.floor(sy - rf - 0.5).astype(np.int64) + 1
    offsets = np.arange(4)
    cols = col0[:, None, None] + offsets[None, None, :]  # (n, 1, 4)
    rows = row0[:, None, None] + offsets[None, :, None]  # (n, 4, 1)
    dx = cols + np.float32(0.5) - sx[:, None, None]
    dy = rows + np.float32(0.5) - sy[:, None, None]
    w = np.maximum(1 - (dx * dx + dy * dy) / (rf * rf)[:, None, None], 0) ** 2
    energy = np.float32(np.pi / 3) * r * r
    w *= (energy / w.sum(axis=(1, 2)))[:, None, None]
    rows, cols = np.broadcast_arrays(rows, cols)
    inside = (rows >= 0) & (rows < frame.height) & (cols >= 0) & (cols < frame.width)
    pixel = np.where(inside, rows * frame.width + cols, 0)
    w = np.where(inside & (depth[:, None, None] < frame.depth.reshape(-1)[pixel]), w, 0)
    target = frame.color.reshape(-1, 3)
    premultiplied = colors[:, :3] * colors[:, 3:]
    for c in range(3):
        np.add.at(target[:, c], pixel.ravel(), (w * premultiplied[:, c, None, None]).ravel())


def numpy_alpha(frame: Frame, cam: Camera, positions, colors, radii) -> None:
    """Alpha-over smooth sprites in NumPy: sort back to front, then one composite each.

    Each sprite's pixel box is composited with array arithmetic (``c = rgb · a + c ·
    (1 - a)``, ``a = alpha · (1 - d²/R²)²``, unit peak, no normalisation): what a NumPy
    user would write; the loop over sprites is in Python because the composite is
    order-dependent.
    """
    sx, sy, depth, r = numpy_project(cam, positions, radii)
    rf = np.maximum(r, np.float32(1.0))
    for i in np.argsort(-depth, kind="stable"):
        if not cam.near <= depth[i] <= cam.far:
            continue
        c0 = max(int(np.floor(sx[i] - rf[i] - 0.5)) + 1, 0)
        c1 = min(int(np.ceil(sx[i] + rf[i] - 0.5)) - 1, frame.width - 1)
        r0 = max(int(np.floor(sy[i] - rf[i] - 0.5)) + 1, 0)
        r1 = min(int(np.ceil(sy[i] + rf[i] - 0.5)) - 1, frame.height - 1)
        if c1 < c0 or r1 < r0:
            continue
        dx = np.arange(c0, c1 + 1) + 0.5 - sx[i]
        dy = np.arange(r0, r1 + 1)[:, None] + 0.5 - sy[i]
        a = colors[i, 3] * np.maximum(1 - (dx * dx + dy * dy) / rf[i] ** 2, 0) ** 2
        a = np.where(depth[i] < frame.depth[r0 : r1 + 1, c0 : c1 + 1], a, 0)[..., None]
        box = frame.color[r0 : r1 + 1, c0 : c1 + 1]
        box[:] = colors[i, :3] * a + box * (1 - a)


# -- cases ------------------------------------------------------------------------------
def bench_additive(sizes: Sizes) -> dict:
    """1M additive 3 px sprites: motes (all threads and one), NumPy."""
    cam = camera()
    positions, colors, radii = sprite_cloud(sizes.additive, 3.0)
    frame = Frame(WIDTH, HEIGHT)
    rasterizer = SpriteRasterizer(SpriteStyle(blend="additive"))
    drawn = rasterizer.draw(frame, cam, positions, colors, radii)
    timing = time_calls(
        lambda: rasterizer.draw(frame, cam, positions, colors, radii), repeat=sizes.repeat
    )
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        one = time_calls(
            lambda: rasterizer.draw(frame, cam, positions, colors, radii),
            repeat=max(2, sizes.repeat // 2),
        )
    finally:
        numba.set_num_threads(threads)
    baseline = Frame(WIDTH, HEIGHT)
    numpy = time_calls(
        lambda: numpy_additive(baseline, cam, positions, colors, radii),
        repeat=sizes.numpy_repeat,
        warmup=0,
    )
    r = numpy_project(cam, positions, radii)[3]
    return {
        "timing": timing,
        "one_thread": one,
        "numpy": numpy,
        "speedup_vs_numpy": numpy.best / timing.best,
        "drawn": drawn,
        "diameter_px": (float(2 * r.min()), float(2 * r.mean()), float(2 * r.max())),
    }


def bench_alpha(sizes: Sizes) -> dict:
    """100k alpha-over 6 px sprites: motes; the NumPy loop on a subset, scaled."""
    cam = camera()
    positions, colors, radii = sprite_cloud(sizes.alpha, 6.0, seed=1)
    frame = Frame(WIDTH, HEIGHT)
    rasterizer = SpriteRasterizer(SpriteStyle(blend="alpha"))
    drawn = rasterizer.draw(frame, cam, positions, colors, radii)
    timing = time_calls(
        lambda: rasterizer.draw(frame, cam, positions, colors, radii), repeat=sizes.repeat
    )
    subset = slice(0, sizes.alpha_numpy_subset)
    baseline = Frame(WIDTH, HEIGHT)
    numpy = time_calls(
        lambda: numpy_alpha(baseline, cam, positions[subset], colors[subset], radii[subset]),
        repeat=sizes.numpy_repeat,
        warmup=0,
    )
    scale = sizes.alpha / sizes.alpha_numpy_subset
    numpy = Timing(numpy.best * scale, numpy.median * scale)
    r = numpy_project(cam, positions, radii)[3]
    coverage = float(np.sum(np.pi * np.maximum(r, 1.0) ** 2) / (WIDTH * HEIGHT))
    return {
        "timing": timing,
        "numpy": numpy,
        "speedup_vs_numpy": numpy.best / timing.best,
        "drawn": drawn,
        "depth_complexity": coverage,
        "diameter_px": float(2 * r.mean()),
    }


def bench_metaballs(sizes: Sizes, quick: bool) -> dict:
    """``benchmarks.metaballs_case.run`` when that module exists; {} otherwise.

    Its keys keep their full-size names in ``--quick`` runs (like the other keys), and
    unprefixed keys get a ``metaballs_`` prefix.
    """
    try:
        from . import metaballs_case
    except ImportError:
        return {}
    parameters = inspect.signature(metaballs_case.run).parameters
    options = {k: v for k, v in sizes.metaballs.items() if k in parameters} if quick else {}
    result = metaballs_case.run(**options)
    measured = options.get("n", parameters["n"].default if "n" in parameters else 50_000)
    token = f"{measured // 1000}k" if measured >= 1000 else str(measured)
    renamed = {}
    for key, value in result.items():
        key = key.replace(f"metaballs_{token}_", "metaballs_50k_")
        renamed[key if key.startswith("metaballs_") else f"metaballs_{key}"] = value
    renamed["metaballs_particles"] = measured
    return renamed


# -- report -----------------------------------------------------------------------------
def scipy_bloom(color: np.ndarray, bloom: Bloom) -> None:
    """:meth:`Bloom.apply` written with SciPy: each Gaussian at full size."""
    from scipy.ndimage import gaussian_filter

    bright = np.maximum(color - bloom.threshold, 0.0)
    sigma = bloom.radius * color.shape[0]
    glow = sum(gaussian_filter(bright, (sigma / 2**k, sigma / 2**k, 0)) for k in range(LEVELS))
    color += bloom.strength * (glow / LEVELS - bright)


def bench_bloom(sizes: Sizes) -> dict:
    """Bloom on a 1280 x 720 frame: motes, SciPy (the frame copied afresh each call,
    the copy's time taken off)."""
    rng = np.random.default_rng(3)
    base = rng.uniform(0.0, 0.5, (HEIGHT, WIDTH, 3)).astype(np.float32)
    base[rng.integers(0, HEIGHT, 2000), rng.integers(0, WIDTH, 2000)] = 20.0
    work = np.empty_like(base)
    bloom = Bloom()
    copy = time_calls(lambda: np.copyto(work, base), repeat=sizes.repeat)

    def timed(apply) -> Timing:
        def call():
            np.copyto(work, base)
            apply(work)

        t = time_calls(call, repeat=sizes.repeat)
        return Timing(max(t.best - copy.best, 0.0), max(t.median - copy.median, 0.0))

    motes = timed(bloom.apply)
    scipy = timed(lambda frame: scipy_bloom(frame, bloom))
    return {"timing": motes, "scipy": scipy, "speedup": scipy.best / motes.best}


def bench_occlusion(sizes: Sizes) -> Timing:
    """Ambient occlusion of a 1280 x 720 depth buffer: a ground, a sphere, a box."""
    from motes.render import geometry
    from motes.render.occlusion import AmbientOcclusion
    from motes.render.renderer import Renderer

    cam = Camera((0.0, 1.2, 3.5), (0.0, 0.3, 0.0), resolution=(WIDTH, HEIGHT))
    objects = [geometry.Ground(0.0), geometry.Sphere((0.0, 0.4, 0.0), 0.4),
               geometry.Box((1.0, 0.25, -0.3), (0.5, 0.5, 0.5))]  # fmt: skip
    depth = Renderer(cam, supersample=1).render_hdr([], objects).depth
    occlusion = AmbientOcclusion()
    return time_calls(lambda: occlusion.occlusion(depth, cam), repeat=sizes.repeat)


#: What the fire gains for the shadow benchmark: a ground and a light (shadows per key).
def scene_frames(sizes: Sizes, quick: bool, scenes: dict, frames: int) -> dict:
    """Draw time of each scene in ``scenes`` (name -> ``(text, overrides)``) after
    ``frames`` frames (a sixth of them with ``quick``), at 1280 x 720 (320 x 180)."""
    from motes.scene import load_scene

    frames = max(1, frames // 6) if quick else frames
    size = (320, 180) if quick else (WIDTH, HEIGHT)
    repeat = max(3, sizes.repeat // 2)
    timings = {}
    for name, (text, overrides) in scenes.items():
        scene = load_scene(text, overrides=overrides)
        for _ in range(frames):
            scene.advance()
        timings[name] = time_calls(lambda s=scene: s.render(size), repeat=repeat)
    return timings


def bench_fire_shadows(sizes: Sizes, quick: bool) -> dict:
    """The built-in fire (logs on a ground under a moonlight that casts shadows), its
    frame drawn with the light's shadow map and the flame's opacity map, and without."""
    from motes.scene.scene import builtin_text

    scenes = {
        shadows: (
            builtin_text("fire"),
            {"render.light.0.shadows": shadows, "system.flame.render.shadows": shadows},
        )
        for shadows in (True, False)
    }
    timings = scene_frames(sizes, quick, scenes, frames=60)
    return {
        "with": timings[True],
        "without": timings[False],
        "ratio": timings[True].best / timings[False].best,
    }


def bench_water(sizes: Sizes, quick: bool) -> dict:
    """The dam break's frame drawn with the water look and with the metaball surface."""
    from motes.scene.scene import builtin_text

    text = builtin_text("dam_break")
    scenes = {
        mode: (text.replace('mode = "water"', f'mode = "{mode}"'), None)
        for mode in ("water", "surface")
    }
    timings = scene_frames(sizes, quick, scenes, frames=20)
    return {
        "water": timings["water"],
        "surface": timings["surface"],
        "ratio": timings["water"].best / timings["surface"].best,
    }


def _ms(timing: Timing) -> str:
    return f"{1e3 * timing.best:9.2f} ms (median {1e3 * timing.median:.2f})"


def run(sizes: Sizes, *, quick: bool, out=print) -> dict:
    """Run the cases, print their tables and return the figures."""
    info = machine()
    threads = info["numba_threads"]
    busy = info["background_busy_cores"]
    figures: dict = {
        "date": datetime.date.today().isoformat(),
        "quick": quick,
        "sizes": {"additive": sizes.additive, "alpha": sizes.alpha},
        "frame": [WIDTH, HEIGHT],
        "cpu_count": info["cpu_count"],
        "numba_threads": threads,
        "background_busy_cores": busy,
    }
    rows = [
        (
            "machine",
            f"{info['usable_cores']} usable cores, {threads} Numba threads "
            f"({info['numba_threading_layer']}), {info['processor']}",
        ),
        (
            "other load",
            f"{busy:.2f} cores busy with other processes at the start"
            + (" - parallel timings will be inflated" if busy > 0.25 else ""),
        ),
        ("versions", f"Python {info['python']}, NumPy {info['numpy']}, Numba {info['numba']}"),
        ("timings", "best of N draws after warm-up draws (median in brackets)"),
    ]
    out(table(rows, title="motes render benchmark" + (" (--quick sizes)" if quick else "")))

    a = bench_additive(sizes)
    figures |= {
        f"{ADDITIVE_KEY}_ms": 1e3 * a["timing"].best,
        f"{ADDITIVE_KEY}_median_ms": 1e3 * a["timing"].median,
        f"{ADDITIVE_KEY}_1thread_ms": 1e3 * a["one_thread"].best,
        f"{ADDITIVE_KEY}_numpy_ms": 1e3 * a["numpy"].best,
        f"{ADDITIVE_KEY}_speedup_vs_numpy": a["speedup_vs_numpy"],
        f"{ADDITIVE_KEY}_drawn": a["drawn"],
    }
    lo, mean, hi = a["diameter_px"]
    rows = [
        (
            "sprites",
            f"{sizes.additive:,} smooth sprites, {lo:.1f}-{hi:.1f} px across "
            f"(mean {mean:.2f}), {a['drawn']:,} drawn, {WIDTH} x {HEIGHT}",
        ),
        ("motes", _ms(a["timing"]) + " (target <= 30 ms)"),
        ("motes, 1 thread", _ms(a["one_thread"])),
        ("NumPy baseline", _ms(a["numpy"])),
        ("", "(NumPy projection, the same 4 x 4 normalised footprint, np.add.at splat)"),
        ("speed-up", f"{a['speedup_vs_numpy']:9.1f}x"),
    ]
    out()
    out(table(rows, title="1. Additive sprites"))

    b = bench_alpha(sizes)
    figures |= {
        f"{ALPHA_KEY}_ms": 1e3 * b["timing"].best,
        f"{ALPHA_KEY}_median_ms": 1e3 * b["timing"].median,
        f"{ALPHA_KEY}_numpy_ms": 1e3 * b["numpy"].best,
        f"{ALPHA_KEY}_speedup_vs_numpy": b["speedup_vs_numpy"],
        f"{ALPHA_KEY}_depth_complexity": b["depth_complexity"],
    }
    rows = [
        (
            "sprites",
            f"{sizes.alpha:,} smooth sprites, {b['diameter_px']:.1f} px across on average, "
            f"covering the frame {b['depth_complexity']:.1f} times, {b['drawn']:,} drawn",
        ),
        ("motes", _ms(b["timing"]) + " (sort, bin, composite back to front)"),
        ("NumPy baseline", _ms(b["numpy"])),
        (
            "",
            f"(per-sprite NumPy composite loop, timed on {sizes.alpha_numpy_subset:,} "
            "sprites and scaled by the count)",
        ),
        ("speed-up", f"{b['speedup_vs_numpy']:9.1f}x"),
    ]
    out()
    out(table(rows, title="2. Alpha-over sprites, depth-sorted"))

    m = bench_metaballs(sizes, quick)
    if m:
        figures |= m
        rows = [
            (key, f"{value:.4g}" if isinstance(value, float) else str(value))
            for key, value in m.items()
        ]
        out()
        out(table(rows, title="3. Metaballs (benchmarks/metaballs_case.py)"))

    g = bench_bloom(sizes)
    figures |= {
        "bloom_720p_ms": 1e3 * g["timing"].best,
        "bloom_720p_scipy_ms": 1e3 * g["scipy"].best,
        "bloom_speedup_vs_scipy": g["speedup"],
    }
    rows = [
        ("frame", f"{WIDTH} x {HEIGHT}, 2,000 sparks above white; Bloom() (radius 0.03)"),
        ("motes", _ms(g["timing"]) + " (pyramid, compiled)"),
        ("SciPy baseline", _ms(g["scipy"]) + " (four gaussian_filter at full size)"),
        ("speed-up", f"{g['speedup']:9.1f}x"),
    ]
    out()
    out(table(rows, title="4. Bloom"))

    o = bench_occlusion(sizes)
    figures |= {"occlusion_720p_ms": 1e3 * o.best, "occlusion_720p_median_ms": 1e3 * o.median}
    out()
    out(table([("frame", f"{WIDTH} x {HEIGHT}: a ground, a sphere, a box; defaults"),
               ("motes", _ms(o) + " (half size, 16 samples, blur, upsample)")],
              title="5. Ambient occlusion"))  # fmt: skip

    s = bench_fire_shadows(sizes, quick)
    figures |= {
        "fire_shadows_ms": 1e3 * s["with"].best,
        "fire_no_shadows_ms": 1e3 * s["without"].best,
        "fire_shadow_cost_ratio": s["ratio"],
    }
    rows = [
        ("frame", f"built-in fire on its logs, {WIDTH} x {HEIGHT}, after 2 s"),
        ("with shadows", _ms(s["with"]) + " (particles' opacity maps, the light's shadow map)"),
        ("without", _ms(s["without"])),
        ("ratio", f"{s['ratio']:9.2f}x (target <= 1.5)"),
    ]
    out()
    out(table(rows, title="6. Fire with and without shadows"))

    w = bench_water(sizes, quick)
    figures |= {
        "water_frame_ms": 1e3 * w["water"].best,
        "surface_frame_ms": 1e3 * w["surface"].best,
        "water_over_surface": w["ratio"],
    }
    rows = [
        ("frame", f"built-in dam_break, {WIDTH} x {HEIGHT}, after 0.67 s (4,608 particles)"),
        ("water", _ms(w["water"]) + " (screen space: splat, smooth, shade; foam, spray)"),
        ("metaball surface", _ms(w["surface"]) + " (marching cubes, mesh drawn)"),
        ("ratio", f"{w['ratio']:9.2f}x"),
    ]
    out()
    out(table(rows, title="7. Water against the metaball surface"))
    return figures


def main(argv: list[str] | None = None) -> dict:
    return benchmark_main(
        argv,
        prog="python -m benchmarks.render",
        doc=__doc__,
        quick_help="20k additive, 5k alpha sprites",
        run=lambda quick: run(Sizes.quick() if quick else Sizes.full(), quick=quick),
    )


if __name__ == "__main__":
    main()
