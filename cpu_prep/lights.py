"""Per-frame light preparation, one numba kernel per timed step (tree paper 4.1):

    scene lights (LIGHT_DTYPE, world)
      --cull-->  visible: float32 view-space rows, float64 culling sphere, and each shape's
                 conservative screen rectangle and depth range (cpu_prep.bounds.shape_bounds)
      --sort-->  order by distance to the camera plane (LSD radix sort, stable: ties by id)
      --pack-->  GPU_LIGHT[], GPU_BOUND[], rectangles, float32 depth ranges, in that order
"""
from __future__ import annotations

from dataclasses import dataclass
import math

import numba
import numpy as np

from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_SPOT

from . import layouts
from .arena import Arena, empty
from .bounds import grow, shape_bounds, spot_sphere
from .camera import FrameCamera
from .layouts import (LIGHT_COLOR_COS_INNER as COLOR, LIGHT_DIR_COS_OUTER as DIR,
                      LIGHT_EXTENT_LENGTH as EXT, LIGHT_ID_TYPE as ID_TYPE,
                      LIGHT_POS_RADIUS as POS, LIGHT_RIGHT as RIGHT, LIGHT_WORDS)
from .limits import PIXEL_MARGIN, RADIUS_REL_MARGIN


@dataclass
class PreparedLights:
    """The frame's visible lights, depth-sorted, as the GPU and the binning see them."""
    ids: np.ndarray          # (N,) uint32 light id (scene order)
    type: np.ndarray         # (N,) uint8
    center: np.ndarray       # (N,3) float64 culling sphere centre, view space
    bound_radius: np.ndarray # (N,) float64 culling sphere radius, margins included
    rect: np.ndarray         # (N,4) float64 pixel rectangle x0, x1, y0, y1 (GL), margins included
    gpu: np.ndarray          # GPU_LIGHT
    bounds: np.ndarray       # GPU_BOUND
    depth_lo: np.ndarray     # float32, rounded down: conservative depth range per light
    depth_hi: np.ndarray     # float32, rounded up

    def __len__(self):
        return len(self.ids)

    @property
    def depth(self) -> np.ndarray:
        return -self.center[:, 2]


@numba.njit(inline="always")
def _rotate(m, v):
    """A world direction in view space (the view transform is rigid)."""
    x, y, z = float(v[0]), float(v[1]), float(v[2])
    return (m[0, 0] * x + m[0, 1] * y + m[0, 2] * z, m[1, 0] * x + m[1, 1] * y + m[1, 2] * z,
            m[2, 0] * x + m[2, 1] * y + m[2, 2] * z)


@numba.njit(inline="always")
def _unit(x, y, z):
    inv = 1.0 / max(math.sqrt(x * x + y * y + z * z), 1e-30)
    return x * inv, y * inv, z * inv


@numba.njit(cache=True, nogil=True)
def _view_cull(lights, m, near, far, tan_x, tan_y, tan_rx, tan_ry, width, height,
               rows, rows_u, sphere, shape):
    """View transform (float64, stored float32 as the GPU sees it), culling sphere, and the
    frustum test of that sphere against the near/far planes and the four side planes
    widened by PIXEL_MARGIN (tan_x, tan_y).  Each visible light is written, in scene order,
    as its finished GPU_LIGHT row (rows / rows_u: float and uint views of one array), its
    float64 culling sphere and its shape's screen rectangle and depth range (tan_rx, tan_ry:
    the camera's own), so the sort's permutation later moves one cache line per light."""
    n = lights.shape[0]
    norm_x, norm_y = math.sqrt(1.0 + tan_x * tan_x), math.sqrt(1.0 + tan_y * tan_y)
    k = 0
    for i in range(n):
        li = lights[i]
        x, y, z = float(li.position[0]), float(li.position[1]), float(li.position[2])
        px = np.float32(m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3])
        py = np.float32(m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3])
        pz = np.float32(m[2, 0] * x + m[2, 1] * y + m[2, 2] * z + m[2, 3])
        x, y, z = _rotate(m, li.direction)
        dx, dy, dz = _unit(x, y, z)
        dx, dy, dz = np.float32(dx), np.float32(dy), np.float32(dz)
        t = li.type
        rx = ry = rz = np.float32(0.0)
        cx, cy, cz, r = float(px), float(py), float(pz), float(li.radius)
        if t == LIGHT_SPOT:
            cx, cy, cz, r = spot_sphere(cx, cy, cz, float(dx), float(dy), float(dz), r, float(li.cos_outer))
        elif t == LIGHT_CAPSULE:
            r += 0.5 * float(li.length)
        elif t == LIGHT_BOX:
            # right = normalize(cross(direction, up)), up' = cross(right, direction) (DESIGN)
            ux, uy, uz = _rotate(m, li.up)
            fx, fy, fz = float(dx), float(dy), float(dz)
            x, y, z = _unit(fy * uz - fz * uy, fz * ux - fx * uz, fx * uy - fy * ux)
            rx, ry, rz = np.float32(x), np.float32(y), np.float32(z)
            e = li.extent
            r = math.sqrt(float(e[0]) ** 2 + float(e[1]) ** 2 + float(e[2]) ** 2)
        r = grow(r, cx, cy, cz)
        depth = -cz
        if depth + r < near * (1 - RADIUS_REL_MARGIN) or depth - r > far * (1 + RADIUS_REL_MARGIN):
            continue
        if (cx + tan_x * depth) / norm_x < -r or (-cx + tan_x * depth) / norm_x < -r:
            continue
        if (cy + tan_y * depth) / norm_y < -r or (-cy + tan_y * depth) / norm_y < -r:
            continue
        # GPU_LIGHT, field by field through the word offsets generated from its dtype
        rows[k, POS], rows[k, POS + 1], rows[k, POS + 2], rows[k, POS + 3] = px, py, pz, li.radius
        for a in range(3):
            rows[k, COLOR + a] = li.color[a] * li.intensity
        rows[k, COLOR + 3] = li.cos_inner
        rows[k, DIR], rows[k, DIR + 1], rows[k, DIR + 2], rows[k, DIR + 3] = dx, dy, dz, li.cos_outer
        rows_u[k, ID_TYPE], rows_u[k, ID_TYPE + 1] = i, li.type
        rows_u[k, ID_TYPE + 2], rows_u[k, ID_TYPE + 3] = 0, 0
        rows[k, EXT], rows[k, EXT + 1], rows[k, EXT + 2] = li.extent[0], li.extent[1], li.extent[2]
        rows[k, EXT + 3] = li.length
        rows[k, RIGHT], rows[k, RIGHT + 1], rows[k, RIGHT + 2], rows[k, RIGHT + 3] = rx, ry, rz, 0.0
        sphere[k, 0], sphere[k, 1], sphere[k, 2], sphere[k, 3] = cx, cy, cz, r
        # bounds of what the float32 light the GPU tests covers (its stored values)
        shape[k] = shape_bounds(t, float(px), float(py), float(pz), float(dx), float(dy), float(dz),
                                float(rx), float(ry), float(rz), float(li.radius),
                                float(li.cos_outer), float(li.length), float(li.extent[0]),
                                float(li.extent[1]), float(li.extent[2]), cx, cy, cz, r,
                                near, tan_rx, tan_ry, width, height)
        k += 1
    return k


def view_and_cull(lights: np.ndarray, cam: FrameCamera, arena: Arena | None = None):
    """(GPU_LIGHT rows (K, words) float32, culling spheres (K,4) float64, shape bounds (K,6)
    float64: x0, x1, y0, y1, depth lo, depth hi) of the K visible lights, in scene order."""
    tx = cam.tan_half_x * (1.0 + 2.0 * PIXEL_MARGIN / cam.width)
    ty = cam.tan_half_y * (1.0 + 2.0 * PIXEL_MARGIN / cam.height)
    n = len(lights)
    rows = empty(arena, "visible_rows", (n, LIGHT_WORDS), np.float32)
    sphere = empty(arena, "visible_spheres", (n, 4), np.float64)
    shape = empty(arena, "visible_shapes", (n, 6), np.float64)
    k = _view_cull(lights, cam.view_from_world, cam.near, cam.far, tx, ty, cam.tan_half_x,
                   cam.tan_half_y, float(cam.width), float(cam.height), rows,
                   rows.view(np.uint32), sphere, shape)
    return rows[:k], sphere[:k], shape[:k]


@numba.njit(cache=True, nogil=True)
def _radix_order(keys):
    """Stable LSD radix sort (4 passes of 8 bits) of uint32 keys: the sorting permutation."""
    n = keys.shape[0]
    order = np.arange(n)
    tmp = np.empty(n, np.int64)
    for shift in range(0, 32, 8):
        count = np.zeros(257, np.int64)
        for i in range(n):
            count[((keys[order[i]] >> shift) & 255) + 1] += 1
        if count[1:].max() == n:
            continue                      # every key has this byte: pass changes nothing
        for b in range(256):
            count[b + 1] += count[b]
        for i in range(n):
            b = (keys[order[i]] >> shift) & 255
            tmp[count[b]] = order[i]
            count[b] += 1
        order, tmp = tmp, order
    return order


@numba.njit(cache=True, nogil=True)
def _bucket_order(depth, buckets):
    """Counting sort into `buckets` equal depth buckets; input order within a bucket."""
    n = depth.shape[0]
    lo, hi = depth.min(), depth.max()
    scale = buckets / max(hi - lo, 1e-30)
    key = np.empty(n, np.int64)
    count = np.zeros(buckets + 1, np.int64)
    for i in range(n):
        key[i] = min(int((depth[i] - lo) * scale), buckets - 1)
        count[key[i] + 1] += 1
    for b in range(buckets):
        count[b + 1] += count[b]
    order = np.empty(n, np.int64)
    for i in range(n):
        order[count[key[i]]] = i
        count[key[i]] += 1
    return order


def depth_order(depth: np.ndarray, buckets: int = 0) -> np.ndarray:
    """Order of lights by distance to the camera plane, ties by index (stable).

    buckets > 0 gives the first author's testbed's approximate sort: lights fall into that
    many equal depth buckets, in input order within one.  Trees stay exact either way
    (node bounds are min/max over their lights), only less tight."""
    if len(depth) == 0:
        return np.zeros(0, np.int64)
    if buckets > 0:
        return _bucket_order(np.ascontiguousarray(depth, np.float64), buckets)
    # float32 bits made to order like the values: flip all bits of negatives, the sign of positives
    bits = depth.astype(np.float32).view(np.uint32)
    key = np.where(bits >> 31, ~bits, bits | np.uint32(0x80000000))
    return _radix_order(key)


@numba.njit(cache=True, nogil=True, parallel=True)
def _pack(order, rows, sphere, shape, gpu, spheres_out, rect, bound, lo, hi):
    for j in numba.prange(order.shape[0]):
        i = order[j]
        for a in range(rows.shape[1]):
            gpu[j, a] = rows[i, a]
        for a in range(4):
            spheres_out[j, a] = sphere[i, a]
            rect[j, a] = shape[i, a]
        r = sphere[i, 3]
        for a in range(3):
            bound[j, a] = sphere[i, a]
        # float32, rounded outwards: the GPU's float32 comparisons stay conservative.
        # (The stored centre's rounding is in grow()'s 4-ulp term; round the radius up.)
        bound[j, 3] = np.nextafter(np.float32(r), np.float32(np.inf))
        lo[j] = np.nextafter(np.float32(shape[i, 4]), np.float32(-np.inf))
        hi[j] = np.nextafter(np.float32(shape[i, 5]), np.float32(np.inf))


def pack(rows, sphere, shape, order, arena: Arena | None = None) -> PreparedLights:
    """GPU_LIGHT / GPU_BOUND, rectangles and the float32 depth ranges, in depth order."""
    n = len(order)
    gpu = empty(arena, "gpu_lights", (n, LIGHT_WORDS), np.float32)
    spheres = empty(arena, "sorted_spheres", (n, 4), np.float64)
    rect = empty(arena, "sorted_rects", (n, 4), np.float64)
    bound = empty(arena, "gpu_bounds", (n, 4), np.float32)
    lo, hi = empty(arena, "depth_lo", n, np.float32), empty(arena, "depth_hi", n, np.float32)
    _pack(order, rows, sphere, shape, gpu, spheres, rect, bound, lo, hi)
    rec = gpu.view(layouts.GPU_LIGHT).reshape(n)
    return PreparedLights(ids=rec["id_type"][:, 0], type=rec["id_type"][:, 1].astype(np.uint8),
                          center=spheres[:, :3], bound_radius=spheres[:, 3], rect=rect, gpu=rec,
                          bounds=bound.view(layouts.GPU_BOUND).reshape(n), depth_lo=lo, depth_hi=hi)
