"""Per-frame light preparation, one numba kernel per timed step (tree paper 4.1):

    scene lights (LIGHT_DTYPE, world)
      --cull-->  visible: float32 view-space position/direction, float64 culling sphere
      --sort-->  order by distance to the camera plane (LSD radix sort, stable: ties by id)
      --pack-->  GPU_LIGHT[], GPU_BOUND[], float32 conservative depth ranges, in that order
"""
from __future__ import annotations

from dataclasses import dataclass
import math

import numba
import numpy as np

from . import layouts
from .bounds import grow, spot_sphere
from .camera import FrameCamera
from .limits import PIXEL_MARGIN, RADIUS_REL_MARGIN

SPOT = 1


@dataclass
class PreparedLights:
    """The frame's visible lights, depth-sorted, as the GPU and the binning see them."""
    ids: np.ndarray          # (N,) uint32 light id (scene order)
    type: np.ndarray         # (N,) uint8
    center: np.ndarray       # (N,3) float64 culling sphere centre, view space
    bound_radius: np.ndarray # (N,) float64 culling sphere radius, margins included
    gpu: np.ndarray          # GPU_LIGHT
    bounds: np.ndarray       # GPU_BOUND
    depth_lo: np.ndarray     # float32, rounded down: conservative depth range per light
    depth_hi: np.ndarray     # float32, rounded up

    def __len__(self):
        return len(self.ids)

    @property
    def depth(self) -> np.ndarray:
        return -self.center[:, 2]


@numba.njit(cache=True, nogil=True)
def _view_cull(lights, m, near, far, tan_x, tan_y):
    """View transform (float64, stored float32 as the GPU sees it), culling sphere, and the
    frustum test of that sphere against the near/far planes and the four side planes
    widened by PIXEL_MARGIN; returns the visible lights only."""
    n = lights.shape[0]
    vis = np.empty(n, np.int64)
    pos = np.empty((n, 3), np.float32)
    dirs = np.empty((n, 3), np.float32)
    center = np.empty((n, 3))
    brad = np.empty(n)
    norm_x, norm_y = math.sqrt(1.0 + tan_x * tan_x), math.sqrt(1.0 + tan_y * tan_y)
    k = 0
    for i in range(n):
        li = lights[i]
        x, y, z = float(li.position[0]), float(li.position[1]), float(li.position[2])
        px = np.float32(m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3])
        py = np.float32(m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3])
        pz = np.float32(m[2, 0] * x + m[2, 1] * y + m[2, 2] * z + m[2, 3])
        x, y, z = float(li.direction[0]), float(li.direction[1]), float(li.direction[2])
        dx = m[0, 0] * x + m[0, 1] * y + m[0, 2] * z
        dy = m[1, 0] * x + m[1, 1] * y + m[1, 2] * z
        dz = m[2, 0] * x + m[2, 1] * y + m[2, 2] * z
        inv = 1.0 / max(math.sqrt(dx * dx + dy * dy + dz * dz), 1e-30)
        dx, dy, dz = np.float32(dx * inv), np.float32(dy * inv), np.float32(dz * inv)
        cx, cy, cz, r = float(px), float(py), float(pz), float(li.radius)
        if li.type == SPOT:
            cx, cy, cz, r = spot_sphere(cx, cy, cz, float(dx), float(dy), float(dz), r, float(li.cos_outer))
        r = grow(r, cx, cy, cz)
        depth = -cz
        if depth + r < near * (1 - RADIUS_REL_MARGIN) or depth - r > far * (1 + RADIUS_REL_MARGIN):
            continue
        if (cx + tan_x * depth) / norm_x < -r or (-cx + tan_x * depth) / norm_x < -r:
            continue
        if (cy + tan_y * depth) / norm_y < -r or (-cy + tan_y * depth) / norm_y < -r:
            continue
        vis[k] = i
        pos[k, 0], pos[k, 1], pos[k, 2] = px, py, pz
        dirs[k, 0], dirs[k, 1], dirs[k, 2] = dx, dy, dz
        center[k, 0], center[k, 1], center[k, 2], brad[k] = cx, cy, cz, r
        k += 1
    return vis[:k], pos[:k], dirs[:k], center[:k], brad[:k]


def view_and_cull(lights: np.ndarray, cam: FrameCamera):
    """(visible ids, float32 view pos, float32 view dir, float64 sphere centre, radius)."""
    tx = cam.tan_half_x * (1.0 + 2.0 * PIXEL_MARGIN / cam.width)
    ty = cam.tan_half_y * (1.0 + 2.0 * PIXEL_MARGIN / cam.height)
    return _view_cull(lights, cam.view_from_world, cam.near, cam.far, tx, ty)


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


def depth_order(depth: np.ndarray, buckets: int = 0) -> np.ndarray:
    """Order of lights by distance to the camera plane, ties by index (stable).

    buckets > 0 gives the first author's testbed's approximate sort: lights fall into that
    many equal depth buckets, in input order within one.  Trees stay exact either way
    (node bounds are min/max over their lights), only less tight."""
    if len(depth) == 0:
        return np.zeros(0, np.int64)
    if buckets > 0:
        lo, hi = float(depth.min()), float(depth.max())
        key = ((depth - lo) * (buckets / max(hi - lo, 1e-30))).clip(0, buckets - 1).astype(np.uint32)
    else:
        # float32 bits made to order like the values: flip all bits of negatives, the sign of positives
        bits = depth.astype(np.float32).view(np.uint32)
        key = np.where(bits >> 31, ~bits, bits | np.uint32(0x80000000))
    return _radix_order(key)


@numba.njit(cache=True, nogil=True, parallel=True)
def _pack(order, vis, pos, dirs, center, brad, lights, gpu_f, gpu_u, bound, lo, hi, c_out, r_out, t_out):
    for j in numba.prange(order.shape[0]):
        i = order[j]
        s = vis[i]
        li = lights[s]
        for a in range(3):
            gpu_f[j, a] = pos[i, a]
            gpu_f[j, 4 + a] = li.color[a] * li.intensity
            gpu_f[j, 8 + a] = dirs[i, a]
            bound[j, a] = center[i, a]
            c_out[j, a] = center[i, a]
        gpu_f[j, 3] = li.radius
        gpu_f[j, 7] = li.cos_inner
        gpu_f[j, 11] = li.cos_outer
        gpu_u[j, 12] = s
        gpu_u[j, 13] = li.type
        r = brad[i]
        r_out[j] = r
        t_out[j] = li.type
        # float32, rounded outwards: the GPU's float32 comparisons stay conservative.
        # (The stored centre's rounding is in grow()'s 4-ulp term; round the radius up.)
        bound[j, 3] = np.nextafter(np.float32(r), np.float32(np.inf))
        lo[j] = np.nextafter(np.float32(-center[i, 2] - r), np.float32(-np.inf))
        hi[j] = np.nextafter(np.float32(-center[i, 2] + r), np.float32(np.inf))


def pack(vis, pos, dirs, center, brad, order, lights: np.ndarray) -> PreparedLights:
    """GPU_LIGHT / GPU_BOUND and the float32 depth ranges, in depth order."""
    n = len(order)
    raw = np.zeros((n, 16), np.float32)
    bound = np.empty((n, 4), np.float32)
    lo, hi = np.empty(n, np.float32), np.empty(n, np.float32)
    c_out, r_out, t_out = np.empty((n, 3)), np.empty(n), np.empty(n, np.uint8)
    _pack(order, vis, pos, dirs, center, brad, lights, raw, raw.view(np.uint32), bound, lo, hi,
          c_out, r_out, t_out)
    return PreparedLights(ids=vis[order].astype(np.uint32), type=t_out, center=c_out, bound_radius=r_out,
                          gpu=raw.view(layouts.GPU_LIGHT).reshape(n), bounds=bound.view(layouts.GPU_BOUND).reshape(n),
                          depth_lo=lo, depth_hi=hi)
