"""Conservative bounds of light volumes: bounding spheres, depth extents, screen rectangles.

Every bound here contains every point the float32 GPU test `affects()` can accept, with the
margins of cpu_prep.limits applied where they are stated.
"""
from __future__ import annotations

import numpy as np

from .camera import FrameCamera
from .limits import PIXEL_MARGIN, RADIUS_REL_MARGIN

F32_EPS = float(np.finfo(np.float32).eps)


def spot_bounding_spheres(pos, direction, radius, cos_outer):
    """Smallest sphere around a spot's volume (sphere of `radius` cut by the cone), after
    Wronski, "Bounding sphere of a cone" (2017): for half-angle > 45 deg the centre sits at
    cos(a)*r along the axis with radius sin(a)*r, otherwise at r / (2 cos a) with that radius."""
    cos_a = np.clip(cos_outer.astype(np.float64), 0.0, 1.0)
    sin_a = np.sqrt(1.0 - cos_a * cos_a)
    wide = cos_a < np.sqrt(0.5)
    dist = np.where(wide, cos_a * radius, radius / (2.0 * np.maximum(cos_a, 1e-30)))
    rad = np.where(wide, sin_a * radius, dist)
    rad = np.minimum(rad, radius)  # never worse than the whole sphere
    dist = np.where(rad >= radius, 0.0, dist)
    return pos + direction * dist[:, None], rad


def culling_spheres(pos, radius, is_spot, direction, cos_outer):
    """View-space bounding sphere of every light, grown so that it is conservative for the
    float32 test: radius * (1 + RADIUS_REL_MARGIN) plus the rounding of a float32 centre."""
    pos = pos.astype(np.float64)
    radius = radius.astype(np.float64)
    center, rad = pos.copy(), radius.copy()
    if is_spot.any():
        c, r = spot_bounding_spheres(pos[is_spot], direction[is_spot].astype(np.float64),
                                     radius[is_spot], cos_outer[is_spot])
        center[is_spot], rad[is_spot] = c, r
    grown = rad * (1.0 + RADIUS_REL_MARGIN) + 4.0 * F32_EPS * np.linalg.norm(center, axis=1)
    return center, grown


def _axis_bounds(ca, cz, r, near_z):
    """Mara & McGuire 2013, listing 1 (getBoundsForAxis), vectorised: the two view-space
    points (a, z) bounding the sphere's projection on one axis, clipped at the near plane
    (near_z < 0).  Correct when the sphere crosses the near plane or contains the eye."""
    t2 = ca * ca + cz * cz - r * r
    inside = t2 <= 0.0
    length = np.sqrt(ca * ca + cz * cz)
    safe = np.where(inside | (length == 0), 1.0, length)
    vx = np.where(inside, 0.0, np.sqrt(np.maximum(t2, 0.0)) / safe)
    vy = np.where(inside, 0.0, r / safe)
    clip_sphere = cz + r >= near_z
    k = np.sqrt(np.maximum(r * r - (near_z - cz) ** 2, 0.0))
    out = []
    for sign in (1.0, -1.0):
        sy = sign * vy
        ba = (vx * ca + sy * cz) * vx      # rotate c by the tangent angle, scale by its cos
        bz = (-sy * ca + vx * cz) * vx
        clip_bound = inside | (bz > near_z)
        use_near = clip_sphere & clip_bound
        # The rotation by +vy turns c towards -a (z < 0 in front), so its near-plane
        # replacement is the chord end at ca - k.  (Listing 1 as printed pairs +vy with +k,
        # which in this -z-forward frame swaps sides: checked by tests/cpu_prep/test_bounds.py.)
        out.append((np.where(use_near, ca - sign * k, ba), np.where(use_near, near_z, bz)))
    return out


def screen_rects(center, radius, cam: FrameCamera):
    """Pixel rectangle [x0, x1] x [y0, y1] (GL convention, y up, continuous pixel units,
    PIXEL_MARGIN included) covering the projection of each sphere's part in front of the
    near plane.  Spheres must reach in front of the near plane (see cull.frustum_cull)."""
    near_z = -cam.near
    rect = []
    for axis, tan_half, size in ((0, cam.tan_half_x, cam.width), (1, cam.tan_half_y, cam.height)):
        (a0, z0), (a1, z1) = _axis_bounds(center[:, axis], center[:, 2], radius, near_z)
        # project: ndc = a / (-z * tan_half); both points lie at z <= near_z < 0
        n0 = a0 / (-z0 * tan_half)
        n1 = a1 / (-z1 * tan_half)
        lo, hi = np.minimum(n0, n1), np.maximum(n0, n1)
        rect.append(((lo * 0.5 + 0.5) * size - PIXEL_MARGIN, (hi * 0.5 + 0.5) * size + PIXEL_MARGIN))
    (x0, x1), (y0, y1) = rect
    return x0, x1, y0, y1
