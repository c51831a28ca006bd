"""Light distributions (vectorised numpy, deterministic for a given Generator).

Tree paper 4.2: "CTF-TitanPass" distributes lights uniformly in the scene bounding box (lights
that may touch no geometry); "EpicCitadel" places them near randomly chosen triangles (every
light intersects geometry, the most taxing case for overdraw).  Radii follow "many small and
few large": a truncated Pareto law skewed to the small end of `radius_range`.

Every function returns an array of LIGHT_DTYPE and draws only from the `rng` it is given.
"""
from __future__ import annotations

import numpy as np

from .geometry import mesh_triangles
from .model import LIGHT_POINT, LIGHT_SPOT, Mesh, make_lights

# Pareto shape: with 0.5..15 m about 60% of the radii are below 1 m and ~3% above 5 m.
PARETO_ALPHA = 1.2
# Intensity = INTENSITY_SCALE * r^2 * U(0.5, 1.5): the window (1-(d/r)^4)^2/(d^2+1) falls
# like 1/d^2, so r^2 keeps a light's look roughly independent of its size.
INTENSITY_SCALE = 0.25
_WARM = np.array([1.0, 0.72, 0.42])
_COOL = np.array([0.55, 0.75, 1.0])


def sample_radii(n: int, rng: np.random.Generator, radius_range, alpha: float = PARETO_ALPHA) -> np.ndarray:
    """Truncated Pareto(alpha) on [lo, hi] (inverse CDF), float64; many small, few large."""
    lo, hi = float(radius_range[0]), float(radius_range[1])
    if not (0 < lo <= hi and np.isfinite(hi)):
        raise ValueError(f"radius_range must satisfy 0 < lo <= hi (got {radius_range!r})")
    u = rng.random(n)
    if lo == hi:
        return np.full(n, lo)
    k = 1.0 - (lo / hi) ** alpha
    r = lo * (1.0 - u * k) ** (-1.0 / alpha)
    return np.clip(r, lo, hi)


def sample_colors(n: int, rng: np.random.Generator) -> np.ndarray:
    """Random warm..cool colours, (n, 3) float64 in (0, 1]."""
    t = rng.random(n)[:, None]
    sat = rng.uniform(0.4, 1.0, n)[:, None]
    c = _WARM * (1 - t) + _COOL * t
    c = 1.0 - sat * (1.0 - c)          # blend towards white
    return c / c.max(axis=1, keepdims=True)


def _fill_common(lights: np.ndarray, radii: np.ndarray, rng: np.random.Generator) -> None:
    n = len(lights)
    lights["radius"] = radii
    lights["color"] = sample_colors(n, rng)
    lights["intensity"] = INTENSITY_SCALE * radii ** 2 * rng.uniform(0.5, 1.5, n)


def uniform_in_box(n: int, lo, hi, rng: np.random.Generator, radius_range) -> np.ndarray:
    """`n` point lights, positions uniform in the box [lo, hi] (they may touch no geometry)."""
    lo = np.asarray(lo, np.float64)
    hi = np.asarray(hi, np.float64)
    lights = make_lights(n)
    lights["type"] = LIGHT_POINT
    lights["position"] = lo + rng.random((n, 3)) * (hi - lo)
    _fill_common(lights, sample_radii(n, rng, radius_range), rng)
    return lights


def sample_on_geometry(n: int, meshes: list[Mesh], rng: np.random.Generator,
                       offset: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """Area-weighted random points on the triangles of `meshes`, pushed `offset` along the
    face normal.  Returns (positions (n,3), normals (n,3)), float64."""
    tris = mesh_triangles(meshes)
    e1 = tris[:, 1] - tris[:, 0]
    e2 = tris[:, 2] - tris[:, 0]
    cr = np.cross(e1, e2)
    area2 = np.linalg.norm(cr, axis=1)
    total = area2.sum()
    if len(tris) == 0 or not total > 0:
        raise ValueError("on_geometry: the meshes have no triangle of positive area")
    cdf = np.cumsum(area2 / total)
    cdf[-1] = 1.0
    idx = np.searchsorted(cdf, rng.random(n), side="right")
    idx = np.minimum(idx, len(tris) - 1)
    # uniform point on a triangle: sqrt trick
    u = rng.random((n, 2))
    s = np.sqrt(u[:, 0])[:, None]
    b = u[:, 1][:, None]
    t = tris[idx]
    p = (1 - s) * t[:, 0] + s * (1 - b) * t[:, 1] + s * b * t[:, 2]
    nrm = cr[idx] / area2[idx][:, None]
    return p + offset * nrm, nrm


def on_geometry(n: int, meshes: list[Mesh], rng: np.random.Generator, radius_range,
                offset: float = 0.25) -> np.ndarray:
    """`n` point lights near the geometry: an area-weighted random triangle, a uniform point on
    it, pushed `offset` metres along the face normal (so every light with radius > offset
    intersects the geometry)."""
    lights = make_lights(n)
    lights["type"] = LIGHT_POINT
    pos, _ = sample_on_geometry(n, meshes, rng, offset)
    lights["position"] = pos
    _fill_common(lights, sample_radii(n, rng, radius_range), rng)
    return lights


def spot_lights(positions, directions, rng: np.random.Generator, radius_range,
                outer_deg_range=(10.0, 30.0), inner_ratio_range=(0.6, 0.9)) -> np.ndarray:
    """Spot lights at `positions` (n,3) pointing along `directions` (n,3, normalised here).

    Outer half-angle uniform in `outer_deg_range` (degrees), inner = outer * U(inner_ratio_range),
    so cos_inner >= cos_outer.  Radii: truncated Pareto on `radius_range`.
    """
    positions = np.asarray(positions, np.float64).reshape(-1, 3)
    directions = np.asarray(directions, np.float64).reshape(-1, 3)
    n = len(positions)
    if directions.shape != positions.shape:
        raise ValueError("spot_lights: positions and directions must have the same shape")
    norm = np.linalg.norm(directions, axis=1)
    if n and not (np.all(np.isfinite(norm)) and np.all(norm > 0)):
        raise ValueError("spot_lights: directions must be finite and non-zero")
    lo, hi = float(outer_deg_range[0]), float(outer_deg_range[1])
    if not (0 < lo <= hi < 90):
        raise ValueError(f"spot_lights: outer_deg_range must lie in (0, 90) (got {outer_deg_range!r})")
    lights = make_lights(n)
    lights["type"] = LIGHT_SPOT
    lights["position"] = positions
    lights["direction"] = directions / norm[:, None] if n else directions
    outer = rng.uniform(lo, hi, n)
    inner = outer * rng.uniform(inner_ratio_range[0], inner_ratio_range[1], n)
    cos_o = np.cos(np.radians(outer)).astype(np.float32)
    cos_i = np.maximum(np.cos(np.radians(inner)).astype(np.float32), cos_o)
    lights["cos_outer"] = cos_o
    lights["cos_inner"] = cos_i
    _fill_common(lights, sample_radii(n, rng, radius_range), rng)
    return lights
