"""Participating media on a voxel grid (smoke, fire, clouds), ray-marched into a frame.

A :class:`Volume` holds a density grid (and optionally a temperature grid) with the
medium's optical parameters. The renderer draws volumes after opaque geometry and before
particles (:meth:`motes.render.renderer.Renderer.render_hdr`):

1. :func:`light_volume` packs the grid with the light reaching every voxel: one
   transmittance volume per light (:mod:`.volume_light`) and the ambient light's;
2. :func:`march_volume` marches every pixel's ray through the box, stopping at opaque
   geometry, and composites ``color T + L`` (:mod:`.volume_kernels`);
3. :func:`froxel_grid` records the radiance ``S(z)`` gathered and transmittance ``T(z)``
   at depth slices on a coarse screen grid, through which :class:`VolumeLayer` changes the
   particles' colours so they sit behind, inside or in front of the volume.

Particles through a volume
--------------------------
The frame over a pixel holds ``F = S(z) + T(z) X`` once the volume is drawn, ``X`` what
lies behind depth ``z`` seen from ``z``. A particle at depth ``z`` blended *over* with
opacity ``a`` and colour ``c'`` gives ``a c' + (1 - a) F``; what it should give is the
volume in front of it over the particle over ``X``: ``S + T (a c + (1 - a) X)``. The
two agree for ``c' = S(z) + T(z) c``, for any ``a`` and any ``X``, so also for any number
of particles drawn back to front. An additive particle adds ``T(z) c``. The sprite
rasteriser multiplies colours by the style's intensity ``k``, so ``c' = S / k + T c``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _memory
from .. import _validate as check
from .camera import Camera, Projection
from .frame import Frame
from .opacity import GRID, opacity_map
from .shading import (
    LIGHT_DIRECTION,
    LIGHT_OPACITY,
    LIGHT_POINT,
    LIGHT_POSITION,
    LIGHT_SHADOW,
    AmbientLight,
    DirectionalLight,
    PointLight,
    default_lights,
)
from .shadows import Shadowing, casters_sphere, light_camera
from .sprites import Blend, SpriteStyle
from .tiles import interleaved
from .volume_blackbody import (
    BLACKBODY_MIN_K,
    BLACKBODY_REFERENCE_K,
    TABLE_STEP_K,
    blackbody_rgb,
    blackbody_table,
    blackbody_xyz,
)
from .volume_kernels import (
    ALBEDO,
    AMBIENT_CH,
    ANISOTROPY,
    CELL,
    EMISSION,
    EXTINCTION,
    JITTER,
    LIGHTS_CH,
    MEDIUM_SIZE,
    ORIGIN,
    STEP,
    TABLE_STEP,
    TEMPERATURE_CH,
    froxel_lookup,
    march,
)
from .volume_light import (
    BRICK,
    POINT_GRID,
    blur_xz,
    brick_distances,
    brick_maxima,
    columns,
    march_point,
    shadow_voxels,
    sweep,
    upsample,
)

__all__ = [
    "BLACKBODY_MIN_K",
    "BLACKBODY_REFERENCE_K",
    "Volume",
    "VolumeLayer",
    "blackbody_rgb",
    "blackbody_xyz",
    "draw_volumes",
    "volume_shadowing",
]

#: Half-width [voxels] of the box filter (run twice) over the ambient light's column
#: transmittances: the sky is seen through a cone about 9 voxels across.
AMBIENT_BLUR = 4

#: Largest leap [bricks] over empty space recorded in the brick distances.
LEAP_CAP = 64

#: Screen pixels per froxel side (at least), and depth slices of the froxel grid.
FROXEL_PIXELS = 4
FROXEL_SLICES = 48
#: Largest froxel grid side [cells]: larger frames get larger froxels.
FROXEL_MAX_SIDE = 320


def _grid(name: str, value, shape=None) -> np.ndarray:
    """A finite, non-negative (nx, ny, nz) float32 copy of ``value``, read-only."""
    try:
        array = np.array(value, dtype=np.float32)
    except (TypeError, ValueError):
        kind = type(value).__name__
        raise TypeError(f"{name} must be a 3-D array of numbers, got {kind}") from None
    if array.ndim != 3 or 0 in array.shape:
        raise ValueError(f"{name} must have shape (nx, ny, nz), each >= 1, got {array.shape}")
    if shape is not None and array.shape != shape:
        raise ValueError(f"{name} must have the density's shape {shape}, got {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    if (array < 0).any():
        raise ValueError(f"{name} must be >= 0 everywhere, got a minimum of {array.min()}")
    array.flags.writeable = False
    return array


class Volume:
    """A participating medium on a voxel grid, drawn by the renderer among ``objects``.

    Parameters
    ----------
    density : (nx, ny, nz) array_like
        Density (>= 0, unitless) at the voxel centres ``origin + (i + 0.5) * cell_size``;
        x, y, z world axes (y up). The grid fills the box ``[origin, origin + shape *
        cell_size]``; between centres it is interpolated trilinearly (clamped to the
        edge voxels up to the box's faces). Copied.
    origin : (3,) array_like
        The box's lowest corner [m].
    cell_size : float
        Voxel side [m], > 0.
    extinction : float
        σ_t [1/m per unit density], >= 0: light crossing a length ``d`` of density ``ρ``
        keeps ``exp(-σ_t ρ d)``.
    albedo : float or (3,) array_like
        Scattering colour in [0, 1]: σ_s = albedo σ_t (linear RGB; 0 absorbs only).
    anisotropy : float
        Henyey–Greenstein ``g`` in (-1, 1): > 0 scatters forward (a silver lining when
        looking toward the light), 0 evenly.
    temperature : (nx, ny, nz) array_like, optional
        Temperature [K] (>= 0) at the voxel centres, for emission.
    emission : float
        Emission scale ``e`` [1/m per unit density], >= 0: a voxel emits ``e ρ B(T)``
        radiance per metre, ``B`` = :func:`blackbody_rgb` (luminance 1 at 1500 K, 0 below
        798 K). An optically thick region at ``T`` glows ``(e / σ_t) B(T)``. Kirchhoff's
        law is ``e = σ_t (1 - albedo)`` (emission equals absorption): a thick, purely
        absorbing region (albedo 0, ``e = σ_t``) then glows ``B(T)``, a blackbody's
        radiance in units where one at 1500 K has luminance 1. Needs ``temperature``.
    step : float
        Camera rays' step [voxels], in [0.05, 8].
    shadows : bool
        Self-shadowing: the medium attenuates the light reaching itself and, from
        directional lights that cast shadows, casts shadows on geometry and lit particles
        (False: every voxel sees the lights, still shadowed by opaque geometry, and the
        medium casts no shadow).
    shadow_step : float
        Step [voxels] of point lights' shadow rays, in [0.05, 8] (directional lights
        sweep one slice per voxel).
    jitter : bool
        Shift each pixel's samples by a fixed hash of the pixel (deterministic), trading
        the banding of a regular lattice for fine noise.
    light : float
        The glow lights the scene, >= 0: one point light at the centre of the glow,
        ``light`` times what it gives off (:mod:`motes.render.emitted_light`); 0: none.
    """

    def __init__(
        self,
        density,
        *,
        cell_size: float,
        origin=(0.0, 0.0, 0.0),
        extinction: float = 10.0,
        albedo=0.8,
        anisotropy: float = 0.0,
        temperature=None,
        emission: float = 0.0,
        step: float = 1.0,
        shadows: bool = True,
        shadow_step: float = 1.0,
        jitter: bool = True,
        light: float = 0.0,
    ):
        self.density = _grid("density", density)
        self.origin = check.vector("origin", origin)
        self.cell_size = check.positive("cell_size", cell_size)
        self.extinction = check.non_negative("extinction", extinction)
        self.albedo = _albedo(albedo)
        self.anisotropy = check.real(
            "anisotropy", anisotropy, low=-1.0, high=1.0, low_open=True, high_open=True
        )
        self.temperature = (
            None if temperature is None else _grid("temperature", temperature, self.density.shape)
        )
        self.emission = check.non_negative("emission", emission)
        if self.emission > 0 and self.temperature is None:
            raise ValueError("emission > 0 needs a temperature grid (temperature=...)")
        self.step = check.real("step", step, low=0.05, high=8.0)
        self.shadow_step = check.real("shadow_step", shadow_step, low=0.05, high=8.0)
        for flag, value in (("shadows", shadows), ("jitter", jitter)):
            if not isinstance(value, bool):
                raise TypeError(f"{flag} must be True or False, got {value!r}")
        self.shadows = shadows
        self.jitter = jitter
        self.light = check.non_negative("light", light)
        self._bricks: np.ndarray | None = None

    @classmethod
    def from_zyx(cls, density, *, temperature=None, **options) -> Volume:
        """A volume from grids indexed ``[k, j, i]``, shape (nz, ny, nx), as
        :class:`motes.gridfluid.GridFluid` keeps its ``density`` and ``temperature``
        (cell centres at ``origin + (i + 0.5, j + 0.5, k + 0.5) * cell_size`` too); the
        other options as for the constructor.

        Examples
        --------
        >>> import numpy as np
        >>> smoke = np.zeros((4, 3, 2), np.float32)  # nz, ny, nx
        >>> Volume.from_zyx(smoke, cell_size=0.1).shape
        (2, 3, 4)
        """

        def turned(grid):  # a wrong shape is left for the constructor to name
            grid = np.asarray(grid)
            return np.transpose(grid, (2, 1, 0)) if grid.ndim == 3 else grid

        if temperature is not None:
            temperature = turned(temperature)
        return cls(turned(density), temperature=temperature, **options)

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.density.shape

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The box's lowest and highest corners [m]."""
        return self.origin, self.origin + np.array(self.shape) * self.cell_size

    def __repr__(self) -> str:
        origin = self.origin.tolist()
        return f"Volume(shape={self.shape}, cell_size={self.cell_size}, origin={origin})"


def _albedo(value) -> np.ndarray:
    array = np.broadcast_to(np.asarray(value, dtype=np.float64), (3,)).copy()
    if not np.isfinite(array).all() or (array < 0).any() or (array > 1).any():
        raise ValueError(f"albedo must be in [0, 1] (one value or 3), got {value!r}")
    return array


@dataclass
class LitVolume:
    """A volume packed with the light reaching its voxels, as the kernels take it.

    ``grid`` (nx, ny, nz, C) float32: density, one transmittance channel per light of
    ``lights``, [the ambient's from above and below], [temperature], [zeros up to four
    channels]; ``medium`` the packed parameters (:data:`.volume_kernels.MEDIUM_SIZE`);
    ``bricks`` the empty-space bricks' distances (:func:`.volume_light.brick_distances`);
    ``lo``, ``hi`` the box [m]; ``inner`` (2, 3) the box around the non-empty bricks
    (None: the volume is empty)."""

    grid: np.ndarray
    medium: np.ndarray
    bricks: np.ndarray
    lights: np.ndarray
    ambient: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    inner: np.ndarray | None


def light_volume(volume: Volume, shadowing: Shadowing) -> LitVolume:
    """Pack ``volume`` with the light of ``shadowing``'s lights reaching each voxel."""
    lights = np.ascontiguousarray(shadowing.lights)
    ambient = np.ascontiguousarray(shadowing.ambient)
    has_ambient = bool(np.any(ambient > 0))
    nx, ny, nz = volume.shape
    hot = volume.temperature is not None and volume.emission > 0
    # density, the lights, the ambient's two, the temperature: the kernels read the first
    # four channels of a voxel in one load, so there are at least four (the unused zero)
    channels = max(1 + len(lights) + 2 * int(has_ambient) + int(hot), 4)
    _memory.check(
        f"Volume of shape {volume.shape}",
        nx * ny * nz * (channels + 2) * 4,
        per=f"{channels} float32 channels per voxel and two scratch ones",
    )
    grid = np.zeros((nx, ny, nz, channels), np.float32)
    grid[..., 0] = volume.density
    medium = np.zeros(MEDIUM_SIZE)
    medium[ORIGIN : ORIGIN + 3] = volume.origin
    medium[CELL] = volume.cell_size
    medium[EXTINCTION] = volume.extinction
    medium[ALBEDO : ALBEDO + 3] = volume.albedo
    medium[ANISOTROPY] = volume.anisotropy
    medium[EMISSION] = volume.emission
    medium[STEP] = volume.step * volume.cell_size
    medium[JITTER] = float(volume.jitter)
    medium[TABLE_STEP] = TABLE_STEP_K
    ch = 1
    medium[LIGHTS_CH] = ch
    bricks = _bricks(volume)
    lo, hi = volume.bounds
    # Optical depths are summed in float32 scratch volumes, then turned into
    # transmittance by NumPy's exp (vectorised: Numba's is a scalar call per voxel).
    tau = np.empty(volume.shape, np.float32)
    for k, row in enumerate(lights):
        if row[LIGHT_POINT] > 0.5:
            _point_light(volume, grid, bricks, ch + k, row[LIGHT_POSITION : LIGHT_POSITION + 3])
            continue
        if volume.shadows:
            _sweep(volume, row[LIGHT_DIRECTION : LIGHT_DIRECTION + 3], tau)
            grid[..., ch + k] = _transmittance(tau)
        else:
            grid[..., ch + k] = 1.0
        if _maps_of(row, shadowing):
            shadow_voxels(
                grid, ch + k, bricks, BRICK, *volume.origin, volume.cell_size, lights, k,
                shadowing.arrays,
            )  # fmt: skip
    ch += len(lights)
    medium[AMBIENT_CH] = ch if has_ambient else -1
    if has_ambient and volume.shadows:
        below = np.empty(volume.shape, np.float32)
        columns(volume.density, 0.5 * volume.extinction * volume.cell_size, tau, below)
        # The sky and the ground are seen through a wide cone, not one column: one
        # column each makes dark vertical streaks under every dense puff.
        up, down = _transmittance(tau), _transmittance(below)
        scratch = np.empty_like(up)
        for _ in range(2):
            blur_xz(up, AMBIENT_BLUR, scratch)
            blur_xz(down, AMBIENT_BLUR, scratch)
        grid[..., ch] = up
        grid[..., ch + 1] = down
    elif has_ambient:
        grid[..., ch : ch + 2] = 1.0
    ch += 2 * int(has_ambient)
    medium[TEMPERATURE_CH] = ch if hot else -1
    if hot:
        grid[..., ch] = volume.temperature
    return LitVolume(grid, medium, bricks, lights, ambient, lo, hi, _inner_box(volume, bricks))


def _inner_box(volume: Volume, bricks: np.ndarray) -> np.ndarray | None:
    """(2, 3) corners [m] of the box around the bricks that hold some medium, clipped to
    the grid's box; None if there are none."""
    occupied = np.argwhere(bricks == 0)
    if len(occupied) == 0:
        return None
    lo, hi = volume.bounds
    span = BRICK * volume.cell_size
    inner = np.stack([lo + occupied.min(axis=0) * span, lo + (occupied.max(axis=0) + 1) * span])
    inner[1] = np.minimum(inner[1], hi)
    return inner


def _transmittance(tau: np.ndarray) -> np.ndarray:
    """``exp(-tau)`` in place."""
    return np.exp(np.negative(tau, out=tau), out=tau)


def _maps_of(row, shadowing: Shadowing) -> bool:
    """Whether a packed light has a shadow map or an opacity map this frame."""
    return row[LIGHT_SHADOW] >= 0 or row[LIGHT_OPACITY] >= 0


def _bricks(volume: Volume) -> np.ndarray:
    """The volume's empty-space bricks: each one's distance [bricks] to the nearest one
    holding medium (:func:`.volume_light.brick_distances`), computed once (the density
    does not change)."""
    if volume._bricks is None:
        shape = tuple(-(-n // BRICK) for n in volume.shape)
        maxima = np.empty(shape, np.float32)
        brick_maxima(volume.density, BRICK, maxima)
        bricks = np.empty(shape, np.int32)
        brick_distances(maxima, LEAP_CAP, bricks)
        volume._bricks = bricks
    return volume._bricks


def _sweep(volume: Volume, toward, tau: np.ndarray) -> None:
    """``tau``: optical depth from each voxel centre toward a directional light in the
    unit direction ``toward`` (:func:`.volume_light.sweep`)."""
    toward = np.asarray(toward, dtype=np.float64)
    axis = int(np.argmax(np.abs(toward)))
    n = volume.shape
    strides = np.array([n[1] * n[2], n[2], 1])
    p, q = [a for a in range(3) if a != axis]  # q is the faster in memory
    along = abs(toward[axis])
    sign = 1 if toward[axis] > 0 else -1
    sweep(
        volume.density.reshape(-1),
        np.array([n[axis], n[p], n[q]], np.int64),
        np.array([strides[axis], strides[p], strides[q]], np.int64),
        n[axis] - 1 if sign > 0 else 0, -sign, toward[p] / along, toward[q] / along,
        0.5 * volume.extinction * volume.cell_size / along, tau.reshape(-1),
    )  # fmt: skip


def _point_light(volume, grid, bricks, ch, position) -> None:
    """Channel ``ch``: transmittance toward a point light, marched on a grid of at most
    ``POINT_GRID`` cells a side and interpolated."""
    if not volume.shadows or volume.extinction == 0:
        grid[..., ch] = 1.0
        return
    factor = max(1, -(-max(volume.shape) // POINT_GRID))
    coarse = np.empty(tuple(-(-n // factor) for n in volume.shape), np.float32)
    lo, hi = volume.bounds
    march_point(
        grid, bricks, BRICK, lo, hi, volume.cell_size, volume.extinction,
        *np.asarray(position, dtype=np.float64), volume.shadow_step * volume.cell_size,
        float(factor), coarse,
    )  # fmt: skip
    upsample(coarse, float(factor), grid, ch)


def volume_shadowing(shadowing: Shadowing, lights, particles, volumes) -> Shadowing:
    """``shadowing`` with the volumes in its opacity maps: for every directional light
    that casts shadows, the opacity map of ``particles`` (``(positions (n, 3), radius
    (n,), alpha (n,))`` as :func:`.shadow_pass.prepare` takes them) is made again over
    them and the self-shadowing ``volumes`` (:func:`volume_casters`), so that opaque
    geometry and lit particles are shadowed by the media too. The shadow maps are kept.
    """
    volumes = [v for v in volumes if v.shadows and v.extinction > 0 and (v.density > 0).any()]
    if lights is None or isinstance(lights, (DirectionalLight, PointLight, AmbientLight)):
        lights = default_lights() if lights is None else [lights]
    rows = [x for x in lights if isinstance(x, (DirectionalLight, PointLight))]
    shadowed = [k for k, x in enumerate(rows) if isinstance(x, DirectionalLight) and x.shadows]
    if not shadowed or not volumes:
        return shadowing
    particles = [p for p in particles if len(p[0])]
    corners = [
        np.array(np.meshgrid(*zip(*v.bounds, strict=True))).reshape(3, -1).T for v in volumes
    ]
    center, radius = casters_sphere(np.concatenate([p[0] for p in particles] + corners))
    casting = particles + [volume_casters(v, 2.0 * radius / GRID) for v in volumes]
    radius += max(float(c[1].max()) for c in casting if len(c[1]))
    positions, sizes, alphas = (np.concatenate([c[i] for c in casting]) for i in range(3))
    packed = shadowing.lights.copy()
    cams, maps, depths = [], [], []
    for k in shadowed:
        view = light_camera(rows[k].direction, center, radius, GRID)
        grid, z0, inv_dz = opacity_map(view, positions, sizes, alphas)
        packed[k, LIGHT_OPACITY] = len(maps)
        cams.append(view.packed())
        maps.append(grid)
        depths.append((z0, inv_dz))
    shadow_cams, shadow_maps = shadowing.arrays[:2]
    arrays = (shadow_cams, shadow_maps, np.stack(cams), np.stack(maps), np.array(depths))
    return Shadowing(packed, shadowing.ambient, arrays)


def volume_casters(volume: Volume, texel: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The medium as particles for an opacity shadow map (:mod:`.opacity`): one per block
    of ``f³`` voxels holding medium (``f`` the voxels in a map texel ``texel`` [m], at
    least 1), at the block's centre. A particle deposits the optical depth ``-ln(1 - α)
    π r²`` over its disc with weights ``1 - d²/r²``; with ``r`` twice the block's side
    ``s``, the sum of those profiles over a layer of blocks is flat to within 5 %, and
    ``-ln(1 - α) = σ_t ρ̄ s³ / (π r²)`` (``ρ̄`` the block's mean density) makes the map's
    optical depth through a column of blocks ``σ_t ∫ρ``, the medium's.
    Returns positions (n, 3) [m], radius (n,) [m] and alpha (n,)."""
    f = max(1, int(texel // volume.cell_size))
    shape = tuple(-(-n // f) * f for n in volume.shape)
    rho = np.zeros(shape, np.float32)
    rho[tuple(slice(0, n) for n in volume.shape)] = volume.density
    rho = rho.reshape(shape[0] // f, f, shape[1] // f, f, shape[2] // f, f).mean(axis=(1, 3, 5))
    index = np.argwhere(rho > 0)
    side = f * volume.cell_size
    positions = volume.origin + (index + 0.5) * side
    radius = 2.0 * side
    alpha = -np.expm1(-volume.extinction * rho[tuple(index.T)] * side**3 / (np.pi * radius**2))
    return positions, np.full(len(index), radius), alpha


def march_volume(frame: Frame, camera: Camera, lit: LitVolume, transmittance: np.ndarray) -> None:
    """Composite the lit volume over ``frame.color`` (``color T + L``), stopping rays at
    ``frame.depth``, and multiply ``transmittance`` (H, W) by each pixel's ``T``."""
    if lit.inner is None:
        return
    _march(camera, lit, 0.0, 0.0, 1.0, frame.depth, frame.color, transmittance, 0.0, 1.0,
           _NO_RECORD)  # fmt: skip


_NO_RECORD = np.zeros((1, 1, 1, 4), np.float32)


def _march(camera, lit, x0, y0, factor, depth, color, trans, z0, thick, record) -> None:
    march(
        camera.packed(), lit.grid, lit.bricks, BRICK, lit.lo, lit.hi, lit.inner, lit.medium,
        lit.lights, lit.ambient, blackbody_table(), interleaved(depth.shape[0]), x0, y0, factor,
        depth, color, trans, z0, thick, record,
    )  # fmt: skip


@dataclass
class Froxels:
    """Radiance gathered and transmittance at depth slices over a coarse screen grid:
    ``grid`` (gh, gw, slices + 1, 4) float32 (``S`` rgb, ``T``) for rays through
    ``(x0 + (j + 0.5) factor, y0 + (i + 0.5) factor)`` [px] at depths ``z0 + s dz``."""

    grid: np.ndarray
    x0: float
    y0: float
    factor: float
    z0: float
    dz: float

    def lookup(self, camera: Camera, positions: np.ndarray) -> np.ndarray:
        """``(S, T)`` (n, 4) at world ``positions`` (n, 3) [m]."""
        p = np.asarray(positions, dtype=np.float64)
        out = np.empty((len(p), 4), np.float32)
        froxel_lookup(
            camera.packed(), self.grid, self.x0, self.y0, self.factor, self.z0, self.dz,
            np.ascontiguousarray(p[:, 0]), np.ascontiguousarray(p[:, 1]),
            np.ascontiguousarray(p[:, 2]), out,
        )  # fmt: skip
        return out


def froxel_grid(camera: Camera, lit: LitVolume) -> Froxels:
    """The froxel grid of a lit, non-empty volume: over the part of the image the box
    around its non-empty bricks covers (plus a cell each side, where rays miss it),
    ``FROXEL_SLICES`` slices over that box's depths. Its rays are marched as the pixels'
    are (:func:`.volume_kernels.march`), with their segments also cut at the slices and
    without jitter; opaque geometry is ignored (a particle behind it is hidden anyway)."""
    corners = np.array(np.meshgrid(*lit.inner.T, indexing="ij"))
    corners = corners.reshape(3, -1).T
    xy, depth = camera.project(corners)
    width, height = camera.resolution
    near, far = camera.near, camera.far
    z0 = max(float(depth.min()), near)
    z1 = min(float(depth.max()), far)
    z1 = max(z1, z0 + 1e-6)
    factor = float(max(FROXEL_PIXELS, -(-max(width, height) // FROXEL_MAX_SIDE)))
    behind = camera.projection is Projection.PERSPECTIVE and float(depth.min()) <= near
    if behind or not np.isfinite(xy).all():
        x0, y0, x1, y1 = 0.0, 0.0, float(width), float(height)
    else:
        x0 = max(float(xy[:, 0].min()), 0.0)
        y0 = max(float(xy[:, 1].min()), 0.0)
        x1 = min(float(xy[:, 0].max()), float(width))
        y1 = min(float(xy[:, 1].max()), float(height))
    # one cell of margin each side: rays there miss the box, so the clamped lookup of a
    # particle beside the volume reads (0, 1)
    x0 -= factor
    y0 -= factor
    gw = max(int(np.ceil((x1 - x0) / factor)) + 1, 2)
    gh = max(int(np.ceil((y1 - y0) / factor)) + 1, 2)
    dz = (z1 - z0) / FROXEL_SLICES
    grid = np.empty((gh, gw, FROXEL_SLICES + 1, 4), np.float32)
    depth = np.full((gh, gw), np.inf, np.float32)  # opaque geometry is ignored
    _march(camera, lit, x0, y0, factor, depth, np.zeros((gh, gw, 3), np.float32),
           np.ones((gh, gw), np.float32), z0, dz, grid)  # fmt: skip
    return Froxels(grid, x0, y0, factor, z0, dz)


@dataclass
class VolumeLayer:
    """What drawing volumes leaves for the layers after them.

    ``transmittance`` (H, W) float32: the fraction of what lies behind the volumes (up to
    opaque geometry) that each pixel still shows; ``froxels``: one :class:`Froxels` per
    volume, nearest first (empty when no particles follow)."""

    transmittance: np.ndarray
    froxels: list

    def through(self, camera: Camera, positions, colors, style: SpriteStyle) -> np.ndarray:
        """Particle colours (n, 4) that put particles at ``positions`` (n, 3) [m] among
        the volumes: ``S / intensity + T c`` for alpha-over (``T c`` without intensity),
        ``T c`` for additive ones (see the module docstring)."""
        rgba = np.array(colors, dtype=np.float32)
        if not self.froxels or len(rgba) == 0:
            return rgba
        gathered = np.zeros((len(rgba), 3), np.float32)
        seen = np.ones(len(rgba), np.float32)
        for grid in self.froxels:  # nearest first: S += T_near S_i, T *= T_i
            values = grid.lookup(camera, positions)
            gathered += seen[:, None] * values[:, :3]
            seen *= values[:, 3]
        rgba[:, :3] *= seen[:, None]
        if style.blend is Blend.ALPHA and style.intensity > 0:
            rgba[:, :3] += gathered / np.float32(style.intensity)
        return rgba

    def cover(self, alpha: np.ndarray) -> np.ndarray:
        """Alpha of a transparent frame with the volumes: ``1 - (1 - alpha) T``."""
        return (1.0 - (1.0 - alpha) * self.transmittance).astype(np.float32)


def draw_volumes(
    frame: Frame, camera: Camera, volumes, shadowing: Shadowing, *, froxels: bool = True
) -> VolumeLayer:
    """Draw ``volumes`` over ``frame`` (far to near by their boxes' centres; overlapping
    volumes are composited as if the nearer were wholly in front) and, with
    ``froxels``, record each one's froxel grid for the particles drawn next."""
    centres = [0.5 * np.add(*v.bounds) for v in volumes]
    depth = [float(camera.to_view(c)[0, 2]) for c in centres]
    order = sorted(range(len(volumes)), key=lambda k: -depth[k])
    transmittance = np.ones((frame.height, frame.width), np.float32)
    grids = []
    for k in order:
        lit = light_volume(volumes[k], shadowing)
        march_volume(frame, camera, lit, transmittance)
        if froxels and lit.inner is not None:
            grids.append(froxel_grid(camera, lit))
    return VolumeLayer(transmittance, grids[::-1])
