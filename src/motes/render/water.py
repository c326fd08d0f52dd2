"""Liquids drawn in screen space: a smooth, clear surface over the particles.

After van der Laan, Green & Sainz (2009), "Screen space fluid rendering with curvature
flow": each particle is splatted as a sphere into a depth buffer (the nearest front)
and a thickness buffer (the summed chords, up to the opaque depth); the depth is
smoothed by a bilateral Gaussian whose width follows the particles' size on screen, so
the spheres' bumps melt into one surface while separate sheets keep their edges; normals
come from the smoothed depth. The outline is where a coverage of the spheres, smoothed
over about one radius, crosses 1/2: a smooth curve rather than the union of discs. A
wide filter runs at half size and is brought back bilinearly by depth. The pixel then
shows

- what lies behind, shifted by the surface's tilt times the liquid's thickness
  (refraction, in screen space), attenuated by Beer-Lambert absorption over the
  thickness: ``exp(-sigma * thickness)`` per channel;
- light scattered back by the liquid's body where it is deep (its colour times the
  light from above, growing with the light the body takes out of the view);
- the sky in the mirror direction and the lights' highlights, weighted by Schlick's
  Fresnel term (2 % at normal incidence for water, all of it at grazing angles).

A liquid thinner than a particle's radius is blended over the background by its
thickness (a thin film shows little). Pixels the liquid covers take
its depth plus one particle radius, so particles drawn after it are hidden behind it,
except those within a radius of the surface (foam riding on it), which show and fade
softly into it.

What this is not: refraction is a screen-space shift (what is off screen or hidden
cannot be refracted), one surface per pixel is shaded (a sheet seen through another
shows as one thicker body), and the liquid casts no shadows. Over a transparent
background (``render_hdr(transparent=True)``, ``--alpha``) a pixel more than half
covered counts as opaque: its alpha is 1, with what it refracts of the empty frame.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .. import _validate as check
from ..color import parse_color
from .background import Background
from .camera import Camera
from .frame import Frame
from .shading import default_lights, pack_lights
from .tiles import bin_boxes
from .water_kernels import (
    DEEP_R,
    EDGE,
    EMPTY,
    GROUND_R,
    HORIZON_R,
    PARAMS,
    REFLECTANCE,
    REFRACTION,
    SHININESS,
    SIGMA_R,
    SPECULAR,
    ZENITH_R,
    double,
    halve,
    shade,
    smooth_rows,
    splat_spheres,
)

#: Widest smoothing [px] (sigma): bounds the cost when particles come close to the camera.
MAX_SIGMA_PX = 16.0
#: From this typical sigma [px] on, the smoothing runs at half size (8x less work; a
#: filter this wide leaves nothing the half-size grid cannot hold).
HALF_SIZE_SIGMA_PX = 6.0


class Passes(NamedTuple):
    """The screen-space buffers of a liquid, each (height, width) float32."""

    surface: np.ndarray  #: smoothed depth of the front [m]; EMPTY without liquid
    thickness: np.ndarray  #: smoothed depth of liquid crossed [m]
    coverage: np.ndarray  #: smoothed share of the spheres' outline: shown above 1/2
    drawn: int  #: particles in view


def _transposed(a: np.ndarray) -> np.ndarray:
    """Rows and columns swapped (a trailing channel axis kept), contiguous."""
    return np.ascontiguousarray(a.swapaxes(0, 1))


class Water:
    """A liquid's particles, drawn as one clear surface (pass it among a render's objects).

    Parameters
    ----------
    positions : (n, 3) array_like
        Particle centres [m].
    radius : float
        Radius [m] of the sphere drawn for each particle, > 0 (about the particle spacing
        makes a closed surface).
    volume : float, optional
        Volume [m^3] of liquid each particle stands for, > 0: the thickness counts each
        sphere's chords scaled by ``volume / (4/3 pi radius^3)``, so that Beer-Lambert sees
        the liquid's real depth (a lattice of spacing ``s`` holds ``s^3`` a particle).
        None: the sphere's own volume.
    color : colour
        What white light looks like after crossing ``clarity`` metres of the liquid
        (hex strings are sRGB, tuples linear RGB; each channel in (0, 1]).
    clarity : float
        The depth [m] at which light has taken ``color``, > 0. Absorption per channel is
        ``-ln(color) / clarity`` [1/m].
    scatter : float
        Share of the light from above that the body scatters back toward the eye where it
        is deep, in [0, 1] (0: clear as glass; murky water about 0.3).
    smoothing : float
        Width of the depth smoothing in particle radii (its Gaussian's sigma), >= 0.
    iterations : int
        Smoothing passes, 0 to 8.
    refraction : float
        Shift [m] of what is seen behind, per metre of liquid crossed and unit of the
        surface's tilt, >= 0 (water's index of refraction, 1.33, gives about 0.25).
    reflectance : float
        Fresnel reflectance at normal incidence, in [0, 1] (water 0.02).
    specular, shininess : float
        Strength (>= 0) and Blinn-Phong exponent (>= 1) of the lights' highlights.
    sky : (colour, colour), optional
        The sky reflected straight up and at the horizon; None: the renderer's
        background (top, bottom).
    ground : colour, optional
        What is reflected from below the horizon; None: the sky's horizon at 60 %.
    """

    def __init__(
        self,
        positions,
        radius: float,
        *,
        volume: float | None = None,
        color="#5fb6d6",
        clarity: float = 1.0,
        scatter: float = 0.1,
        smoothing: float = 2.0,
        iterations: int = 2,
        refraction: float = 0.25,
        reflectance: float = 0.02,
        specular: float = 1.0,
        shininess: float = 300.0,
        sky=None,
        ground=None,
    ):
        self.positions = check.points("positions", positions, min_rows=0)
        self.radius = check.positive("radius", radius)
        sphere = 4.0 / 3.0 * math.pi * self.radius**3
        self.volume = sphere if volume is None else check.positive("volume", volume)
        rgb = np.asarray(parse_color(color)[:3], dtype=np.float64)
        if not ((rgb > 0) & (rgb <= 1)).all():
            raise ValueError(f"color must have each channel in (0, 1], got {tuple(rgb)}")
        self.color = rgb
        self.clarity = check.positive("clarity", clarity)
        self.scatter = check.unit_interval("scatter", scatter)
        self.smoothing = check.non_negative("smoothing", smoothing)
        self.iterations = check.integer("iterations", iterations, low=0)
        if self.iterations > 8:
            raise ValueError(f"iterations must be <= 8, got {iterations}")
        self.refraction = check.non_negative("refraction", refraction)
        self.reflectance = check.unit_interval("reflectance", reflectance)
        self.specular = check.non_negative("specular", specular)
        self.shininess = check.real("shininess", shininess, low=1.0, high=1e6)
        if sky is not None:
            if not isinstance(sky, (tuple, list)) or len(sky) != 2:
                raise ValueError(f"sky must be (zenith, horizon) colours or None, got {sky!r}")
            sky = tuple(np.asarray(parse_color(c)[:3], dtype=np.float64) for c in sky)
        self.sky = sky
        self.ground = None if ground is None else np.asarray(parse_color(ground)[:3], float)

    @property
    def absorption(self) -> np.ndarray:
        """Absorption coefficient [1/m] per RGB channel."""
        return -np.log(self.color) / self.clarity

    def draw(self, frame: Frame, camera: Camera, *, lights=None, background=None) -> int:
        """Draw into ``frame`` (colour and depth); returns the number of particles drawn.

        ``lights`` as :class:`~motes.render.renderer.Renderer` takes them (None: the
        default lights); ``background`` the :class:`Background` whose colours are the sky
        when :attr:`sky` is None.
        """
        buffers = self.passes(frame, camera)
        if buffers is None:
            return 0
        packed, ambient = pack_lights(default_lights() if lights is None else lights)
        behind = frame.color.copy()
        opaque = np.minimum(frame.depth, EMPTY)
        plain = np.ascontiguousarray(np.stack([buffers.thickness, buffers.coverage], axis=-1))
        shade(
            camera.packed(), behind, opaque, buffers.surface, plain, packed, ambient,
            self._params(background or Background()), frame.color, frame.depth,
        )  # fmt: skip
        return buffers.drawn

    def passes(self, frame: Frame, camera: Camera) -> Passes | None:
        """The smoothed buffers over ``frame``'s opaque depth (:class:`Passes`); None
        when no particle is in view."""
        width, height = camera.resolution
        if (frame.width, frame.height) != (width, height):
            raise ValueError(
                f"frame is {frame.width}x{frame.height} but the camera renders {width}x{height}"
            )
        xy, depth = camera.project(self.positions)
        ppm = camera.pixels_per_metre(np.where(depth > 0, depth, 1.0))
        rpx = self.radius * ppm
        seen = (
            (depth >= camera.near)
            & (depth <= camera.far)
            & (xy[:, 0] + rpx >= 0)
            & (xy[:, 0] - rpx <= width)
            & (xy[:, 1] + rpx >= 0)
            & (xy[:, 1] - rpx <= height)
        )
        if not seen.any():
            return None
        sx = xy[seen, 0].astype(np.float32)
        sy = xy[seen, 1].astype(np.float32)
        rpx = rpx[seen].astype(np.float32)
        z = depth[seen].astype(np.float32)
        x0 = np.clip(np.floor(sx - rpx), 0, width - 1).astype(np.int32)
        x1 = np.clip(np.floor(sx + rpx), 0, width - 1).astype(np.int32)
        y0 = np.clip(np.floor(sy - rpx), 0, height - 1).astype(np.int32)
        y1 = np.clip(np.floor(sy + rpx), 0, height - 1).astype(np.int32)
        bins = bin_boxes(x0, y0, x1, y1, width, height)
        opaque = np.minimum(frame.depth, EMPTY)
        surface = np.full((height, width), EMPTY, np.float32)
        thickness = np.zeros((height, width), np.float32)
        # Chords of a sphere of the given radius, scaled to the volume a particle holds.
        size = np.full(len(z), self.radius, np.float32)
        splat_spheres(bins.starts, bins.items, bins.tiles_x, sx, sy, z, rpx, size, opaque,
                      surface, thickness)  # fmt: skip
        thickness *= np.float32(self.volume / (4.0 / 3.0 * math.pi * self.radius**3))
        plain = np.stack([thickness, (surface < EMPTY).astype(np.float32)], axis=-1)
        if self.iterations and self.smoothing > 0:
            surface, plain = self._smooth(camera, surface, plain)
        return Passes(surface, plain[..., 0], plain[..., 1], int(seen.sum()))

    def _smooth(self, camera: Camera, surface, plain):
        """Separable bilateral smoothing, :attr:`iterations` times (rows, then columns),
        over the liquid's bounding box grown by the widest filter; at half size when the
        filter is wide (:data:`HALF_SIZE_SIGMA_PX`), brought back by
        :func:`~motes.render.water_kernels.double`."""
        liquid = surface < EMPTY
        if not liquid.any():  # every particle hidden behind opaque geometry
            return surface, plain
        rows = np.flatnonzero(liquid.any(axis=1))
        cols = np.flatnonzero(liquid.any(axis=0))
        margin = int(2 * MAX_SIGMA_PX) + 2
        top, bottom = max(rows[0] - margin, 0), min(rows[-1] + margin + 1, surface.shape[0])
        left, right = max(cols[0] - margin, 0), min(cols[-1] + margin + 1, surface.shape[1])
        box = (slice(top, bottom), slice(left, right))
        raw = np.ascontiguousarray(surface[box])
        s, t = raw, np.ascontiguousarray(plain[box])
        reach = self.smoothing * self.radius
        # Depths more than four spatial reaches apart are not averaged: a face seen at a
        # grazing angle (whose depth changes fast across the screen) is still smoothed,
        # while a sheet further behind keeps its own depth.
        inv_range2 = np.float32(1.0 / (4.0 * max(reach, self.radius)) ** 2)
        inside = raw < EMPTY
        typical = float(np.median(reach * camera.pixels_per_metre(raw[inside])))
        scale = 2 if typical >= HALF_SIZE_SIGMA_PX else 1
        if scale == 2:
            size = tuple((n + 1) // 2 for n in s.shape)
            s_half, t_half = np.empty(size, np.float32), np.empty((*size, 2), np.float32)
            halve(s, t, s_half, t_half)
            s, t = s_half, t_half
        inside = s < EMPTY
        sigma = np.empty(s.shape, np.float32)
        sigma[inside] = reach * camera.pixels_per_metre(s[inside]) / scale
        sigma[~inside] = float(np.median(sigma[inside]))
        np.clip(sigma, 0.5, MAX_SIGMA_PX / scale, out=sigma)
        sigma_t = np.ascontiguousarray(sigma.T)
        # thickness and coverage: smoothed over about a radius (their sigma's share)
        share = np.float32(min(1.0, 1.0 / self.smoothing))
        for _ in range(self.iterations):
            s, t = self._pass(s, t, sigma, share, inv_range2)
            s, t = self._pass(_transposed(s), _transposed(t), sigma_t, share, inv_range2)
            s, t = _transposed(s), _transposed(t)
        if scale == 2:
            full_s, full_t = np.empty_like(raw), np.empty((*raw.shape, 2), np.float32)
            double(raw, s, t, inv_range2, full_s, full_t)
            s, t = full_s, full_t
        surface[box], plain[box] = s, t
        return surface, plain

    @staticmethod
    def _pass(surface, plain, sigma, share, inv_range2):
        out_s, out_t = np.empty_like(surface), np.empty_like(plain)
        smooth_rows(surface, plain, sigma, share, inv_range2, out_s, out_t)
        return out_s, out_t

    def _params(self, background: Background) -> np.ndarray:
        p = np.zeros(PARAMS)
        p[SIGMA_R : SIGMA_R + 3] = self.absorption
        p[DEEP_R : DEEP_R + 3] = self.color * self.scatter
        p[REFRACTION] = self.refraction
        p[REFLECTANCE] = self.reflectance
        p[SHININESS] = self.shininess
        p[SPECULAR] = self.specular
        p[EDGE] = self.radius
        zenith, horizon = self.sky or (background.top, background.bottom)
        p[ZENITH_R : ZENITH_R + 3] = zenith
        p[HORIZON_R : HORIZON_R + 3] = horizon
        ground = 0.6 * np.asarray(horizon) if self.ground is None else self.ground
        p[GROUND_R : GROUND_R + 3] = ground
        return p
