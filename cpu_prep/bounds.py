"""Conservative bounds of light volumes: bounding spheres, screen rectangles.

Scalar numba functions, so the cull and bin kernels call them per light with no
temporaries; `screen_rects` and `spot_bounding_spheres` are array wrappers for tests and
tools.  Every bound contains every point the float32 GPU test `affects()` can accept, with
the margins of cpu_prep.limits applied where stated.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .camera import FrameCamera
from .limits import PIXEL_MARGIN, RADIUS_REL_MARGIN

F32_EPS = float(np.finfo(np.float32).eps)
HALF_SQRT2 = math.sqrt(0.5)


@numba.njit(inline="always")
def spot_sphere(px, py, pz, dx, dy, dz, radius, cos_outer):
    """Smallest sphere around a spot's volume (sphere of `radius` cut by the cone), after
    Wronski, "Bounding sphere of a cone" (2017): for half-angle > 45 deg the centre sits at
    cos(a)*r along the axis with radius sin(a)*r, otherwise at r / (2 cos a) with that
    radius; never larger than the light's own sphere."""
    cos_a = min(max(cos_outer, 0.0), 1.0)
    if cos_a < HALF_SQRT2:
        dist, rad = cos_a * radius, math.sqrt(1.0 - cos_a * cos_a) * radius
    else:
        dist = radius / (2.0 * cos_a)
        rad = dist
    if rad >= radius:
        return px, py, pz, radius
    return px + dx * dist, py + dy * dist, pz + dz * dist, rad


@numba.njit(inline="always")
def grow(radius, cx, cy, cz):
    """Culling radius: float32 rounding of the GPU test (RADIUS_REL_MARGIN) plus the
    rounding of a float32-stored centre (4 ulp of |c|)."""
    return radius * (1.0 + RADIUS_REL_MARGIN) + 4.0 * F32_EPS * math.sqrt(cx * cx + cy * cy + cz * cz)


@numba.njit(inline="always")
def project_axis(ca, cz, r, near_z, tan_half):
    """Mara & McGuire 2013, listing 1 (getBoundsForAxis), on one axis: NDC range of the
    sphere (centre (ca, cz) in the a-z plane) clipped at the near plane near_z < 0.
    Correct when the sphere crosses the near plane or contains the eye."""
    length2 = ca * ca + cz * cz
    t2 = length2 - r * r
    inside = t2 <= 0.0
    vx = vy = 0.0
    if not inside:
        length = math.sqrt(length2)
        vx, vy = math.sqrt(t2) / length, r / length
    clip_sphere = cz + r >= near_z
    k = math.sqrt(max(r * r - (near_z - cz) * (near_z - cz), 0.0))
    lo, hi = math.inf, -math.inf
    for sign in (1.0, -1.0):
        sy = sign * vy
        ba = (vx * ca + sy * cz) * vx        # rotate c by the tangent angle, scale by its cos
        bz = (-sy * ca + vx * cz) * vx
        if clip_sphere and (inside or bz > near_z):
            # The rotation by +vy turns c towards -a (z < 0 in front), so its near-plane
            # replacement is the chord end at ca - k.  (Listing 1 as printed pairs +vy with
            # +k, which in this -z-forward frame swaps sides: tests/cpu_prep/test_bounds.py.)
            ba, bz = ca - sign * k, near_z
        n = ba / (-bz * tan_half)
        lo, hi = min(lo, n), max(hi, n)
    return lo, hi


@numba.njit(inline="always")
def pixel_rect(cx, cy, cz, r, near, tan_x, tan_y, width, height):
    """Pixel rectangle (x0, x1, y0, y1), GL convention (y up), continuous pixel units,
    PIXEL_MARGIN included, of the sphere's part in front of the near plane."""
    lx, hx = project_axis(cx, cz, r, -near, tan_x)
    ly, hy = project_axis(cy, cz, r, -near, tan_y)
    return ((lx * 0.5 + 0.5) * width - PIXEL_MARGIN, (hx * 0.5 + 0.5) * width + PIXEL_MARGIN,
            (ly * 0.5 + 0.5) * height - PIXEL_MARGIN, (hy * 0.5 + 0.5) * height + PIXEL_MARGIN)


@numba.njit(cache=True)
def _rects(center, radius, near, tan_x, tan_y, width, height):
    out = np.empty((center.shape[0], 4))
    for i in range(center.shape[0]):
        out[i] = pixel_rect(center[i, 0], center[i, 1], center[i, 2], radius[i],
                            near, tan_x, tan_y, width, height)
    return out


def screen_rects(center, radius, cam: FrameCamera):
    """Arrays (x0, x1, y0, y1) of pixel_rect for many spheres."""
    r = _rects(np.ascontiguousarray(center, np.float64), np.ascontiguousarray(radius, np.float64),
               cam.near, cam.tan_half_x, cam.tan_half_y, float(cam.width), float(cam.height))
    return r[:, 0], r[:, 1], r[:, 2], r[:, 3]


@numba.njit(cache=True)
def _spheres(pos, direction, radius, cos_outer):
    out = np.empty((pos.shape[0], 4))
    for i in range(pos.shape[0]):
        out[i] = spot_sphere(pos[i, 0], pos[i, 1], pos[i, 2], direction[i, 0], direction[i, 1],
                             direction[i, 2], radius[i], cos_outer[i])
    return out


def spot_bounding_spheres(pos, direction, radius, cos_outer):
    """(centres (N,3), radii (N,)) of spot_sphere for many spots."""
    s = _spheres(np.ascontiguousarray(pos, np.float64), np.ascontiguousarray(direction, np.float64),
                 np.ascontiguousarray(radius, np.float64), np.ascontiguousarray(cos_outer, np.float64))
    return s[:, :3], s[:, 3]
