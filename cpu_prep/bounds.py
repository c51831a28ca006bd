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

from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_SPOT

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
    Correct when the sphere crosses the near plane or contains the eye.

    Fast path (most lights): a sphere wholly in front of the near plane (cz + r < near_z)
    neither contains the eye (|c| >= -cz > r, so t2 > 0) nor has a tangent point behind the
    plane (a tangent point's z is at most cz + r), so listing 1's clip never applies and
    the two tangent directions' NDC values are, with t = sqrt(t2) and the common factors
    t / length^2 of ba and bz cancelled,

        n = (t * ca + s * r * cz) / ((s * r * ca - t * cz) * tan_half),   s = +1, -1,

    one square root and two divisions instead of three and four.  Both forms are the same
    real number; each float64 evaluation errs by a few ulp of its terms, and the
    denominator is >= -near_z * length (the tangent point is in front of the near plane),
    so the two differ by < 1e-12 * length / (near * tan_half) in NDC: under 1e-6 pixel for
    any camera of the lab (near >= 0.01, depths <= 1e5, 1e4 pixels), against the
    PIXEL_MARGIN of a whole pixel added to every rectangle (tests/cpu_prep/test_bounds.py
    holds the two forms to each other)."""
    if cz + r < near_z:
        return project_axis_ahead(ca, cz, r, tan_half)
    return project_axis_general(ca, cz, r, near_z, tan_half)


@numba.njit(inline="always")
def project_axis_ahead(ca, cz, r, tan_half):
    """project_axis()'s fast path, for a sphere wholly in front of the near plane (no
    branch: the pack evaluates it for a block of lights at once, in SIMD lanes)."""
    t = math.sqrt(ca * ca + cz * cz - r * r)
    tca, tcz, rca, rcz = t * ca, t * cz, r * ca, r * cz
    n0 = (tca + rcz) / ((rca - tcz) * tan_half)
    n1 = (tca - rcz) / ((-rca - tcz) * tan_half)
    return min(n0, n1), max(n0, n1)


@numba.njit(inline="always")
def project_axis_general(ca, cz, r, near_z, tan_half):
    """project_axis() as listing 1 writes it (every case): the reference of its fast path."""
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


@numba.njit(cache=True, nogil=True, error_model="numpy")
def pixel_rect(cx, cy, cz, r, near, tan_x, tan_y, width, height):
    """Pixel rectangle (x0, x1, y0, y1), GL convention (y up), continuous pixel units,
    PIXEL_MARGIN included, of the sphere's part in front of the near plane."""
    lx, hx = project_axis(cx, cz, r, -near, tan_x)
    ly, hy = project_axis(cy, cz, r, -near, tan_y)
    return ndc_rect(lx, hx, ly, hy, width, height)


@numba.njit(inline="always")
def ndc_rect(lx, hx, ly, hy, width, height):
    """Pixel rectangle of an NDC one, PIXEL_MARGIN added."""
    return ((lx * 0.5 + 0.5) * width - PIXEL_MARGIN, (hx * 0.5 + 0.5) * width + PIXEL_MARGIN,
            (ly * 0.5 + 0.5) * height - PIXEL_MARGIN, (hy * 0.5 + 0.5) * height + PIXEL_MARGIN)


@numba.njit(inline="always")
def sphere_only(t, cos_outer, length):
    """Whether shape_bounds() of a light of type t is its culling sphere's bounds alone (a
    point, a spot wider than WIDE_CONE_COS, a capsule of no length)."""
    return not ((t == LIGHT_SPOT and cos_outer >= WIDE_CONE_COS) or
                (t == LIGHT_CAPSULE and length > 0.0) or t == LIGHT_BOX)


@numba.njit(cache=True, error_model="numpy")
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


@numba.njit(cache=True, error_model="numpy")
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


# ---- the other light shapes: tight conservative screen rectangles and depth ranges ------
# A rectangle (x0, x1, y0, y1) in pixels (GL, y up) and a depth range (d_lo, d_hi) of the
# part of a light's volume a pixel could see: the whole volume's bounding sphere first, then,
# per shape, a tighter cover intersected with it (both are conservative, so is the overlap).

SHAPE_PIECES = 4              # spheres covering a capsule's segment
WIDE_CONE_COS = 0.2           # past ~78 degrees a cone's pyramid is wider than its sphere


@numba.njit(cache=True, nogil=True, error_model="numpy")
def spot_pyramid(px, py, pz, dx, dy, dz, radius, cos_outer, near, tan_x, tan_y, width, height):
    """Bounds of the square pyramid around a spot's volume (the cone of half-angle a cut by
    the sphere): apex at the light, axis `radius` long, half side radius * tan(a) at its
    base.  Every point of the volume lies at axial distance t <= radius and lateral distance
    <= t tan(a), so inside it."""
    cos_a = min(max(cos_outer, WIDE_CONE_COS), 1.0)
    w = radius * math.sqrt(1.0 - cos_a * cos_a) / cos_a
    # a unit vector across the axis: from the view axis least aligned with it
    if abs(dx) < 0.6:
        rx, ry, rz = 0.0, -dz, dy                   # x cross d
    else:
        rx, ry, rz = dz, 0.0, -dx                   # y cross d
    n = math.sqrt(rx * rx + ry * ry + rz * rz)
    rx, ry, rz = rx / n, ry / n, rz / n
    h = 0.5 * radius
    return box_bounds(px + dx * h, py + dy * h, pz + dz * h, dx, dy, dz, rx, ry, rz, w, w, h,
                      near, tan_x, tan_y, width, height, 0.0)


@numba.njit(inline="always")
def _cover(x0, x1, y0, y1, d0, d1, cx, cy, cz, r, near, tan_x, tan_y, width, height):
    """Union of the running bounds with a sphere's (rect and depth range)."""
    a0, a1, b0, b1 = pixel_rect(cx, cy, cz, r, near, tan_x, tan_y, width, height)
    return (min(x0, a0), max(x1, a1), min(y0, b0), max(y1, b1),
            min(d0, -cz - r), max(d1, -cz + r))


@numba.njit(cache=True, nogil=True, error_model="numpy")
def capsule_pieces(px, py, pz, dx, dy, dz, radius, length, near, tan_x, tan_y, width, height):
    """Bounds of SHAPE_PIECES spheres along the segment, each of the capsule radius plus half
    its piece of the segment (so it holds the capsule around that piece)."""
    x0 = y0 = d0 = math.inf
    x1 = y1 = d1 = -math.inf
    piece = length / SHAPE_PIECES
    for k in range(SHAPE_PIECES):
        t = -0.5 * length + piece * (k + 0.5)
        cx, cy, cz = px + dx * t, py + dy * t, pz + dz * t
        r = grow(radius + 0.5 * piece, cx, cy, cz)
        x0, x1, y0, y1, d0, d1 = _cover(x0, x1, y0, y1, d0, d1, cx, cy, cz, r, near, tan_x, tan_y, width, height)
    return x0, x1, y0, y1, d0, d1


@numba.njit(inline="always")
def _box_point(x0, x1, y0, y1, d0, d1, x, y, z, tan_x, tan_y, width, height):
    """Add a point in front of the eye (z < 0) to the bounds."""
    sx = (x / (-z * tan_x) * 0.5 + 0.5) * width
    sy = (y / (-z * tan_y) * 0.5 + 0.5) * height
    return min(x0, sx), max(x1, sx), min(y0, sy), max(y1, sy), min(d0, -z), max(d1, -z)


@numba.njit(inline="always")
def _corner(k, px, py, pz, rx, ry, rz, ux, uy, uz, dx, dy, dz, ex, ey, ez, back):
    """Corner k (bits: +right, +up', +direction) of an oriented box whose face on the
    -direction side is scaled by `back` (1: a box; 0: a pyramid with its apex there)."""
    f = 1.0 if k & 4 else back
    sx = ex * f if k & 1 else -ex * f
    sy = ey * f if k & 2 else -ey * f
    sz = ez if k & 4 else -ez
    return (px + rx * sx + ux * sy + dx * sz, py + ry * sx + uy * sy + dy * sz,
            pz + rz * sx + uz * sy + dz * sz)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def box_bounds(px, py, pz, dx, dy, dz, rx, ry, rz, ex, ey, ez, near, tan_x, tan_y, width, height,
               back=1.0):
    """Bounds of the oriented box's part in front of the near plane: its corners in front, and
    where its 12 edges cross the plane z = -near (the section of a convex polytope by a plane
    is the hull of those crossings), projected; empty (x0 > x1) when nothing is in front.
    Half extents grow by the float32 margin of the GPU test.  `back` < 1 shrinks the
    -direction face (Mikkelsen's OBB with a scaled face, for cones)."""
    ux, uy, uz = ry * dz - rz * dy, rz * dx - rx * dz, rx * dy - ry * dx      # up' = right x dir
    # the GPU's float32 dot products err by a few ulp of |P - position| (up to the largest
    # extent) and of the stored centre: grow every extent by a margin of both
    pad = (RADIUS_REL_MARGIN + 8.0 * F32_EPS) * max(ex, ey, ez) + \
        4.0 * F32_EPS * math.sqrt(px * px + py * py + pz * pz)
    ex, ey, ez = ex + pad, ey + pad, ez + pad
    x0 = y0 = d0 = math.inf
    x1 = y1 = d1 = -math.inf
    zn = -near
    for k in range(8):
        ax, ay, az = _corner(k, px, py, pz, rx, ry, rz, ux, uy, uz, dx, dy, dz, ex, ey, ez, back)
        if az <= zn:
            x0, x1, y0, y1, d0, d1 = _box_point(x0, x1, y0, y1, d0, d1, ax, ay, az,
                                                tan_x, tan_y, width, height)
        for bit in (1, 2, 4):          # the edges from corner k along each axis, once each
            j = k | bit
            if j == k:
                continue
            bx, by, bz = _corner(j, px, py, pz, rx, ry, rz, ux, uy, uz, dx, dy, dz, ex, ey, ez, back)
            if (az - zn) * (bz - zn) < 0.0:
                t = (zn - az) / (bz - az)
                x0, x1, y0, y1, d0, d1 = _box_point(x0, x1, y0, y1, d0, d1, ax + (bx - ax) * t,
                                                    ay + (by - ay) * t, zn, tan_x, tan_y, width, height)
    return (x0 - PIXEL_MARGIN, x1 + PIXEL_MARGIN, y0 - PIXEL_MARGIN, y1 + PIXEL_MARGIN, d0, d1)


@numba.njit(inline="always")
def shape_bounds(t, px, py, pz, dx, dy, dz, rx, ry, rz, radius, cos_outer, length, ex, ey, ez,
                 cx, cy, cz, r, near, tan_x, tan_y, width, height):
    """(x0, x1, y0, y1, d_lo, d_hi) of a light: its culling sphere's rectangle and depth
    range, tightened by its shape's own cover (a spot's cone, a capsule's swept sphere, a
    box's corners)."""
    x0, x1, y0, y1 = pixel_rect(cx, cy, cz, r, near, tan_x, tan_y, width, height)
    d0, d1 = -cz - r, -cz + r
    if sphere_only(t, cos_outer, length):
        return x0, x1, y0, y1, d0, d1
    if t == LIGHT_SPOT:
        a0, a1, b0, b1, e0, e1 = spot_pyramid(px, py, pz, dx, dy, dz, radius, cos_outer,
                                              near, tan_x, tan_y, width, height)
    elif t == LIGHT_CAPSULE:
        a0, a1, b0, b1, e0, e1 = capsule_pieces(px, py, pz, dx, dy, dz, radius, length,
                                                near, tan_x, tan_y, width, height)
    else:
        a0, a1, b0, b1, e0, e1 = box_bounds(px, py, pz, dx, dy, dz, rx, ry, rz, ex, ey, ez,
                                            near, tan_x, tan_y, width, height)
    return max(x0, a0), min(x1, a1), max(y0, b0), min(y1, b1), max(d0, e0), min(d1, e1)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def shape_bounds_call(t, px, py, pz, dx, dy, dz, rx, ry, rz, radius, cos_outer, length, ex, ey, ez,
                      cx, cy, cz, r, near, tan_x, tan_y, width, height):
    """shape_bounds() as a plain call, for the pack's scalar slow path: numba inlines an
    inline="always" function by copying its IR at every call site, and shape_bounds' tree
    of inlined covers (eight box corners, the cone, the capsule) made the pack's two kernels
    take 30-80 s each to compile (cold test runs, a fresh clone); called, it compiles once,
    and the common path's SIMD helpers stay inlined.  The covers it reaches (pixel_rect,
    spot_pyramid, capsule_pieces, box_bounds) are plain calls too, for the same reason: as
    inlined IR (pixel_rect twice, box_bounds twice, project_axis four times) this function
    alone took 12 s to compile cold, as calls 4 s.  The same IEEE operations either way."""
    return shape_bounds(t, px, py, pz, dx, dy, dz, rx, ry, rz, radius, cos_outer, length, ex, ey, ez,
                        cx, cy, cz, r, near, tan_x, tan_y, width, height)
