"""raster (Drobot 2017, "Improved Culling for Tiled and Clustered Rendering", rasterization
based culling): every visible light is a proxy mesh, drawn instanced against the scene's
depth; each fragment that survives the early depth test and the shader's depth-bounds test
ORs its light's bit into the flat bit array of its 8x8 tile (zbin's layout), and the frame
is shaded by zbin's loop (glsl/shade_zbin.comp, any zbin_variant) over those bits.  With
`cluster`, the slides' cluster rasterizer marks clusters instead (MARK / WALK, below).

    proxies (built once per shape, placed and scaled per light in raster_proxy.vert):
      sphere   icosphere (80 triangles) circumscribing the point light's sphere
      cone     cone cap for spots: apex + 12-sided cone + 3 rings of spherical cap (72 tris)
      capsule  two 3-ring hemispheres joined by a 12-sided cylinder (144 triangles)
      box      the light's own box (12 triangles)
    per light (RasterProxy, CPU): margin M, the cone's apex shift and cap angle, circumscribed
      radius, the light's depth span (cpu_prep's conservative range), which faces to draw
    A known limit: the slides' production proxies are "tightly cut to level geometry (~300
    tris)", triangulated from each stationary light's conservative shadow map.  This lab
    simulates no shadows (a light lights its whole volume), so a proxy cut by occluders
    would drop pixels that light reaches: the proxies stay the light's own shape.

    passes: [stats twin, untimed] fill -> mark (per proxy mesh and side) -> shade
      fill   the scene's depth into the technique's own 32-bit depth target, from the
             G-buffer's linear depth: reversed, far plane at infinity (window depth
             near / depth, affine on screen, well conditioned in float32)
      front  eye outside the proxy, proxy wholly past the near plane: front faces, depth
             test GREATER_EQUAL (reversed: proxy in front of the scene), then the shader:
             scene depth in the light's span (the slides' depth bounds test, emulated) and
             proxy depth <= scene depth, exactly, in linear depth
      back   eye inside the proxy, or the proxy reaching the near plane (its clipped front
             faces would be lost): back faces, LESS_EQUAL (the proxy behind the scene), span
             and proxy depth >= scene depth; no far plane to clip them
      stencil option, front group: per light, front faces set the stencil where they pass,
             then back faces pass where it is set, mark and clear it: the slides' two-pass,
             pixel-perfect test [THI11] (two draws per light)
      tile   bits[(ty * tiles_x + tx) * words + N / 32] |= 1 << N % 32  (N: sorted light)

The slides' tile rasterizer table is the option `raster_variant`:
  0 atomic     full resolution, one atomicOr per marking fragment
  1 + 4xMSAA   proxies drawn into a half-resolution 4-sample target whose samples hold the
               scene depth of the full-resolution pixels (the fill pass writes them per
               sample: a console aliases one buffer as the other); one fragment per low-res
               pixel, each covered sample marks its own pixel's tile
  2 + compaction  WaveCompactValue over the fragment subgroup (GL_ARB_shader_ballot): only
               the first lane per distinct bit issues the atomic; without native ballot the
               variant issues every atomic (fragment shaders have no shared memory)
  3 both
Every culling pass is timed, the fill pass too (a console gets it free by aliasing); the
atomics, fragments and per-light marks of a frame are counted by an untimed twin of the
culling passes (`raster_stats`), so the counters cost the timed passes nothing; the twin
also takes each tile's min / max scene depth first (raster_tile_depth.comp: the meta's
occlusion figures below, and the cluster rasterizer's bound).

Cluster rasterizer (`cluster` 1 or 2; raster_cluster.frag; clusters of cluster_tile px x
cluster_slices listing-4 slices; no depth test, no fill): MARK, back faces of the proxies the
eye is outside of mark the clusters their triangle conservatively touches in the pixel's
column (depth from derivatives, clamped to the triangle's vertex depths, as the slides give
it); WALK, their front faces then walk from their conservative depth to the column's
farthest MARK; proxies holding the eye walk their back faces from the near plane.  Shaded
by a per-cluster loop over the cluster's bits (raster_shade_cluster.comp).  All variants.

    passes: [stats twin, untimed] tile depth (cluster 1) -> mark (per proxy mesh) -> walk
            -> inside -> shade
      tile depth  each tile's min / max scene depth (raster_tile_depth.comp): the slides'
                  "conservative depth from prepass to early reject"
      mark / walk / inside   within the slices [near, far] of that min / max (cluster 1)

`cluster` 1 bounds MARK and WALK by the depth prepass; 2 does not (the slides' rasterizer
with no prepass).  Both set the same bits in every cluster a pixel reads, so they evaluate
the same lights (a pixel reads only the cluster of its own depth's slice, which lies in its
tile's [near, far]); the bound saves the marks, atomics and walk steps of the clusters no
pixel reads (in front of and behind the tile's surfaces, and every cluster of a tile with
no geometry).  The cluster mode's evaluations exceed the tile mode's because of its XY
size: a cluster_tile (32 px, the slides' 60 x 40 at 1080p) column holds 16 of the tile
mode's 8x8 tiles, and marks every cluster a light's volume passes through, where a tile is
marked only by lit surface pixels.

Why it is exact (every pixel whose G-buffer position P a light affects gets that light's
bit in its tile or cluster; README "What the lab guarantees"):
  * A fragment is generated only where the proxy covers a pixel CENTRE, which is exactly
    where the G-buffer sampled P (P lies on that pixel's centre ray up to float rounding).
    So a full-resolution proxy that contains the light's volume grown by a margin M covers
    every pixel whose P is inside: the point X of the centre ray at P's depth is inside the
    proxy.  M (cpu side, per light) covers float32 rounding of the proxy's vertices and of P
    (3e-5 of the light's distance plus extent: 30x the GPU test's own error) and the
    rasterizer's sub-pixel vertex snapping (1/32 pixel of footprint at the proxy's far end,
    8 x llvmpipe's 1/256-pixel grid).  The proxies circumscribe their volumes: every mesh
    face plane lies at least the volume's (grown) radius from its centre, computed from the
    mesh (icosphere 0.934, cylinders cos(15 deg), a spot's cap per light); a spot's cone is
    widened by moving its apex back by M / sin(outer) (the cone grown by M lies inside;
    cones too narrow for that fall back to the sphere).  Tests check containment of sampled
    grown volumes and convexity of every proxy, every shape.
  * Depth: the proxy is convex, so along the centre ray a point inside lies behind every
    front-facing plane and before every back-facing one, even where the rasterizer
    extrapolates a face's depth a fraction of a pixel outside the face.  The G-buffer's own
    depth buffer is NOT used: llvmpipe's interpolation of window depth on huge triangles
    errs by 2e-4 near 1.0 (a floor 1e5 wide: 11 cm at 7.5 m), which rejected a lit pixel
    (test_hard_cases' slice boundaries).  The fill pass writes near / depth from
    g_position's linear depth instead; the proxies' window depth moves by 2^-16 relative
    and 2^-20 absolute towards passing; the shader redoes the comparison exactly in linear
    depth (1 / gl_FragCoord.w, affine on screen) with a 1e-5 relative slack.
  * Near plane: a proxy that reaches the near plane loses its clipped front faces, so it is
    drawn like the eye-inside case (back faces); the choice is conservative (proxy bound
    sphere within 1e-3 of near).  The far plane is at infinity: nothing else clips.
  * MSAA at half resolution: llvmpipe's 4 samples sit one per quadrant of the low-res pixel
    (standard positions, queried), so sample k stands for the full-res pixel of its
    quadrant; the proxy is grown by the distance between a sample and that pixel's centre
    (0.354 full-res pixels, plus the snapping margin) times the footprint at its far end, so
    every full-res centre inside the volume has its sample covered, passing the depth test
    (the fill wrote that pixel's scene depth into it) and the shader's test at the grown
    proxy's depth at that sample (from the derivatives of 1 / depth: llvmpipe's
    interpolateAtSample returns the pixel centre's value).  Any tile size, odd ones too.
  * Compaction keys on the bit itself (word * 32 + bit): the slides key on the word alone,
    which drops bits when one wave mixes lights of one word; instanced draws do mix them.
  * A light whose margin would be a large part of its depth (a pixel's footprint at that
    depth comparable to the light: 1x1 screens, huge fields of view) gets an icosphere
    around both it and the eye, drawn as back faces: it then marks every tile whose scene
    depth lies in its span.
  * The cluster depth bound (`cluster` 1): clusters outside a tile's slices [near, far]
    (of its min / max scene depth, moved out by the shader slack) are never read, so it is
    exact if every read cluster keeps every bit the unbounded MARK / WALK gives it.  The
    unbounded WALK from front slice s0 goes to F, the farthest MARK at or past s0 (or to
    the last slice if there is none).  Bounded, a MARK range [a, b] meeting [near, far]
    writes its part inside; one wholly in front writes b alone, one wholly behind far + 1
    alone (clusters no pixel reads); a WALK with s0 > far walks nothing (all it would mark
    lies behind), else searches down from far + 1 and walks [max(s0, near), min(F', far)].
    F in [near, far] is written, so F' = F; F behind far leaves far or far + 1 marked, so
    F' >= far; F in front of near leaves b = F marked, so the walk marks nothing (nor did
    the unbounded one, inside); no MARK at or past s0 leaves none there bounded either (the
    written clusters are MARKs' own or far + 1 from a MARK past s0), so both walk to the
    end.  Eye-inside walks are cut to [near, far]; a tile with no geometry is skipped.
Occlusion comes free: a light whose volume reaches no visible surface marks nothing.  The
meta stats count those (`unmarked_lights`, of the lights whose CPU rectangles touch the
screen) and the ones among them that a tile depth-bounds test (tiled's per-tile min/max
depth over the CPU rectangle) would still keep (`occluded_lights`): removed by occlusion
and per-pixel depth alone.  `raster_marks` / `rect_marks`: (tile or cluster, light) pairs
marked, against the CPU boxes' pairs (zbin's bits, clustered's cells).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
import math

import numpy as np

from cpu_prep import frame as cpuframe, grid as gridmod, layouts, limits, zbin as zb
from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_SPOT

from ..pipeline.gbuffer import column_major
from ..pipeline.passes import (WAVE_STATS, Buffer, Draw, HostStep, Pass, StencilStep, Target,
                               image_groups)
from .base import Technique, prepare, shading_passes
from .options import option
from .zbin import (VARIANTS as SHADE_VARIANTS, ShadingOptions, _wave_counters, add_bit_words,
                   attach_zbins, tile_boxes, variant_flags)

VARIANTS = ("atomic", "atomic + 4xMSAA", "atomic + compaction", "atomic + compaction + 4xMSAA")
PROXY_SPHERE, PROXY_CONE, PROXY_CAPSULE, PROXY_BOX = 0, 1, 2, 3
PROXY_NAMES = ("sphere", "cone", "capsule", "box")

# ---- margins (module doc) ----------------------------------------------------------------
MARGIN_REL = 3e-5            # of (|light position| + extent + near): float32 rounding
MARGIN_PX = 1.0 / 32.0       # pixels of footprint: sub-pixel vertex snapping (1/256 px)
NEAR_SIDE = 1e-3             # proxies within this relative distance of the near plane: back faces
DEPTH_BIAS_REL = 2.0 ** -16  # proxy window depth n / d moved towards passing the hardware
DEPTH_BIAS_ABS = 2.0 ** -20  #   test by this relative and absolute amount
FRONT_TEST, BACK_TEST = "greater_equal", "less_equal"   # reversed depth: window depth n / d
SHADER_SLACK = 1e-5          # relative slack of the shader's depth comparisons
MSAA_SAMPLES = 4

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


def _outward(tris: np.ndarray, inside) -> np.ndarray:
    """Triangles (T, 3, 3) reordered counter-clockwise seen from outside (`inside`: a point
    inside, or (T, 3) points)."""
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    flip = np.einsum("ij,ij->i", n, tris[:, 0] - inside) < 0
    out = tris.copy()
    out[flip, 1], out[flip, 2] = tris[flip, 2], tris[flip, 1]
    return out


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
    rows, place = [], []
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
    flip = _outward(place, np.array([0.0, 0.0, 0.3]))
    out = rows.copy()
    swap = ~np.all(np.isclose(flip, place), axis=(1, 2))
    out[swap, 1], out[swap, 2] = rows[swap, 2], rows[swap, 1]
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
    flip = _outward(place, np.zeros(3))
    swap = ~np.all(np.isclose(flip, place), axis=(1, 2))
    out = rows.copy()
    out[swap, 1], out[swap, 2] = rows[swap, 2], rows[swap, 1]
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
CLUSTER_MODES = {"mark": 3, "walk": 4, "inside": 5}    # raster_cluster.frag's u_mode
CLUSTER_BOUNDED = 1             # `cluster`: 1 MARK / WALK within each tile's scene depth, 2 not
CLUSTER_NAMES = ("tiles", "clusters", "clusters, no depth bound")
# the options cluster mode does not read: zbin's shading loop's, the tile rasterizer's own
CLUSTER_IGNORES = ("zbin_variant", "zbins", "printed_mask", "native_wave", "bit_tile", "stencil",
                   "early_depth")
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
STRUCTS_GLSL = layouts.glsl_struct("RasterProxy", RASTER_PROXY) + "\n" + "\n".join(
    f"#define PROXY_{n.upper()} {i}" for i, n in enumerate(PROXY_NAMES)) + \
    f"\n#define DEPTH_BIAS_REL {DEPTH_BIAS_REL!r}\n#define DEPTH_BIAS_ABS {DEPTH_BIAS_ABS!r}" \
    f"\n#define SHADER_SLACK {SHADER_SLACK!r}\n"


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
    cos_o = g["dir_cos_outer"][:, 3].astype(np.float64)
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
    # M = a + c * z_far, z_far = the proxy's far depth <= d0 + grow * (reach + M)
    footprint = 2.0 * cam.tan_half_y / cam.height          # metres per pixel per metre of depth
    c = (MARGIN_PX + dilation_px) * footprint
    a = MARGIN_REL * (dist + reach + cam.near)
    ok = c * grow < 0.5
    M = (a + c * np.maximum(d0 + grow * reach, cam.near)) / np.where(ok, 1.0 - c * grow, 1.0)
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
    theta_r = np.zeros(n)
    for _ in range(8):
        theta_r = gamma + np.arcsin(np.clip(np.sin(gamma) * b / rho, -1.0, 1.0))
        need = R1 / cap_plane_distance(theta_r)
        short = spot & (rho < need)
        if not short.any():
            break
        rho = np.where(short, need * (1.0 + 1e-12), rho)
    else:
        shape[spot & (rho < need)] = PROXY_SPHERE          # (never seen) fall back: sphere
    spot = shape == PROXY_CONE
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


def basis(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(e1, e2) with (e1, e2, f) right-handed orthonormal (Duff et al. 2017), as the vertex
    shader builds it."""
    s = np.where(f[..., 2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (s + f[..., 2])
    b = f[..., 0] * f[..., 1] * a
    e1 = np.stack([1.0 + s * f[..., 0] ** 2 * a, s * b, -s * f[..., 0]], -1)
    e2 = np.stack([b, s + f[..., 1] ** 2 * a, -f[..., 1]], -1)
    return e1, e2


def proxy_vertices(light, proxy) -> np.ndarray:
    """(V, 3) float64 view-space vertices of one light's proxy (GPU_LIGHT and RASTER_PROXY
    records), as glsl/raster_proxy.vert places them: for tests and tools."""
    shape = int(proxy["shape"])
    mesh = MESHES[shape].astype(np.float64)
    p = light["pos_radius"][:3].astype(np.float64)
    f = light["dir_cos_outer"][:3].astype(np.float64)
    M, r = float(proxy["margin"]), float(proxy["radius"])
    if shape == PROXY_SPHERE:
        return p + r * mesh[:, :3]
    e1, e2 = basis(f)
    if shape == PROXY_CAPSULE:
        half = 0.5 * float(light["extent_length"][3])
        local = mesh[:, 0:1] * e1 + mesh[:, 1:2] * e2 + mesh[:, 2:3] * f
        return p + f * (mesh[:, 3:4] * half) + r * local
    if shape == PROXY_CONE:
        th = mesh[:, 2:3] * float(proxy["cap_angle"])
        local = np.sin(th) * (mesh[:, 0:1] * e1 + mesh[:, 1:2] * e2) + np.cos(th) * f
        return np.where(mesh[:, 3:4] > 0.5, p - f * float(proxy["apex_back"]), p + r * local)
    right = light["right"][:3].astype(np.float64)
    upp = np.cross(right, f)
    e = light["extent_length"][:3].astype(np.float64) + M
    return p + mesh[:, 0:1] * e[0] * right + mesh[:, 1:2] * e[1] * upp + mesh[:, 2:3] * e[2] * f


class Raster(Technique, register_at=80):
    name = "raster"
    summary = "light proxy meshes rasterized into tile bit arrays with atomics (Drobot 2017)"
    evaluates_per_wave = True          # the zbin loop's scalarized variants (zbin.py)
    views = Technique.views + ("tiles", "slices", "maps")   # slices: --cluster
    glsl = {"raster_structs.glsl": STRUCTS_GLSL}

    @dataclass(frozen=True)
    class Options(ShadingOptions):          # zbin's shading loop's options (not its tile_depth)
        raster_variant: int = option(0, "the slides' tile rasterizer table: 0 atomic, 1 + 4xMSAA "
                                        "at half resolution, 2 + wave compaction, 3 both",
                                     lo=0, hi=3, study=(0, 1, 2, 3), also_study=("contention",))
        stencil: bool = option(False, "tile rasterizer: two-pass stencil test (front faces, then "
                                      "back faces; pixel-perfect) for proxies the eye is outside of",
                               study=(False, True))
        cluster: int = option(0, "0 tiles + zbin's loop; 1 the slides' cluster rasterizer: back "
                                 "faces MARK, front faces WALK clusters of cluster_tile px x "
                                 "cluster_slices depth slices within each tile's scene depth "
                                 "(the depth prepass), shaded by a per-cluster loop; 2 the same "
                                 "without the depth prepass", lo=0, hi=2, study=(0, 1, 2))
        cluster_tile: int = option(32, "cluster rasterizer: tile in pixels, before the memory "
                                       "budget (bit_budget_mib) doubles it", lo=1, hi=4096)
        cluster_slices: int = option(limits.DEFAULT_SLICES, "cluster rasterizer: depth slices "
                                     "(listing 4, near slice to 5 m)", lo=2, hi=64)
        early_depth: bool = option(True, "the hardware depth test before the shader (off: the "
                                         "shader's exact depth tests alone; same bits, slower)")
        raster_stats: bool = option(True, "count fragments, atomics and per-light marks in an "
                                          "untimed twin of the culling passes (meta stats)")

        def ignored(self) -> dict[str, str]:
            """What the mode does not read (options.py's rule): cluster mode shades with its
            own loop (none of zbin's shading options) and has no depth test, stencil or
            tiles of bit_tile; tile mode has no clusters, and its zbin loop ignores what
            zbin.ShadingOptions.ignored says (the z-bins' count and mask without z-bins, the
            wave ops in the base tile; compaction's wave ops follow raster_variant)."""
            if self.cluster:
                mode = f"in cluster mode (--cluster {self.cluster})"
                return dict.fromkeys(CLUSTER_IGNORES, mode)
            out = dict(super().ignored())          # zbin's shading loop's (ShadingOptions)
            out.update(dict.fromkeys(("cluster_tile", "cluster_slices"), "in tile mode (--cluster 0)"))
            return out

    # ---- CPU stage ---------------------------------------------------------------------

    def build(self, frame, opts):
        opts = self.resolve_options(opts)
        b = prepare(frame)
        masked, _ = variant_flags(opts.zbin_variant)
        msaa = bool(opts.raster_variant & 1)
        n = len(b.lights)
        w, h = frame.size
        slices = opts.cluster_slices if opts.cluster else 1
        tile = cluster_tile(w, h, n, opts.cluster_tile, slices, opts.bit_budget_mib) if opts.cluster \
            else zb.choose_tile(w, h, n, opts.bit_tile, int(opts.bit_budget_mib * 2**20))
        b.grid = gridmod.make_grid(frame.camera, tile, slices, frame.max_depth,
                                   limits.DEFAULT_NEAR_SLICE_DEPTH)
        g = b.grid
        masked = masked and not opts.cluster
        if masked:
            attach_zbins(b, opts.zbins, frame.max_depth)
        dilation, quad = 0.0, np.zeros((MSAA_SAMPLES, 2), np.int32)
        positions = np.full((MSAA_SAMPLES, 2), 0.5, np.float32)
        if msaa:
            from ..pipeline.renderer import sample_positions
            positions = np.asarray(sample_positions(MSAA_SAMPLES), np.float32)
            quad, dilation = msaa_dilation(positions)
        with b.times.stage("build"):
            proxies = proxy_params(b.lights, frame.camera, dilation)
            key = proxies["shape"].astype(np.int64) * 2 + proxies["back"]
            order = np.argsort(key, kind="stable").astype(np.uint32)
            groups = np.bincount(key, minlength=8)
        bits_bytes = g.cells * zb.words_for(n) * 4
        cpuframe.check_buffer("raster bit arrays", bits_bytes)
        b.buffers["raster_proxies"] = proxies
        b.buffers["raster_order"] = order if n else np.zeros(1, np.uint32)
        b.data.update(groups=groups, quad=quad, sample_pos=positions)
        tris = sum(int(groups[2 * s + k]) * len(MESHES[s]) // 3 for s in range(4) for k in range(2))
        wide = zb.is_wide(n)
        b.stats.update(
            variant=VARIANTS[opts.raster_variant] + (f" ({CLUSTER_NAMES[opts.cluster]})" if opts.cluster else ""),
            shade_variant="cluster loop" if opts.cluster else SHADE_VARIANTS[opts.zbin_variant],
            stencil=int(opts.stencil), bit_tile_used=tile,
            tiles=g.tiles_x * g.tiles_y, cells=g.cells, words_per_tile=zb.words_for(n),
            bits_bytes=bits_bytes,
            zbins=opts.zbins if masked else 0,
            zbin_bytes=int(b.buffers["zbins"].nbytes) if masked else 0,
            zbin_id_bits=32 if wide else zb.ZBIN_ID_BITS,
            proxies_front=int(groups[0::2].sum()), proxies_back=int(groups[1::2].sum()),
            proxy_triangles=tris, msaa_dilation_px=round(dilation, 4),
            compaction=_compaction(opts.raster_variant),
            **{f"proxies_{PROXY_NAMES[s]}": int(groups[2 * s] + groups[2 * s + 1]) for s in range(4)})
        return b

    def report_notes(self, rows):
        return _notes(self, rows)

    def maps(self, result, read):
        """Lights whose proxy marked each tile (the rasterized bit arrays; tile mode)."""
        b = result.build
        if b.grid.slices > 1:
            return {}
        from .zbin import tile_bit_maps
        m = tile_bit_maps(read("raster_bits"), b.grid)
        return {"raster_lights": (m["tile_lights"][0], "marked lights / tile")}

    # ---- GPU passes ----------------------------------------------------------------------

    def passes(self, build, opts):
        opts = self.resolve_options(opts)
        out = []
        if opts.raster_stats:
            out += [replace(p, figures=True) for p in self._cull_passes(build, opts, stats=True)]
            out.append(HostStep("raster counters", ("raster_counters", "raster_light_tiles",
                                                    "raster_tile_depth"),
                                lambda got: _raster_counters(build, got), figures=True))
        out += self._cull_passes(build, opts, stats=False)
        g, n = build.grid, len(build.lights)
        if opts.cluster:
            out += shading_passes(
                build, "raster_shade_cluster.comp", ("cluster_bits",), longest=n,
                uniforms={"u_tile": g.tile, "u_tiles_x": g.tiles_x, "u_words": zb.words_for(n),
                          "u_slices": g.slices, "u_slice_scale": float(g.slice_scale),
                          "u_slice_bias": float(g.slice_bias)},
                sources={"cluster_bits": "raster_bits"})
            return out
        masked, scalarized = variant_flags(opts.zbin_variant)
        wide = zb.is_wide(n)
        out += shading_passes(
            build, "shade_zbin.comp", ("tile_bits",) + (("zbins",) if masked else ()), longest=n,
            defines={"ZBIN_MASKED": int(masked), "SCALARIZED": int(scalarized),
                     "ZBIN_WIDE": int(wide), "ZBIN_PRINTED_MASK": int(opts.printed_mask),
                     "ZBIN_EMPTY_MIN": zb.ZBIN_WIDE_EMPTY_MIN if wide else zb.ZBIN_NARROW_EMPTY},
            uniforms={"u_tile": g.tile, "u_tiles_x": g.tiles_x, "u_words": zb.words_for(n),
                      "u_bins": opts.zbins, "u_bin_scale": build.data.get("bin_scale", 0.0)},
            native_wave=opts.native_wave, sources={"tile_bits": "raster_bits"})
        out.append(HostStep("wave counters", (WAVE_STATS,),
                            lambda got: _wave_counters(build, got[WAVE_STATS]), figures=True))
        return out

    def cull_figures(self, frame, width):
        """The depth fill (a fragment a pixel; tile mode), the tile depth pass (cluster
        mode with its depth bound: an 8x8 group of lanes a block, a texel each, reduced in
        shared memory when the tile is a multiple of 8) and the proxy draws: their
        vertices, and the fragments and atomics the untimed stats twin counted."""
        from ..model import waves
        b = frame.build
        w, h = frame.size
        frags = int(b.stats.get("raster_fragments", 0))
        atomics = int(b.stats.get("raster_atomics", 0))
        verts = 3 * int(b.stats.get("proxy_triangles", 0))
        up = lambda k: -(-k // width)
        out = {}
        tiles_bytes = b.grid.tiles_x * b.grid.tiles_y * 8
        if not frame.opts.cluster:
            out["raster fill"] = waves.analytic(
                width, up(w * h), {"fragment": (up(w * h), w * h, up(w * h), up(w * h) * 4)},
                {"g_position": w * h * 16}, graphics=True, fragments=w * h)
        elif frame.opts.cluster == CLUSTER_BOUNDED:
            gx, gy, _ = image_groups(w, h)
            per = 64 // width
            launched = gx * gy * per
            covered = int(frame.shading.sum())
            grouped = b.grid.tile % 8 == 0
            x, y = frame.pixel_xy
            sel = frame.shading
            busy = len(np.unique((y[sel] // 8) * gx + x[sel] // 8))    # groups with geometry
            out["raster tile depth"] = waves.analytic(
                width, launched, {"depth": (launched, w * h, launched, launched * width * 16 // waves.LINE)},
                {"g_position": w * h * 16, "raster_depth_bounds": tiles_bytes},
                barriers=2 * gx * gy if grouped else 0,
                shared_atomics=2 * covered if grouped else 0,
                atomics=2 * busy if grouped else 2 * covered)
        bounds = {"raster_depth_bounds": tiles_bytes} if frame.opts.cluster == CLUSTER_BOUNDED else {}
        out["raster proxies"] = waves.analytic(
            width, up(verts) + up(frags),
            {"vertex": (up(verts), verts, 2 * up(verts), 2 * up(verts) * 2),
             "fragment": (up(frags), frags, up(frags), atomics)},
            {"lights": len(b.lights) * 96, "raster_proxies": len(b.lights) * RASTER_PROXY.itemsize,
             "raster_bits": int(b.stats.get("bits_bytes", 0)), **bounds},
            graphics=True, fragments=frags, atomics=atomics)
        return out

    def wave_program(self, frame, width):
        """zbin's loop over the rasterized bits, or the per-cluster loop (cluster mode)."""
        from ..model import waves
        opts = frame.opts
        masked, scalarized = variant_flags(opts.zbin_variant)
        prog = waves.Program(frame, width)
        if opts.cluster:
            add_bit_words(prog, "raster_bits", frame.build.grid, False, False, False, cluster=True)
        else:
            add_bit_words(prog, "raster_bits", frame.build.grid, masked, scalarized, opts.printed_mask)
        return prog

    def _cull_passes(self, build, opts, stats: bool) -> list:
        """The fill pass (own depth target) and one mark pass per non-empty (proxy, side)
        group (the cluster rasterizer: MARK passes, then WALK passes); `stats`: the untimed
        twin that counts into its own buffers."""
        g, n = build.grid, len(build.lights)
        w, h = build.frame.size
        cam = build.frame.camera
        msaa = bool(opts.raster_variant & 1)
        compact = bool(opts.raster_variant & 2)
        words = zb.words_for(n)
        bits_name = "raster_stats_bits" if stats else "raster_bits"
        tiles = g.tiles_x * g.tiles_y
        target = Target("raster_depth", scale=2 if msaa else 1, samples=MSAA_SAMPLES if msaa else 0,
                        stencil=opts.stencil)
        suffix = " (stats)" if stats else ""
        lw = -(-w // 2) if msaa else w
        lh = -(-h // 2) if msaa else h
        sx, sy = (w / (2.0 * lw), h / (2.0 * lh)) if msaa else (1.0, 1.0)
        clip = column_major(cam.clip_from_view)
        quad = np.ascontiguousarray(build.data["quad"], np.int32)
        writes = {bits_name: Buffer(max(g.cells * words, 1) * 4, cleared=True)}
        if stats:
            writes["raster_counters"] = Buffer(16, cleared=True)
            writes["raster_light_tiles"] = Buffer(max(n, 1) * 4, cleared=True)
        uniforms = {"u_clip_from_view": clip, "u_near": float(cam.near), "u_instance": 0,
                    "u_step": 0, "u_ndc": (sx, sy, sx - 1.0, sy - 1.0), "u_tile": g.tile,
                    "u_tiles_x": g.tiles_x, "u_words": words, "u_sample_pixel": quad,
                    "u_sample_pos": build.data["sample_pos"], "u_slices": g.slices,
                    "u_slice_scale": float(g.slice_scale), "u_slice_bias": float(g.slice_bias)}
        # each tile's min / max scene depth: the stats' (tile mode: which unmarked lights a
        # depth-bounds test would keep), the cluster MARK / WALK's bounds (the depth prepass)
        bounded = opts.cluster == CLUSTER_BOUNDED
        depth = "raster_tile_depth" if stats else "raster_depth_bounds"
        out = []
        if stats or bounded:
            out.append(Pass("raster tile depth" + suffix, "raster_tile_depth.comp",
                            writes={"raster_tile_depth": Buffer(max(tiles, 1) * 8, cleared=True)},
                            groups=image_groups(w, h), timed=not stats,
                            defines={"TILE_DEPTH_GROUP": int(g.tile % 8 == 0)},
                            uniforms={"u_tile": g.tile, "u_tiles_x": g.tiles_x},
                            sources={"raster_tile_depth": depth}))
        if opts.cluster:
            out += self._cluster_passes(build, msaa, compact, stats, bounded, depth, writes,
                                        uniforms, suffix)
        else:
            out += self._tile_passes(build, opts, target, msaa, compact, stats, writes, uniforms, suffix)
        return out

    @staticmethod
    def _written(writes: dict, first: bool) -> dict:
        """The bit arrays (and counters) a pass writes: cleared by the first pass only."""
        return dict(writes) if first else {k: Buffer(v.nbytes) for k, v in writes.items()}

    def _cluster_passes(self, build, msaa, compact, stats, bounded, depth, writes, uniforms,
                        suffix) -> list:
        """MARK (back faces of the proxies the eye is outside of), then WALK (their front
        faces) and the eye-inside proxies' back faces (raster_cluster.frag); `bounded`:
        within each tile's scene depth (buffer `depth`, the tile depth pass's)."""
        # A target with no colour attachment (the technique's own depth target, untested):
        # with "none"'s colour renderbuffer and no depth test, llvmpipe (Mesa 22.3) takes a
        # triangle that covers a whole 64x64 bin as opaque and drops the bin's earlier
        # commands, side effects (our atomics) and all: on hangar at 480x270 an eye-inside
        # proxy drawn later erased other lights' marks in whole 2x2-tile blocks.
        target = Target("raster_cluster", scale=2 if msaa else 1, samples=MSAA_SAMPLES if msaa else 0)
        groups, out = build.data["groups"], []
        starts = np.concatenate([[0], np.cumsum(groups)])      # order[] is sorted by (shape, side)
        for mode, back, cull in (("mark", 0, "front"), ("walk", 0, "back"), ("inside", 1, "front")):
            for shape in range(4):
                count = int(groups[2 * shape + back])
                if count:
                    out.append(Pass(
                        f"raster {PROXY_NAMES[shape]} {mode}" + suffix,
                        ("raster_proxy.vert", "raster_cluster.frag"),
                        reads=("lights", "raster_proxies", "raster_order")
                        + (("raster_tile_depth",) if bounded else ()),
                        writes=self._written(writes, not out),
                        draw=Draw(vertices=MESHES_CORNERS[shape], format="4f 4f 4f",
                                  attributes=("in_vertex", "in_vertex1", "in_vertex2"),
                                  instances=count, target=target, cull=cull),
                        timed=not stats, native_wave=compact,
                        defines={"RASTER_MSAA": int(msaa), "RASTER_COMPACT": int(compact),
                                 "RASTER_STATS": int(stats), "RASTER_TRI_BOUNDS": 1,
                                 "RASTER_DEPTH_BOUND": int(bounded)},
                        uniforms=dict(uniforms, u_shape=shape, u_first=int(starts[2 * shape + back]),
                                      u_mode=CLUSTER_MODES[mode]),
                        sources={"raster_tile_depth": depth}))
        return out or [self._no_lights(writes, stats, suffix)]

    @staticmethod
    def _no_lights(writes, stats, suffix) -> Pass:
        """No light: the (empty) bit arrays still come from a pass."""
        return Pass("raster none" + suffix, ("raster_proxy.vert", "raster_mark.frag"),
                    reads=("lights", "raster_proxies", "raster_order"), writes=writes,
                    draw=Draw(count=0, target="none"), timed=not stats,
                    defines={"RASTER_MSAA": 0, "RASTER_COMPACT": 0, "RASTER_STATS": int(stats),
                             "RASTER_TRI_BOUNDS": 0})

    def _tile_passes(self, build, opts, target, msaa, compact, stats, writes, uniforms, suffix):
        cam = build.frame.camera
        quad = uniforms["u_sample_pixel"]
        out = [Pass("raster fill" + suffix, ("raster_fill.vert", "raster_fill.frag"),
                    draw=Draw(count=3, target=target, depth_test="always", depth_write=True, clear=True),
                    defines={"RASTER_MSAA": int(msaa)}, timed=not stats,
                    uniforms={"u_near": float(cam.near), "u_sample_pixel": quad})]
        groups = build.data["groups"]
        first = 0
        drawn = False
        for shape in range(4):
            for back in (0, 1):
                count = int(groups[2 * shape + back])
                if count == 0:
                    first += count
                    continue
                stencil = ()
                mode = back
                if opts.stencil and not back:
                    mode = 2
                    stencil = (StencilStep(cull="back", depth_test=FRONT_TEST, func="always",
                                           ops=("keep", "keep", "replace")),
                               StencilStep(cull="front", depth_test=BACK_TEST, func="equal",
                                           ops=("keep", "keep", "zero")))
                draw = Draw(vertices=MESHES[shape], format="4f", attributes=("in_vertex",),
                            instances=count, target=target,
                            depth_test=(BACK_TEST if back else FRONT_TEST) if opts.early_depth else "always",
                            cull="front" if back else "back", stencil=stencil)
                out.append(Pass(
                    f"raster {PROXY_NAMES[shape]} {'back' if back else 'front'}" + suffix,
                    ("raster_proxy.vert", "raster_mark.frag"),
                    reads=("lights", "raster_proxies", "raster_order"),
                    writes=self._written(writes, not drawn),
                    draw=draw, timed=not stats, native_wave=compact,
                    defines={"RASTER_MSAA": int(msaa), "RASTER_COMPACT": int(compact),
                             "RASTER_STATS": int(stats), "RASTER_TRI_BOUNDS": 0},
                    uniforms=dict(uniforms, u_shape=shape, u_first=first, u_mode=mode)))
                drawn = True
                first += count
        if not drawn:
            out.append(self._no_lights(writes, stats, suffix))
        return out


def _compaction(variant: int) -> str:
    """How the compaction variants run here (meta stats)."""
    if not variant & 2:
        return "off"
    from ..pipeline import gl
    if gl.limits().native_wave:
        return "native subgroup"
    return "unavailable (neither GL_KHR_shader_subgroup nor GL_ARB_shader_ballot): plain atomics"


def cluster_tile(width: int, height: int, lights: int, tile: int, slices: int, budget_mib: float) -> int:
    """The cluster rasterizer's tile: `tile`, doubled until its bit arrays (tiles x slices x
    words x 4 bytes) fit the budget (as zbin.choose_tile for tiles)."""
    budget = min(int(budget_mib * 2**20), limits.MAX_STORAGE_BYTES)
    while zb.bits_bytes(width, height, tile, lights) * slices > budget and tile < max(width, height):
        tile *= 2
    return int(tile)


def _raster_counters(build, got):
    """Meta stats of the untimed twin (module doc): fragments, atomics, marks, and the
    lights occlusion removed."""
    c = got["raster_counters"].view(np.uint32)
    per_light = got["raster_light_tiles"].view(np.uint32)[:len(build.lights)].astype(np.int64)
    g, pl = build.grid, build.lights
    boxes = tile_boxes(pl, g)
    nx = (boxes[:, 1] - boxes[:, 0] + 1).clip(0)
    ny = (boxes[:, 3] - boxes[:, 2] + 1).clip(0)
    ns = (boxes[:, 5] - boxes[:, 4] + 1).clip(0)
    rect_tiles = nx * ny * ns              # the cells (tiles, or clusters) of the CPU's boxes
    depth = got["raster_tile_depth"].view(np.uint32).reshape(-1, 2)
    lo = (~depth[:, 0]).view(np.float32).reshape(g.tiles_y, g.tiles_x)
    hi = depth[:, 1].view(np.float32).reshape(g.tiles_y, g.tiles_x)
    covered = depth[:, 1].reshape(g.tiles_y, g.tiles_x) != 0
    unmarked = np.nonzero((per_light == 0) & (rect_tiles > 0))[0]
    occluded = 0
    for i in unmarked:         # would a tile depth-bounds test (tiled) keep the light?
        x0, x1, y0, y1 = boxes[i, :4]
        sl = np.s_[y0:y1 + 1, x0:x1 + 1]
        keep = covered[sl] & (lo[sl] <= pl.depth_hi[i]) & (hi[sl] >= pl.depth_lo[i])
        occluded += bool(keep.any())
    build.stats.update(
        raster_fragments=int(c[0]), raster_atomics=int(c[1]), raster_marks=int(per_light.sum()),
        rect_marks=int(rect_tiles.sum()), unmarked_lights=int(len(unmarked)),
        occluded_lights=int(occluded), raster_pixel_marks=int(c[2]))
    return {}, []


# ---- the slides' figures beside this run's (app/report/notes.py) ------------------------

SLIDES_TILE = {0: "1.44 ms (100%)", 1: "0.27 ms (18%)", 2: "0.36 ms (25%)", 3: "0.10 ms (7%)"}
SLIDES_TILE_MS = {0: 1.44, 1: 0.27, 2: 0.36, 3: 0.10}
CONTENTION_SCENE = "contention"      # scenes/builtin.py: the slides' "3 x full screen lights"
SLIDES_SIZE = (1920, 1080)           # their 240 x 135 tiles of 8 x 8
MODEL_GPU = "ps4"                    # the slides' GPU in app/model/cost.py


def contention_figures(technique, size=SLIDES_SIZE) -> dict[int, dict]:
    """Per raster_variant, the contention scene at `size` (its default lights, frame 0): the
    stats twin's atomics and fragments, the tile grid, and the culling passes modelled on
    the slides' PS4.  Counters and model only, no timing (the report rebuilds to the same
    text from the same results); the shading passes skip their light loops (CELLS_ONLY)."""
    from scenes import load_scene
    from ..model import cost, waves
    from ..pipeline.renderer import Renderer
    gpu = cost.BY_KEY[MODEL_GPU]
    out = {}
    scene = load_scene(CONTENTION_SCENE)
    with Renderer(scene, tuple(size)) as r:
        for v in range(len(VARIANTS)):
            opts = technique.resolve_options({"raster_variant": v})
            res = r.render(technique, 0, opts, defines={"CELLS_ONLY": 1})
            figs = technique.cull_figures(waves.frame_data(r, res, opts), gpu.wave)
            st = res.meta["stats"]
            out[v] = {"atomics": int(st["raster_atomics"]), "fragments": int(st["raster_fragments"]),
                      "model_ms": sum(cost.pass_ms(f, gpu) for f in figs.values()),
                      "tiles": (res.build.grid.tiles_x, res.build.grid.tiles_y),
                      "lights": len(scene.lights), "size": tuple(size)}
    return out


def resolution(r) -> str:
    return f"{int(r['width'])}x{int(r['height'])}"


def _share(a, b) -> str:
    return f"{a / b:.0%}" if b else "-"


def _variant_table(technique, study, measured=()) -> list[str]:
    """The slides' tile rasterizer table beside the contention scene's counters (rendered
    here at the slides' resolution), the variant study's rows, and the contention scene's
    own study rows (`measured`: the benchmark's "raster_variant@contention")."""
    import json
    from ..pipeline import gl
    by = {int(r["raster_variant"]): r for r in study}
    there = {int(r["raster_variant"]): r for r in measured}
    r0 = study[0]
    try:
        con = contention_figures(technique)
    except Exception as exc:                 # no GL context where the report is rebuilt
        con = {}
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    atomics = {v: json.loads(r["stats"]).get("raster_atomics") if r.get("stats") else None
               for v, r in by.items()}
    base_ms = float(by[0]["gpu_cull_ms"]) if 0 in by else 0.0
    text = []
    if con:
        tx, ty = con[0]["tiles"]
        w, h = con[0]["size"]
        text += [f"The slides' tile rasterizer table (\"3 x full screen lights - 240x135 - (PS4)\") "
                 f"beside the {CONTENTION_SCENE} scene (three lights holding the whole hall and "
                 f"{con[0]['lights'] - 3} small ones, {w}x{h}: {tx}x{ty} tiles; the "
                 f"stats twin's atomics, rendered for this report, and the culling passes (the "
                 f"depth fill included) "
                 f"modelled on the PS4, whose model has no atomic contention) and this run's "
                 f"variant study ({r0['scene']}, {int(r0['lights'])} lights; culling passes with "
                 f"the depth fill measured here, median: on a software rasterizer MSAA is "
                 f"per-sample work and atomics are cheap, so only the atomic counts carry over):",
                 "", f"| variant | slides | {CONTENTION_SCENE}: atomics | of atomic | modelled PS4 "
                 + (f"| {CONTENTION_SCENE}: measured here, {resolution(measured[0])} | of atomic "
                    if there else "")
                 + f"| {r0['scene']}: measured | of atomic | atomics | of atomic |",
                 "|---|---|---|---|---|" + ("---|---|" if there else "") + "---|---|---|---|"]
    else:
        text += [f"The slides' tile rasterizer table (\"3 x full screen lights - 240x135 - (PS4)\") "
                 f"beside this run's variant study ({r0['scene']}, {int(r0['lights'])} lights; "
                 f"culling passes with the depth fill, median; only the atomic counts carry over "
                 f"from a software rasterizer); the {CONTENTION_SCENE} scene's counters need a GL "
                 f"context, none here ({why}):", "",
                 f"| variant | slides | {r0['scene']}: measured | of atomic | atomics | of atomic |",
                 "|---|---|---|---|---|---|"]
    for v in range(len(VARIANTS)):
        r = by.get(v)
        cells = [VARIANTS[v], SLIDES_TILE[v]]
        if con:
            c = con[v]
            cells += [f"{c['atomics']:,}", _share(c["atomics"], con[0]["atomics"]),
                      f"{c['model_ms']:.3g} ms"]
            if there:
                m = there.get(v)
                cells += ([f"{float(m['gpu_cull_ms']):.3g} ms ({float(m['gpu_cull_min_ms']):.3g}-"
                           f"{float(m['gpu_cull_max_ms']):.3g})",
                           _share(float(m["gpu_cull_ms"]), float(there[0]["gpu_cull_ms"]))]
                          if m is not None and 0 in there else ["-", "-"])
        if r is None:
            cells += ["-"] * 4
        else:
            cull = float(r["gpu_cull_ms"])
            a, a0 = atomics.get(v), atomics.get(0)
            cells += [f"{cull:.3g} ms", _share(cull, base_ms), f"{a:,}" if a is not None else "-",
                      _share(a, a0) if a is not None and a0 else "-"]
        text.append("| " + " | ".join(cells) + " |")
    if con:
        sub = gl.limits().subgroup_size
        plain = con[0]
        text.append(
            f"\nIn the {CONTENTION_SCENE} scene every pixel marks three lights, so each tile's "
            f"pixels issue their atomics on the same words: compaction leaves "
            f"{_share(con[2]['atomics'], plain['atomics'])} of the plain rasterizer's "
            f"{plain['atomics']:,} atomics (on this driver's "
            f"{f'{sub}-lane ' if sub else ''}subgroups; a 64-lane wave merges more), MSAA "
            f"{_share(con[1]['atomics'], plain['atomics'])}, both "
            f"{_share(con[3]['atomics'], plain['atomics'])}, against the slides' times 25%, 18% "
            f"and 7%.  The model's PS4 culling time for the plain rasterizer, "
            f"{plain['model_ms']:.3g} ms, is {SLIDES_TILE_MS[0] / plain['model_ms']:.2g}x below "
            f"the slides' 1.44 ms: the model counts an atomic as one memory access, and their "
            f"contention is what compaction removes.")
    return text


def _cluster_text(study) -> list[str]:
    """Cluster against tile waste, with and without the depth bound (the `cluster` study)."""
    import json
    by = {int(r["cluster"]): r for r in study}
    if 0 not in by or not ({1, 2} & set(by)):
        return []
    st = {v: json.loads(r["stats"]) if r.get("stats") else {} for v, r in by.items()}
    t = by[0]
    tile = st[0].get("bit_tile_used", "?")
    parts = []
    for v in (1, 2):
        if v in by:
            r = by[v]
            parts.append(f"{float(r['evaluated_pp']):.3g} lights a pixel "
                         f"{'with' if v == CLUSTER_BOUNDED else 'without'} the depth bound "
                         f"(waste {float(r['waste']):.3g}x the exact lights)")
    text = [f"\nThe cluster rasterizer against the tiles (the cluster study, {t['scene']}, "
            f"{int(t['lights'])} lights): tiles evaluate {float(t['evaluated_pp']):.3g} lights a "
            f"pixel (waste {float(t['waste']):.3g}x), clusters {' and '.join(parts)}."]
    if 1 in by and 2 in by:
        b, u = st[1], st[2]
        same = float(by[1]["evaluated_pp"]) == float(by[2]["evaluated_pp"])
        text.append(
            f"The bound {'leaves the evaluations as they are' if same else 'changes the evaluations'}"
            f" (a pixel reads only the cluster of its own depth's slice, which lies within its "
            f"tile's depth range) and saves marking: {b.get('raster_marks', '-')} (cluster, light) "
            f"marks against {u.get('raster_marks', '-')}, {b.get('raster_atomics', '-')} atomics "
            f"against {u.get('raster_atomics', '-')}, culling {float(by[1]['gpu_cull_ms']):.3g} ms "
            f"against {float(by[2]['gpu_cull_ms']):.3g} ms (the bound's own depth pass included).")
    ctile = st.get(1, st.get(2, {})).get("bit_tile_used", "?")
    text.append(f"What the clusters waste is their size on screen: {ctile} px clusters against "
                f"{tile} px tiles, each marked wherever a light's volume passes through it, where "
                f"a tile is marked only by a lit surface pixel of its own.")
    return [" ".join(text)]


def _notes(technique, rows) -> tuple[str, str]:
    import json
    text = []
    study = [r for r in rows if r.get("study") == "raster_variant"]
    if study:
        text += _variant_table(technique, study, [r for r in rows if r.get("study") ==
                                                  f"raster_variant@{CONTENTION_SCENE}"])
    text += _cluster_text([r for r in rows if r.get("study") == "cluster"])
    path = [r for r in rows if r.get("study") == "path"]
    st = [json.loads(r["stats"]) for r in path if r.get("stats")]
    if st:
        vis = sum(s.get("visible_lights", 0) for s in st)
        un = sum(s.get("unmarked_lights", 0) for s in st)
        occ = sum(s.get("occluded_lights", 0) for s in st)
        text.append(f"\nAlong the camera paths, {un} of {vis} visible lights marked no tile "
                    f"(their volume reaches no visible surface); {occ} of them a per-tile depth "
                    f"bounds test would still have kept: occlusion alone removed them.")
    return "what the slides measure", "\n".join(text)
