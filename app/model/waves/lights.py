"""The float32 twin of the shaders' light tests (glsl light_affects_as and the wave's
bounding-sphere test) the replay decides with, and the bounding spheres it tests."""
from __future__ import annotations

import numba
import numpy as np

from cpu_prep import layouts
from scenes.model import LIGHT_TYPES

# word offsets of a GPU_LIGHT row (layouts: one source), compile-time constants below
_POS, _DIR = layouts.LIGHT_POS_RADIUS, layouts.LIGHT_DIR_COS_OUTER
_EXT, _RIGHT = layouts.LIGHT_EXTENT_LENGTH, layouts.LIGHT_RIGHT


@numba.njit(inline="always")
def affects(px, py, pz, i, L, types, unbounded) -> bool:
    """glsl light_affects_as in float32 (pixel.glsl, features.py SHAPES): the view-space
    point P inside light i's volume; L holds the GPU_LIGHT rows as float32 words."""
    if unbounded:
        return True
    f32 = np.float32
    dx, dy, dz = f32(px - L[i, _POS]), f32(py - L[i, _POS + 1]), f32(pz - L[i, _POS + 2])
    d2 = f32(dx * dx + dy * dy + dz * dz)
    r2 = L[i, _POS + 3] * L[i, _POS + 3]
    t = types[i]
    if t == 0:                                   # point
        return d2 < r2
    fx, fy, fz = L[i, _DIR], L[i, _DIR + 1], L[i, _DIR + 2]
    along = f32(dx * fx + dy * fy + dz * fz)
    if t == 1:                                   # spot: the sphere cut by the cone
        return d2 < r2 and along > f32(L[i, _DIR + 3] * np.sqrt(d2))
    if t == 2:                                   # capsule: distance to the segment
        h = f32(0.5) * L[i, _EXT + 3]
        s = min(max(along, -h), h)
        qx, qy, qz = f32(dx - fx * s), f32(dy - fy * s), f32(dz - fz * s)
        return f32(qx * qx + qy * qy + qz * qz) < r2
    # box: the local frame (right, up' = right x direction, direction)
    rx, ry, rz = L[i, _RIGHT], L[i, _RIGHT + 1], L[i, _RIGHT + 2]
    ux, uy, uz = f32(ry * fz - rz * fy), f32(rz * fx - rx * fz), f32(rx * fy - ry * fx)
    a = abs(f32(dx * rx + dy * ry + dz * rz))
    b = abs(f32(dx * ux + dy * uy + dz * uz))
    return a < L[i, _EXT] and b < L[i, _EXT + 1] and abs(along) < L[i, _EXT + 2]


@numba.njit(inline="always")
def _misses_box(i, L, bound, lo, hi) -> bool:
    """Light i's bounding sphere misses the box [lo, hi] of the iteration's lane positions."""
    d2 = np.float32(0.0)
    for k in range(3):
        c = L[i, _POS + k]
        e = lo[k] - c if c < lo[k] else (c - hi[k] if c > hi[k] else np.float32(0.0))
        d2 += e * e
    return d2 > bound[i] * bound[i]


def light_bounds(pos, ext, types) -> np.ndarray:
    """A bounding sphere radius per light around its position (point/spot: the radius;
    capsule: radius + half length; box: its half diagonal), a little grown."""
    r = pos[:, 3].astype(np.float64)
    r = np.where(types == LIGHT_TYPES.index("capsule"), r + 0.5 * ext[:, 3], r)
    r = np.where(types == LIGHT_TYPES.index("box"), np.linalg.norm(ext[:, :3].astype(np.float64), axis=1), r)
    return (r * 1.001 + 1e-6).astype(np.float32)
