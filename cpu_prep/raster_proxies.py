"""raster's proxies (Drobot 2017, rasterization based culling): the canonical proxy meshes and
each visible light's RasterProxy record.  numpy only, no OpenGL: app/techniques/raster.py
draws them, app/techniques/raster/raster_proxy.vert places and scales them (docs/raster.md: the design).

    proxies (built once per shape, placed and scaled per light in raster_proxy.vert):
      sphere   icosphere (80 triangles) circumscribing the point light's sphere
      cone     cone cap for spots: apex + 12-sided cone + 3 rings of spherical cap (72 tris)
      capsule  two 3-ring hemispheres joined by a 12-sided cylinder (144 triangles)
      box      the light's own box (12 triangles)
    per light (RASTER_PROXY): margin M, the cone's apex shift and cap angle, circumscribed
      radius, the light's depth span (cpu_prep's conservative range), which faces to draw

A known limit: the slides' production proxies are "tightly cut to level geometry (~300
tris)", triangulated from each stationary light's conservative shadow map.  This lab
simulates no shadows (a light lights its whole volume), so a proxy cut by occluders would
drop pixels that light reaches: the proxies stay the light's own shape.

Why a proxy holds every pixel its light reaches (docs/raster.md, "Why it is exact"): M
covers float32 rounding of the proxy's vertices and of P (MARGIN_REL of the light's distance
plus extent: 30x the GPU test's own error) and the rasterizer's sub-pixel vertex snapping
(MARGIN_PX of footprint at the proxy's far end, 8 x llvmpipe's 1/256-pixel grid).  Every
mesh face plane lies at least the volume's grown radius from its centre (icosphere 0.934,
cylinders cos(15 deg), a spot's cap per light); a spot's cone is widened by moving its apex
back by M / sin(outer) (cones too narrow for that fall back to the sphere).  MSAA at half
resolution grows M by the sample-to-pixel-centre distance (msaa_dilation).  A proxy within
NEAR_SIDE of the near plane is drawn as back faces; a light whose margin would be a large
part of its depth (1x1 screens, huge fields of view) gets an icosphere around both it and
the eye, back faces.
"""
from __future__ import annotations

import math

import numpy as np

from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_SPOT

PROXY_SPHERE, PROXY_CONE, PROXY_CAPSULE, PROXY_BOX = 0, 1, 2, 3
PROXY_NAMES = ("sphere", "cone", "capsule", "box")      # the ids' names (PROXY_* in GLSL)

# ---- margins (module doc) ----------------------------------------------------------------
MARGIN_REL = 3e-5            # of (|light position| + extent + near): float32 rounding
MARGIN_PX = 1.0 / 32.0       # pixels of footprint: sub-pixel vertex snapping (1/256 px)
NEAR_SIDE = 1e-3             # proxies within this relative distance of the near plane: back faces

# ---- proxy meshes (canonical, unit; the vertex shader places and scales them) -------------
SIDES = 12                   # azimuth segments of cones, cylinders and caps
RINGS = 3                    # polar bands of a cap (a spot's, a capsule's hemisphere)


def _icosphere(level: int) -> tuple[np.ndarray, np.ndarray]:
    t = (1.0 + 5.0 ** 0.5) / 2.0
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
         (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    vs = [np.asarray(p, np.float64) / np.linalg.norm(p) for p in v]
    for _ in range(level):
        mids: dict = {}

        def mid(a, b):
            k = (min(a, b), max(a, b))
            if k not in mids:
                m = vs[a] + vs[b]
                vs.append(m / np.linalg.norm(m))
                mids[k] = len(vs) - 1
            return mids[k]
        nf = []
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    return np.asarray(vs), np.asarray(f)


def _flipped(tris: np.ndarray, inside) -> np.ndarray:
    """Which triangles (T, 3, 3) are clockwise seen from outside (`inside`: a point inside,
    or (T, 3) points)."""
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    return np.einsum("ij,ij->i", n, tris[:, 0] - inside) < 0


def _swap_corners(rows: np.ndarray, flip: np.ndarray) -> np.ndarray:
    """Rows (T, 3, k) with corners 1 and 2 swapped where `flip`."""
    out = rows.copy()
    out[flip, 1], out[flip, 2] = rows[flip, 2], rows[flip, 1]
    return out


def _outward(tris: np.ndarray, inside) -> np.ndarray:
    """Triangles (T, 3, 3) reordered counter-clockwise seen from outside."""
    return _swap_corners(tris, _flipped(tris, inside))


def plane_distance(a, b, c) -> np.ndarray:
    """Distance from the origin to the plane through points a, b, c ((..., 3) arrays)."""
    n = np.cross(b - a, c - a)
    return np.abs(np.einsum("...k,...k->...", n, a)) / np.linalg.norm(n, axis=-1)


def _unit(theta, phi):
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)


def cap_plane_distance(theta_r) -> np.ndarray:
    """Smallest distance from the centre to the face planes of a unit-sphere cap of RINGS
    polar bands over [0, theta_r] and SIDES azimuth segments (the cap of the cone and
    capsule proxies): bands are isosceles trapezoids (triangles at the pole), planar."""
    theta_r = np.asarray(theta_r, np.float64)[..., None]
    j = np.arange(RINGS, dtype=np.float64)
    t0, t1 = theta_r * j / RINGS, theta_r * (j + 1) / RINGS
    dphi = 2.0 * math.pi / SIDES
    z = np.zeros_like(t0)
    a = _unit(t1, z)
    b = _unit(t1, z + dphi)
    c = np.where((j == 0)[..., None], _unit(z, z), _unit(t0, z))   # the pole, or the band's top
    return plane_distance(a, b, c).min(-1)


def _cap_vertex(j: int, i: int) -> tuple[float, float, float]:
    """(cos phi, sin phi, polar fraction) of cap ring j (0 = pole), azimuth step i."""
    phi = 2.0 * math.pi * (i % SIDES) / SIDES
    return math.cos(phi), math.sin(phi), j / RINGS


def _cap_faces() -> list:
    """Faces of a cap as (ring, step) vertex pairs, outward for a cap around +z."""
    faces = []
    for i in range(SIDES):
        faces.append(((0, 0), (1, i), (1, i + 1)))
        for j in range(1, RINGS):
            faces.append(((j, i), (j + 1, i), (j + 1, i + 1)))
            faces.append(((j, i), (j + 1, i + 1), (j, i + 1)))
    return faces


def _sphere_mesh() -> tuple[np.ndarray, float]:
    v, f = _icosphere(1)
    tris = _outward(v[f], np.zeros(3))
    k = 1.0 / plane_distance(tris[:, 0], tris[:, 1], tris[:, 2]).min()
    out = np.zeros((len(tris) * 3, 4), np.float32)
    out[:, :3] = tris.reshape(-1, 3)
    return out, k


def _cone_mesh() -> np.ndarray:
    """Attributes (cos phi, sin phi, polar fraction t, apex flag): cap vertex at polar angle
    t * theta_r, or the (moved back) apex.  Winding checked on a sample placement."""
    rows = []
    theta_r, b = 1.2, 0.1

    def at(a):
        if a[3]:
            return np.array([0.0, 0.0, -b])
        cp, sp, t = a[:3]
        s = math.sin(t * theta_r)
        return np.array([s * cp, s * sp, math.cos(t * theta_r)])
    for face in _cap_faces():
        rows.append([(*_cap_vertex(j, i), 0.0) for j, i in face])
    for i in range(SIDES):
        rows.append([(0.0, 0.0, 0.0, 1.0), (*_cap_vertex(RINGS, i + 1), 0.0), (*_cap_vertex(RINGS, i), 0.0)])
    rows = np.asarray(rows, np.float64)                        # (T, 3, 4)
    place = np.asarray([[at(a) for a in tri] for tri in rows])
    out = _swap_corners(rows, _flipped(place, np.array([0.0, 0.0, 0.3])))
    return out.reshape(-1, 4).astype(np.float32)


def _capsule_mesh() -> tuple[np.ndarray, float]:
    """Attributes (unit x, y, z, end): a vertex of the hemisphere around segment end `end`
    (+1 / -1), placed at end * length / 2 along the axis.  Hemispheres of RINGS bands,
    a SIDES-sided cylinder between their equators."""
    def cap(sign):
        tris = []
        for face in _cap_faces():
            tri = []
            for j, i in face:
                cp, sp, t = _cap_vertex(j, i)
                th = t * math.pi / 2
                tri.append((math.sin(th) * cp, math.sin(th) * sp, sign * math.cos(th), sign))
            tris.append(tri)
        return tris
    tris = cap(1.0) + cap(-1.0)
    for i in range(SIDES):
        a, b = _cap_vertex(RINGS, i), _cap_vertex(RINGS, i + 1)
        top = [(a[0], a[1], 0.0, 1.0), (b[0], b[1], 0.0, 1.0)]
        bot = [(a[0], a[1], 0.0, -1.0), (b[0], b[1], 0.0, -1.0)]
        tris += [[top[0], bot[0], bot[1]], [top[0], bot[1], top[1]]]
    rows = np.asarray(tris, np.float64)
    place = rows[..., :3] + np.stack([np.zeros_like(rows[..., 3])] * 2 + [rows[..., 3]], -1)
    out = _swap_corners(rows, _flipped(place, np.zeros(3)))
    k = 1.0 / min(float(cap_plane_distance(math.pi / 2)), math.cos(math.pi / SIDES))
    return out.reshape(-1, 4).astype(np.float32), k


def _box_mesh() -> np.ndarray:
    """Corners (+-1, +-1, +-1) on the light's axes (right, up' = right x dir, dir): a
    left-handed frame (right x up' = -dir), so the winding is set in it."""
    c = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = np.asarray([c[[q[0], q[1], q[2]]] for q in quads] + [c[[q[0], q[2], q[3]]] for q in quads])
    mirror = np.array([1.0, 1.0, -1.0])                 # into the left-handed frame and back
    tris = _outward(tris * mirror, np.zeros(3)) * mirror
    out = np.zeros((len(tris) * 3, 4), np.float32)
    out[:, :3] = tris.reshape(-1, 3)
    return out


SPHERE_MESH, K_SPHERE = _sphere_mesh()
CONE_MESH = _cone_mesh()
CAPSULE_MESH, K_CAPSULE = _capsule_mesh()
BOX_MESH = _box_mesh()
MESHES = (SPHERE_MESH, CONE_MESH, CAPSULE_MESH, BOX_MESH)


def _with_corners(mesh: np.ndarray) -> np.ndarray:
    """(V, 12): each vertex followed by its triangle's other two corners (in order), so the
    vertex shader can bound the triangle's depth (the cluster rasterizer)."""
    t = mesh.reshape(-1, 3, 4)
    rot = lambda k: np.roll(t, -k, axis=1)
    return np.concatenate([t, rot(1), rot(2)], axis=2).reshape(-1, 12).astype(np.float32)


MESHES_CORNERS = tuple(_with_corners(m) for m in MESHES)
CONE_APEX_MAX = 1.0 / 16.0    # a spot's apex moves back at most this fraction of its radius
# cap angles stay below 90 deg + asin(1/16): the largest cap factor a cone proxy can need
K_CONE_MAX = 1.0 / float(cap_plane_distance(math.pi / 2 + math.asin(CONE_APEX_MAX) + 0.05))

# One visible light's proxy (sorted order), as the vertex and fragment shaders read it.
RASTER_PROXY = np.dtype([
    ("radius", np.float32),       # sphere / capsule / cone: vertex radius (circumscribing)
    ("margin", np.float32),       # M: the volume's growth (box extents grow by it)
    ("apex_back", np.float32),    # cone: apex moved back along -direction
    ("cap_angle", np.float32),    # cone: polar angle of the cap's rim (radians)
    ("depth_span", np.float32, 2),  # the light's conservative view-depth range
    ("shape", np.uint32),         # the proxy mesh drawn (PROXY_*)
    ("back", np.uint32),          # 1: drawn as back faces (eye inside / near plane)
])
assert RASTER_PROXY.itemsize == 32


def msaa_dilation(positions) -> tuple[np.ndarray, float]:
    """(pixel offsets (4, 2) int32 of each sample's full-res pixel inside its low-res pixel,
    dilation in full-res pixels: the farthest a sample sits from that pixel's centre).
    Needs one sample per quadrant (refused otherwise)."""
    pos = np.asarray(positions, np.float64)
    quad = np.floor(pos * 2.0).astype(np.int32).clip(0, 1)
    if len({tuple(q) for q in quad}) != len(pos):
        raise ValueError(f"MSAA sample positions {pos.tolist()} are not one per quadrant")
    d = np.linalg.norm(pos * 2.0 - (quad + 0.5), axis=1).max()
    return quad, float(d)


def _margins(dist, reach, d0, grow, cam, dilation_px: float) -> tuple[np.ndarray, np.ndarray]:
    """(M, ok) per light: the growth covering float rounding (MARGIN_REL) and vertex snapping
    plus `dilation_px` at the proxy's far end; ok False where the footprint is comparable to
    the light (no margin holds it: the eye ball of proxy_params)."""
    # M = a + c * z_far, z_far = the proxy's far depth <= d0 + grow * (reach + M)
    footprint = 2.0 * cam.tan_half_y / cam.height          # metres per pixel per metre of depth
    c = (MARGIN_PX + dilation_px) * footprint
    a = MARGIN_REL * (dist + reach + cam.near)
    ok = c * grow < 0.5
    M = (a + c * np.maximum(d0 + grow * reach, cam.near)) / np.where(ok, 1.0 - c * grow, 1.0)
    return M, ok


def _fit_cones(shape, R, cos_o, M) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(apex shift b, vertex radius rho, cap angle theta_r) of the spots' cone proxies; a
    spot too narrow for its margin becomes a sphere in `shape`."""
    # spots: the cone grown by M lies in the cone with its apex moved back by M / sin(outer)
    spot = shape == PROXY_CONE
    ca = np.clip(cos_o, 0.0, 1.0)
    sa = np.sqrt(1.0 - ca * ca)
    sa2 = np.maximum(sa, M / (CONE_APEX_MAX * np.maximum(R, 1e-30)))
    as_sphere = spot & (sa2 > 1.0)
    shape[as_sphere] = PROXY_SPHERE
    spot &= ~as_sphere
    alpha = np.where(sa2 > sa, np.arcsin(np.minimum(sa2, 1.0)), np.arccos(ca))
    b = np.where(spot, M / np.maximum(sa2, 1e-30), 0.0)
    R1 = R + M
    # lateral faces: a SIDES-gon cone through the rim circumscribes the cone of `alpha`
    gamma = np.arctan2(np.sin(alpha), np.cos(alpha) * math.cos(math.pi / SIDES))
    rho = R1.copy()
    theta_r = np.zeros(len(shape))
    # a spot's cap depends on its own rho alone: each round refits the spots the last one
    # grew (a spot's need is the same while its rho is), the others keep theirs
    need, refit = np.zeros(len(shape)), np.nonzero(spot)[0]
    for _ in range(8):
        theta_r = gamma + np.arcsin(np.clip(np.sin(gamma) * b / rho, -1.0, 1.0))
        need[refit] = R1[refit] / cap_plane_distance(theta_r[refit])
        short = spot & (rho < need)
        if not short.any():
            break
        rho = np.where(short, need * (1.0 + 1e-12), rho)
        refit = np.nonzero(short)[0]
    else:
        shape[spot & (rho < need)] = PROXY_SPHERE          # (never seen) fall back: sphere
    return b, rho, theta_r


def proxy_params(pl, cam, dilation_px: float = 0.0) -> np.ndarray:
    """RASTER_PROXY per visible light (float64 arithmetic, stored float32 rounded outwards
    where it grows the proxy).  `dilation_px`: extra growth in full-res pixels (MSAA)."""
    n = len(pl)
    out = np.zeros(n, RASTER_PROXY)
    if n == 0:
        return out
    g = pl.gpu
    pos = g["pos_radius"][:, :3].astype(np.float64)
    R = g["pos_radius"][:, 3].astype(np.float64)
    ext = g["extent_length"][:, :3].astype(np.float64)
    half = 0.5 * g["extent_length"][:, 3].astype(np.float64)
    t = pl.type
    dist = np.linalg.norm(pos, axis=1)
    d0 = -pos[:, 2]
    shape = np.full(n, PROXY_SPHERE, np.uint32)
    shape[t == LIGHT_CAPSULE] = PROXY_CAPSULE
    shape[t == LIGHT_BOX] = PROXY_BOX
    shape[t == LIGHT_SPOT] = PROXY_CONE
    reach = np.where(t == LIGHT_CAPSULE, R + half, R)
    reach = np.where(t == LIGHT_BOX, np.linalg.norm(ext, axis=1), reach)
    grow = np.select([shape == PROXY_SPHERE, shape == PROXY_CAPSULE, shape == PROXY_BOX],
                     [K_SPHERE, K_CAPSULE, math.sqrt(3.0)], K_CONE_MAX)
    M, ok = _margins(dist, reach, d0, grow, cam, dilation_px)
    b, rho, theta_r = _fit_cones(shape, R, g["dir_cos_outer"][:, 3].astype(np.float64), M)
    spot = shape == PROXY_CONE
    R1 = R + M
    radius = np.select([shape == PROXY_SPHERE, shape == PROXY_CAPSULE], [K_SPHERE * R1, K_CAPSULE * R1],
                       np.where(spot, rho, 0.0))
    # the proxy's bounding radius around the light position, and which faces to draw
    bound = np.select([shape == PROXY_SPHERE, shape == PROXY_CAPSULE, shape == PROXY_BOX],
                      [radius, half + radius, np.linalg.norm(ext + M[:, None], axis=1)],
                      np.maximum(rho, b))
    back = d0 - bound <= cam.near * (1.0 + NEAR_SIDE)
    # no usable margin (footprint comparable to the light): an icosphere holding the eye and
    # the whole volume, back faces: every pixel whose depth is in the span
    eye_ball = ~ok
    shape[eye_ball] = PROXY_SPHERE
    radius = np.where(eye_ball, K_SPHERE * ((2.0 * dist + reach) * (1.0 + 1e-3) + cam.near), radius)
    back |= eye_ball
    up = lambda x: np.nextafter(x.astype(np.float32), np.float32(np.inf))
    out["radius"] = up(radius)
    out["margin"] = up(M)
    out["apex_back"] = up(b)
    out["cap_angle"] = np.where(spot, theta_r, 0.0).astype(np.float32)
    out["depth_span"][:, 0] = pl.depth_lo
    out["depth_span"][:, 1] = pl.depth_hi
    out["shape"] = shape
    out["back"] = back
    return out


__all__ = ["PROXY_SPHERE", "PROXY_CONE", "PROXY_CAPSULE", "PROXY_BOX", "PROXY_NAMES", "MESHES",
           "MESHES_CORNERS", "RASTER_PROXY", "plane_distance", "cap_plane_distance",
           "msaa_dilation", "proxy_params"]
