"""The grid fluid's validation cases, shared by ``python -m benchmarks.grid`` and the
tests: the Taylor-Green vortex (analytic) and the lid-driven cavity at Re = 100 (Ghia,
Ghia & Shin 1982)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from motes.gridfluid import GridFluid, Wall

GHIA = Path(__file__).parent / "data" / "ghia_1982_cavity_re100.csv"


def taylor_green(n: int, *, viscosity: float = 0.1, advection: str = "maccormack") -> GridFluid:
    """The 2D Taylor-Green vortex ``u = sin x cos y``, ``v = -cos x sin y`` on
    ``[0, pi]^2`` between slipping walls (where it is exact), ``n`` cells a side."""
    h = np.pi / n
    fluid = GridFluid((n, n), h, viscosity=viscosity, advection=advection)
    x_faces, x_centres = np.arange(n + 1) * h, (np.arange(n) + 0.5) * h
    fluid.u[0] = np.sin(x_faces)[None, :] * np.cos(x_centres)[:, None]
    fluid.v[0] = -np.cos(x_centres)[None, :] * np.sin(x_faces)[:, None]
    return fluid


def taylor_green_amplitude(fluid: GridFluid, start: np.ndarray) -> float:
    """The amplitude of the initial u field ``start`` left in ``fluid.u`` (projection)."""
    return float((fluid.u * start).sum(dtype=np.float64) / (start * start).sum(dtype=np.float64))


def lid_driven_cavity(
    n: int, *, reynolds: float = 100.0, advection: str = "maccormack"
) -> GridFluid:
    """The unit square cavity, ``n`` cells a side, its lid (y = 1) moving at u = 1, the
    other walls at rest, no slip anywhere; ``nu = 1 / reynolds``."""
    walls = {side: "no-slip" for side in ("-x", "+x", "-y")}
    walls["+y"] = Wall(slip=False, velocity=(1.0, 0.0, 0.0))
    return GridFluid((n, n), 1.0 / n, viscosity=1.0 / reynolds, walls=walls, advection=advection)


def ghia() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Ghia et al.'s centreline data: ``{"u": (y, u), "v": (x, v)}``."""
    lines = [line for line in GHIA.read_text().splitlines() if not line.startswith("#")]
    rows = list(csv.reader(lines))
    out = {}
    for line in ("u", "v"):
        pairs = np.array([(float(p), float(v)) for name, p, v in rows[1:] if name == line])
        out[line] = (pairs[:, 0], pairs[:, 1])
    return out


def cavity_centrelines(fluid: GridFluid) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The cavity's ``u`` on x = 0.5 and ``v`` on y = 0.5 interpolated to Ghia's points
    (the walls' velocities at the ends): ``{"u": (y, u), "v": (x, v)}``."""
    n = fluid.resolution[0]
    h = 1.0 / n
    centres = (np.arange(n) + 0.5) * h
    out = {}
    reference = ghia()
    # x = 0.5 is a column of x faces when n is even; y = 0.5 a row of y faces
    u_line = np.concatenate([[0.0], fluid.u[0, :, n // 2], [1.0]])
    v_line = np.concatenate([[0.0], fluid.v[0, n // 2, :], [0.0]])
    where = np.concatenate([[0.0], centres, [1.0]])
    for name, line in (("u", u_line), ("v", v_line)):
        at = reference[name][0]
        out[name] = (at, np.interp(at, where, line))
    return out


def run_cavity(n: int, *, end_time: float = 10.0, cfl: float = 1.0, **options) -> GridFluid:
    """The cavity run from rest to ``end_time`` [s] (steady by t = 10 at Re = 100) with
    ``dt = cfl * h / U``."""
    fluid = lid_driven_cavity(n, **options)
    dt = cfl / n
    for _ in range(round(end_time / dt)):
        fluid.step(dt)
    return fluid
