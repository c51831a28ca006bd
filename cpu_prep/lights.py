"""Per-frame light preparation, one numba kernel per timed step (tree paper 4.1):

    scene lights (LIGHT_DTYPE, world)
      --cull-->  the visible lights, in scene order, as (depth key << 32 | scene id) and
                 the sphere-centre depth: the culling sphere against the frustum, branch-
                 free, 12 bytes written a visible light
      --sort-->  LSD radix sort of those uint64 on the key, three passes of 11 bits, the
                 three histograms counted in one pass (stable: ties keep scene order)
      --pack-->  gathers each light in depth order from the scene array (software
                 prefetch) and writes, in that order, GPU_LIGHT[], GPU_BOUND[], the light
                 types, its culling sphere, its shape's screen rectangle and the float32
                 depth ranges (cpu_prep.bounds.shape_bounds); the GPU rows, bounds and
                 spheres, which the CPU stage does not read again, with streaming stores

The cull writes nothing the pack needs but the order: the pack recomputes a light's view-
space values from the scene record it must read anyway (colour, angles, extents), with
the same inline functions as the cull (`_position`, `_direction`, `_sphere`,
`_view_light`), instead of the cull storing ~180 bytes a light for the pack to gather back
in depth order (a cache miss a line: 1.5-3 ms at 65,536 lights, the earlier design).
There is no fastmath here (bounds use inf sentinels; no reassociation, no fused
multiply-add), so every evaluation of the same expressions gives the same bits, in a
scalar loop or in SIMD lanes; tests/cpu_prep/test_prep_equivalence.py holds the outputs
to the earlier kernels' bit for bit (the rectangles to 1e-6 pixel: bounds.project_axis).

Every kernel is compiled with error_model="numpy": a float division by zero gives inf or
NaN instead of raising, so no division carries a zero test and a branch, and loops of
divisions and square roots can be vectorized.  Where a result is kept, no divisor is zero
(each is bounded away from it where its branch is taken); the pack's SIMD rectangle loop
evaluates the in-front-of-the-near-plane formula for every light of a block and keeps it
only where it applies, which is why it needs this error model.
"""
from __future__ import annotations

from dataclasses import dataclass
import math

import numba
import numpy as np

from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_POINT, LIGHT_SPOT

from . import layouts, parallel, share
from .arena import Arena, empty
from .bounds import (grow, ndc_rect, project_axis_ahead, shape_bounds_call, sphere_only,
                     spot_sphere)
from .camera import FrameCamera
from .layouts import (LIGHT_COLOR_COS_INNER as COLOR, LIGHT_DIR_COS_OUTER as DIR,
                      LIGHT_EXTENT_LENGTH as EXT, LIGHT_ID_TYPE as ID_TYPE,
                      LIGHT_POS_RADIUS as POS, LIGHT_RIGHT as RIGHT, LIGHT_WORDS)
from .limits import PIXEL_MARGIN, RADIUS_REL_MARGIN
from .intrinsics import (bits_to_f32, f32_to_bits, fetch_add, next_down_f32, next_up_f32,
                         prefetch_ahead, store4_nt, store_fence)


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


@numba.njit(inline="always")
def _position_xyz(m, x, y, z):
    """A world position (float64) in view space as stored (float64 transform, rounded to
    float32).  m: the view matrix (an array, or a tuple of its top 12 entries)."""
    px = np.float32(m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3])
    py = np.float32(m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3])
    pz = np.float32(m[2, 0] * x + m[2, 1] * y + m[2, 2] * z + m[2, 3])
    return px, py, pz


@numba.njit(inline="always")
def _position(li, m):
    """A light's view-space position as stored."""
    return _position_xyz(m, float(li.position[0]), float(li.position[1]), float(li.position[2]))


@numba.njit(inline="always")
def _direction_xyz(m, x, y, z):
    """A world direction (float64) in view space, unit length, as stored (float32)."""
    x, y, z = (m[0, 0] * x + m[0, 1] * y + m[0, 2] * z, m[1, 0] * x + m[1, 1] * y + m[1, 2] * z,
               m[2, 0] * x + m[2, 1] * y + m[2, 2] * z)
    dx, dy, dz = _unit(x, y, z)
    return np.float32(dx), np.float32(dy), np.float32(dz)


@numba.njit(inline="always")
def _direction(li, m):
    """A light's view-space unit direction as stored (float32)."""
    return _direction_xyz(m, float(li.direction[0]), float(li.direction[1]), float(li.direction[2]))


@numba.njit(inline="always")
def _sphere(t, li, px, py, pz, dx, dy, dz):
    """The float64 culling sphere (centre, radius with the margins of grow()) of a light
    from its stored position and direction (the direction is read for spots only)."""
    cx, cy, cz, r = float(px), float(py), float(pz), float(li.radius)
    if t == LIGHT_SPOT:
        cx, cy, cz, r = spot_sphere(cx, cy, cz, float(dx), float(dy), float(dz), r, float(li.cos_outer))
    elif t == LIGHT_CAPSULE:
        r += 0.5 * float(li.length)
    elif t == LIGHT_BOX:
        e = li.extent
        r = math.sqrt(float(e[0]) ** 2 + float(e[1]) ** 2 + float(e[2]) ** 2)
    return cx, cy, cz, grow(r, cx, cy, cz)


@numba.njit(inline="always")
def _view_light(li, m):
    """One scene light in view space: its stored float32 position, direction and box right
    axis (as the GPU sees them: float64 transform, rounded once), and its float64 culling
    sphere (centre, radius with the margins of grow())."""
    px, py, pz = _position(li, m)
    dx, dy, dz = _direction(li, m)
    t = li.type
    rx = ry = rz = np.float32(0.0)
    if t == LIGHT_BOX:
        # right = normalize(cross(direction, up)), up' = cross(right, direction) (docs/contracts.md)
        ux, uy, uz = _rotate(m, li.up)
        fx, fy, fz = float(dx), float(dy), float(dz)
        x, y, z = _unit(fy * uz - fz * uy, fz * ux - fx * uz, fx * uy - fy * ux)
        rx, ry, rz = np.float32(x), np.float32(y), np.float32(z)
    cx, cy, cz, r = _sphere(t, li, px, py, pz, dx, dy, dz)
    return px, py, pz, dx, dy, dz, rx, ry, rz, cx, cy, cz, r


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _view_light_call(li, m):
    """_view_light() as a plain call, for the pack's non-point lights (shape_bounds_call
    says why: compile time, the same operations)."""
    return _view_light(li, m)


CULL_BLOCK = 128      # lights a block of the cull: its temporaries stay in L1


@numba.njit(inline="always")
def _culled(cx, cy, cz, r, norm_x, norm_y, near_lo, far_hi, tan_x, tan_y):
    """Whether the sphere is out of the frustum (the tests as the rejections they are: a
    NaN sphere is kept, never dropped); branch-free, a quarter of the lights fail at random,
    which a branch mispredicts."""
    d = -cz
    rx, ry = r * norm_x, r * norm_y
    return ((d + r < near_lo) | (d - r > far_hi) |
            (cx + tan_x * d < -rx) | (-cx + tan_x * d < -rx) |
            (cy + tan_y * d < -ry) | (-cy + tan_y * d < -ry))


@numba.njit(inline="always")
def _cull_range(lights, a, b, m, near, far, tan_x, tan_y, keyed, depth):
    """Frustum test of each light's culling sphere against the near/far planes and the four
    side planes widened by PIXEL_MARGIN (tan_x, tan_y).  The visible lights, in scene order:
    keyed[k] = sort key << 32 | scene id (the key: the float32 bits of the sphere-centre
    depth made to order like the values) and depth[k], that depth in float64.  Returns
    their count.

    The sphere is the pack's (_sphere on the same stored position), computed without the
    direction unless the light is a spot.  The side test is the plane distance
    (c.x + tan_x * depth) / |n| < -r with the division by |n| = sqrt(1 + tan_x^2) moved to
    the right side (a multiplication, not four divisions a light): the two differ by a
    rounding of the last bit, a 1e-16 relative shift of a plane that PIXEL_MARGIN already
    moved out by a pixel (~1e-3 of the depth), so the test stays conservative.

    As the pack, blocks of CULL_BLOCK lights in a few loops: the records' fields gathered
    into one array per value, the view transform, grow()'s square root, the tests and the
    keys of a point light in loops LLVM turns into SIMD code, the other shapes' spheres
    redone by _sphere (the same operations, the same bits), then the visible ones written.

    Lights a .. b-1 only, their visible ones written from index a (of them, fewer): the
    chunks of _cull_chunks."""
    norm_x, norm_y = math.sqrt(1.0 + tan_x * tan_x), math.sqrt(1.0 + tan_y * tan_y)
    near_lo, far_hi = near * (1 - RADIUS_REL_MARGIN), far * (1 + RADIUS_REL_MARGIN)
    m00, m01, m02, m03 = m[0, 0], m[0, 1], m[0, 2], m[0, 3]
    m10, m11, m12, m13 = m[1, 0], m[1, 1], m[1, 2], m[1, 3]
    m20, m21, m22, m23 = m[2, 0], m[2, 1], m[2, 2], m[2, 3]
    wx, wy, wz = np.empty(CULL_BLOCK), np.empty(CULL_BLOCK), np.empty(CULL_BLOCK)
    rad, cz_ = np.empty(CULL_BLOCK), np.empty(CULL_BLOCK)
    key = np.empty(CULL_BLOCK, np.uint64)
    out = np.empty(CULL_BLOCK, np.bool_)
    kind = np.empty(CULL_BLOCK, np.uint8)
    k = np.uint64(a)
    for j0 in range(a, b, CULL_BLOCK):
        nb = np.uint64(min(j0 + CULL_BLOCK, b) - j0)
        J0 = np.uint64(j0)
        for jj in range(nb):                       # unsigned: no wraparound code
            li = lights[J0 + jj]
            wx[jj], wy[jj], wz[jj] = float(li.position[0]), float(li.position[1]), float(li.position[2])
            rad[jj] = float(li.radius)
            kind[jj] = li.type
        for jj in range(nb):                       # SIMD: every light as a point
            x, y, z = wx[jj], wy[jj], wz[jj]
            # (np.float64, not float(): numba's float() of a float32 stays a float32)
            cx = np.float64(np.float32(m00 * x + m01 * y + m02 * z + m03))
            cy = np.float64(np.float32(m10 * x + m11 * y + m12 * z + m13))
            cz = np.float64(np.float32(m20 * x + m21 * y + m22 * z + m23))
            r = grow(rad[jj], cx, cy, cz)
            out[jj] = _culled(cx, cy, cz, r, norm_x, norm_y, near_lo, far_hi, tan_x, tan_y)
            cz_[jj] = cz
        for jj in range(nb):                       # scalar: the other shapes' spheres
            if kind[jj] != LIGHT_POINT:
                li = lights[J0 + jj]
                px, py, pz = _position(li, m)
                t = li.type
                dx = dy = dz = np.float32(0.0)
                if t == LIGHT_SPOT:
                    dx, dy, dz = _direction(li, m)
                cx, cy, cz, r = _sphere(t, li, px, py, pz, dx, dy, dz)
                out[jj] = _culled(cx, cy, cz, r, norm_x, norm_y, near_lo, far_hi, tan_x, tan_y)
                cz_[jj] = cz
        for jj in range(nb):                       # SIMD: the keys
            key[jj] = np.uint64(_float_key(f32_to_bits(np.float32(-cz_[jj]))))
        for jj in range(nb):                       # the visible ones, back to back
            keyed[k] = (key[jj] << np.uint64(32)) | (J0 + jj)   # written always, kept when visible
            depth[k] = -cz_[jj]
            k += np.uint64(0 if out[jj] else 1)
    return np.int64(k) - a


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _cull_chunks(claim, chunks, lights, m, near, far, tan_x, tan_y, keyed, depth, visible):
    """The chunks of lights this thread claims (cpu_prep.share): chunk k's visible lights
    from its first light's index on, their count into visible[k]."""
    n = lights.shape[0]
    k = fetch_add(claim, 0, 1)
    while k < chunks:
        visible[k] = _cull_range(lights, k * n // chunks, (k + 1) * n // chunks, m, near, far,
                                 tan_x, tan_y, keyed, depth)
        fetch_add(claim, 1, 1)
        k = fetch_add(claim, 0, 1)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _close_cull_gaps(n, keyed, depth, visible):
    """The chunks' visible lights moved down to lie back to back, in scene order (a forward
    copy: each chunk's place starts at or before its first light).  Returns their count."""
    chunks = visible.shape[0]
    w = np.uint64(visible[0])
    for k in range(1, chunks):
        a = np.uint64(k * n // chunks)
        for j in range(np.uint64(visible[k])):
            keyed[w + j] = keyed[a + j]
            depth[w + j] = depth[a + j]
        w += np.uint64(visible[k])
    return w


CULL_CHUNKS = 16      # with threads: chunks of lights to claim (a late thread leaves less)


def cull(lights: np.ndarray, cam: FrameCamera, arena: Arena | None = None):
    """(keyed uint64 (K,): depth sort key << 32 | scene id, sphere-centre depths float64
    (K,)) of the K visible lights, in scene order."""
    tx = cam.tan_half_x * (1.0 + 2.0 * PIXEL_MARGIN / cam.width)
    ty = cam.tan_half_y * (1.0 + 2.0 * PIXEL_MARGIN / cam.height)
    n = len(lights)
    keyed = empty(arena, "visible_keys", n, np.uint64)
    depth = empty(arena, "visible_depths", n, np.float64)
    chunks = max(min(n, CULL_CHUNKS), 1) if parallel() else 1
    visible = np.empty(chunks, np.int64)
    share.run(_cull_chunks, chunks, lights, cam.view_from_world, cam.near, cam.far, tx, ty,
              keyed, depth, visible)
    k = int(visible[0]) if chunks == 1 else int(_close_cull_gaps(n, keyed, depth, visible))
    return keyed[:k], depth[:k]


# ---- sort ------------------------------------------------------------------------------
RADIX_BITS = 11
RADIX = 1 << RADIX_BITS


@numba.njit(inline="always")
def _float_key(f32_bits):
    """float32 bits made to order like the values: flip all bits of negatives, the sign of
    positives (-0.0 sorts just before +0.0, as the earlier sort did)."""
    if f32_bits >> np.uint32(31):
        return ~f32_bits
    return f32_bits | np.uint32(0x80000000)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _radix_sort(a, b):
    """Stable LSD radix sort of the uint64 values in `a` on their high 32 bits (the key),
    three passes of 11, 11 and 10 bits, the histograms of all three counted in one pass; a
    pass whose digit is the same for every value is skipped.  Returns the sorted array
    (a or b; the other is scratch)."""
    n = a.shape[0]
    hist = np.zeros((3, RADIX), np.int64)
    mask = np.uint64(RADIX - 1)
    for k in range(n):
        key = a[k] >> np.uint64(32)
        hist[0, key & mask] += 1
        hist[1, (key >> np.uint64(RADIX_BITS)) & mask] += 1
        hist[2, key >> np.uint64(2 * RADIX_BITS)] += 1
    src, dst = a, b
    for p in range(3):
        h = hist[p]
        if h.max() == n:
            continue                       # every key has this digit: the pass moves nothing
        total = 0
        for d in range(RADIX):
            c = h[d]
            h[d] = total
            total += c
        shift = np.uint64(32 + RADIX_BITS * p)
        for k in range(n):
            v = src[k]
            d = (v >> shift) & mask
            dst[np.uint64(h[d])] = v
            h[d] += 1
        src, dst = dst, src
    return src


def sort_ids(keyed: np.ndarray, depth: np.ndarray, buckets: int = 0,
             arena: Arena | None = None) -> np.ndarray:
    """The visible lights (cull()'s keyed values) in depth order, uint64, scene ids in the
    low 32 bits.  Ties keep scene order.  buckets > 0 gives depth_order()'s approximate
    bucket sort instead.  `keyed` (the cull's array) is used as scratch."""
    n = len(keyed)
    b = empty(arena, "sort_scratch", n, np.uint64)
    if buckets > 0 and n:
        np.take(keyed, _bucket_order(np.ascontiguousarray(depth, np.float64), buckets), out=b)
        return b
    return _radix_sort(keyed, b)


@numba.njit(cache=True, nogil=True, error_model="numpy")
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


@numba.njit(cache=True, nogil=True, error_model="numpy")
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


# ---- pack ------------------------------------------------------------------------------

# GPU_LIGHT's six 16-byte fields (POS, COLOR, DIR, ID_TYPE, EXT, RIGHT in _row_nt) by word
# offset: the order the streaming stores write them in
_ROW_ORDER = tuple(int(k) for k in np.argsort([POS, COLOR, DIR, ID_TYPE, EXT, RIGHT]))
assert sorted([POS, COLOR, DIR, ID_TYPE, EXT, RIGHT]) == list(range(0, LIGHT_WORDS, 4))
PACK_BLOCK = 128      # lights a block: its temporaries stay in L1 between the block's loops
PACK_CHUNKS = 32      # with threads: chunks of blocks to claim (a late thread leaves less)
_WX, _WY, _WZ, _UX, _UY, _UZ, _RAD = 0, 1, 2, 3, 4, 5, 6        # gathered (world)
_COS, _LEN, _EX, _EY, _EZ = 7, 8, 9, 10, 11                        # gathered (shape)
_PX, _PY, _PZ, _DX, _DY, _DZ = 12, 13, 14, 15, 16, 17             # stored position, direction
_RX, _RY, _RZ = 18, 19, 20                                        # stored box right axis
_CX, _CY, _CZ, _R = 21, 22, 23, 24                                # culling sphere
_X0, _X1, _Y0, _Y1 = 25, 26, 27, 28                               # screen rectangle
_CR, _CG, _CB, _CIN = 29, 30, 31, 32                              # colour * intensity, cos inner
_TEMPS = 33


@numba.njit(inline="always")
def _f32(tmp, k, jj):
    """A temporary holding a float32 value, as the float32 it is (exact)."""
    return np.float32(tmp[k, jj])


@numba.njit(inline="always")
def _row_nt(rows, j, tmp, jj, i, t):
    """Row j of GPU_LIGHT from the block temporaries, one streaming 16-byte store a field."""
    fields = ((POS, _f32(tmp, _PX, jj), _f32(tmp, _PY, jj), _f32(tmp, _PZ, jj), _f32(tmp, _RAD, jj)),
              (COLOR, _f32(tmp, _CR, jj), _f32(tmp, _CG, jj), _f32(tmp, _CB, jj), _f32(tmp, _CIN, jj)),
              (DIR, _f32(tmp, _DX, jj), _f32(tmp, _DY, jj), _f32(tmp, _DZ, jj), _f32(tmp, _COS, jj)),
              (ID_TYPE, bits_to_f32(np.uint32(i)), bits_to_f32(np.uint32(t)), bits_to_f32(np.uint32(0)),
               bits_to_f32(np.uint32(0))),
              (EXT, _f32(tmp, _EX, jj), _f32(tmp, _EY, jj), _f32(tmp, _EZ, jj), _f32(tmp, _LEN, jj)),
              (RIGHT, _f32(tmp, _RX, jj), _f32(tmp, _RY, jj), _f32(tmp, _RZ, jj), np.float32(0.0)))
    for f in _ROW_ORDER:
        w, a, b, c, d = fields[f]
        store4_nt(rows, j, w, a, b, c, d)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _pack_chunks(claim, chunks, lights, sorted_ids, m, near, tan_x, tan_y, width, height,
                 rows, types, sphere, rect, bound, lo, hi):
    """The blocks of the chunks this thread claims (cpu_prep.share).

    Each block, lights j0 .. j1-1 of the depth order, as a few loops over the block.  The
    scalar loops gather scene records and write the GPU rows, one 16-byte field at a time with
    streaming stores (through the word offsets generated from the dtype); the arithmetic of
    the common case runs in loops over block temporaries laid out one array per value,
    which LLVM turns into SIMD code (the view transform, the direction's square root and
    division, grow()'s square root, the screen rectangle's square roots and divisions).
    The cases off the common path (a light not a point, a sphere reaching the near plane,
    a shape with its own cover) are then redone by the scalar functions: every value is
    the one _view_light() and shape_bounds() give, bit for bit (the same IEEE operations
    in the same order; no fastmath, so no reassociation or fused multiply-add)."""
    n = sorted_ids.shape[0]
    blocks = (n + PACK_BLOCK - 1) // PACK_BLOCK
    tmp = np.empty((_TEMPS, PACK_BLOCK))
    kind = np.empty(PACK_BLOCK, np.uint8)
    slow = np.empty(PACK_BLOCK, np.uint8)
    k = fetch_add(claim, 0, 1)
    while k < chunks:
        for b in range(k * blocks // chunks, (k + 1) * blocks // chunks):
            j0 = b * PACK_BLOCK
            j1 = min(j0 + PACK_BLOCK, n)
            # (the block's loops written out here, not an inline="always" function:
            # numba deep-copied that function's IR, scope and all, into this kernel,
            # 3-4 s of the cold compile; as a plain call the warm pack took 0.5 ms more)
            nb = j1 - j0
            J0 = np.uint64(j0)
            # 1. gather: scene record -> temporaries, and the GPU row's fields copied from it
            for j in range(J0, np.uint64(j1)):                 # unsigned: no wraparound code
                jj = j - J0
                prefetch_ahead(lights, sorted_ids, j)
                i = sorted_ids[j] & np.uint64(0xFFFFFFFF)
                li = lights[i]
                tmp[_WX, jj], tmp[_WY, jj], tmp[_WZ, jj] = float(li.position[0]), float(li.position[1]), float(li.position[2])
                tmp[_UX, jj], tmp[_UY, jj], tmp[_UZ, jj] = float(li.direction[0]), float(li.direction[1]), float(li.direction[2])
                tmp[_RAD, jj], tmp[_COS, jj], tmp[_LEN, jj] = float(li.radius), float(li.cos_outer), float(li.length)
                tmp[_EX, jj], tmp[_EY, jj], tmp[_EZ, jj] = float(li.extent[0]), float(li.extent[1]), float(li.extent[2])
                t = li.type
                kind[jj] = t
                types[j] = t
                slow[jj] = 0 if sphere_only(t, float(li.cos_outer), float(li.length)) else 1
                tmp[_CR, jj], tmp[_CG, jj] = li.color[0] * li.intensity, li.color[1] * li.intensity
                tmp[_CB, jj], tmp[_CIN, jj] = li.color[2] * li.intensity, li.cos_inner
            # 2. SIMD: view transform, unit direction, a point light's culling sphere
            m00, m01, m02, m03 = m[0, 0], m[0, 1], m[0, 2], m[0, 3]
            m10, m11, m12, m13 = m[1, 0], m[1, 1], m[1, 2], m[1, 3]
            m20, m21, m22, m23 = m[2, 0], m[2, 1], m[2, 2], m[2, 3]
            for jj in range(np.uint64(nb)):
                x, y, z = tmp[_WX, jj], tmp[_WY, jj], tmp[_WZ, jj]
                # (np.float64, not float(): numba's float() of a float32 stays a float32)
                px = np.float64(np.float32(m00 * x + m01 * y + m02 * z + m03))
                py = np.float64(np.float32(m10 * x + m11 * y + m12 * z + m13))
                pz = np.float64(np.float32(m20 * x + m21 * y + m22 * z + m23))
                x, y, z = tmp[_UX, jj], tmp[_UY, jj], tmp[_UZ, jj]
                ux, uy, uz = (m00 * x + m01 * y + m02 * z, m10 * x + m11 * y + m12 * z,
                              m20 * x + m21 * y + m22 * z)
                ux, uy, uz = _unit(ux, uy, uz)
                tmp[_PX, jj], tmp[_PY, jj], tmp[_PZ, jj] = px, py, pz
                tmp[_DX, jj], tmp[_DY, jj], tmp[_DZ, jj] = np.float32(ux), np.float32(uy), np.float32(uz)
                tmp[_RX, jj], tmp[_RY, jj], tmp[_RZ, jj] = 0.0, 0.0, 0.0
                tmp[_CX, jj], tmp[_CY, jj], tmp[_CZ, jj] = px, py, pz
                tmp[_R, jj] = grow(tmp[_RAD, jj], px, py, pz)
            # 3. scalar: the other shapes' spheres (and a box's right axis); the rows' view fields
            for j in range(J0, np.uint64(j1)):
                jj = j - J0
                if kind[jj] != LIGHT_POINT:
                    li = lights[sorted_ids[j] & np.uint64(0xFFFFFFFF)]
                    _, _, _, _, _, _, rx, ry, rz, cx, cy, cz, r = _view_light_call(li, m)
                    tmp[_RX, jj], tmp[_RY, jj], tmp[_RZ, jj] = rx, ry, rz
                    tmp[_CX, jj], tmp[_CY, jj], tmp[_CZ, jj], tmp[_R, jj] = cx, cy, cz, r
                # the whole row, its 16-byte fields in memory order, so that the streaming stores of
                # consecutive rows fill whole cache lines in the write-combining buffers
                _row_nt(rows, j, tmp, jj, sorted_ids[j] & np.uint64(0xFFFFFFFF), kind[jj])
                cx, cy, cz, r = tmp[_CX, jj], tmp[_CY, jj], tmp[_CZ, jj], tmp[_R, jj]
                store4_nt(sphere, j, 0, cx, cy, cz, r)     # (not read again in the CPU stage)
                # float32, rounded outwards: the GPU's float32 comparisons stay conservative.
                # (The stored centre's rounding is in grow()'s 4-ulp term; round the radius up.)
                store4_nt(bound, j, 0, np.float32(cx), np.float32(cy), np.float32(cz), next_up_f32(np.float32(r)))
            # 4. SIMD: the rectangle and depth range of a sphere in front of the near plane
            zn = -near
            for jj in range(np.uint64(nb)):
                cx, cy, cz, r = tmp[_CX, jj], tmp[_CY, jj], tmp[_CZ, jj], tmp[_R, jj]
                lx, hx = project_axis_ahead(cx, cz, r, tan_x)
                ly, hy = project_axis_ahead(cy, cz, r, tan_y)
                tmp[_X0, jj], tmp[_X1, jj], tmp[_Y0, jj], tmp[_Y1, jj] = ndc_rect(lx, hx, ly, hy, width, height)
                lo[J0 + jj] = next_down_f32(np.float32(-cz - r))
                hi[J0 + jj] = next_up_f32(np.float32(-cz + r))
                slow[jj] |= 0 if cz + r < zn else 1
            # 5. scalar: the rest through shape_bounds() (on the stored float32 values, as the
            #    GPU tests them); the rectangles
            for j in range(J0, np.uint64(j1)):
                jj = j - J0
                if slow[jj]:
                    x0, x1, y0, y1, d0, d1 = shape_bounds_call(
                        kind[jj], _f32(tmp, _PX, jj), _f32(tmp, _PY, jj), _f32(tmp, _PZ, jj),
                        _f32(tmp, _DX, jj), _f32(tmp, _DY, jj), _f32(tmp, _DZ, jj),
                        _f32(tmp, _RX, jj), _f32(tmp, _RY, jj), _f32(tmp, _RZ, jj),
                        _f32(tmp, _RAD, jj), _f32(tmp, _COS, jj), _f32(tmp, _LEN, jj),
                        _f32(tmp, _EX, jj), _f32(tmp, _EY, jj), _f32(tmp, _EZ, jj),
                        tmp[_CX, jj], tmp[_CY, jj], tmp[_CZ, jj], tmp[_R, jj],
                        near, tan_x, tan_y, width, height)
                    tmp[_X0, jj], tmp[_X1, jj], tmp[_Y0, jj], tmp[_Y1, jj] = x0, x1, y0, y1
                    lo[j] = next_down_f32(np.float32(d0))
                    hi[j] = next_up_f32(np.float32(d1))
                rect[j, 0], rect[j, 1], rect[j, 2], rect[j, 3] = tmp[_X0, jj], tmp[_X1, jj], tmp[_Y0, jj], tmp[_Y1, jj]
            store_fence()
        fetch_add(claim, 1, 1)
        k = fetch_add(claim, 0, 1)


def pack(lights: np.ndarray, cam: FrameCamera, sorted_ids: np.ndarray,
         arena: Arena | None = None) -> PreparedLights:
    """GPU_LIGHT / GPU_BOUND, culling spheres, rectangles and the float32 depth ranges of
    the lights `sorted_ids` (sort_ids(): ids in the low 32 bits), in that order."""
    n = len(sorted_ids)
    gpu = empty(arena, "gpu_lights", (n, LIGHT_WORDS), np.float32)
    spheres = empty(arena, "sorted_spheres", (n, 4), np.float64)
    rect = empty(arena, "sorted_rects", (n, 4), np.float64)
    bound = empty(arena, "gpu_bounds", (n, 4), np.float32)
    lo, hi = empty(arena, "depth_lo", n, np.float32), empty(arena, "depth_hi", n, np.float32)
    types = empty(arena, "light_types", n, np.uint8)
    blocks = -(-n // PACK_BLOCK)
    share.run(_pack_chunks, min(blocks, PACK_CHUNKS) if parallel() else 1, lights, sorted_ids,
              cam.view_from_world, cam.near, cam.tan_half_x, cam.tan_half_y, float(cam.width),
              float(cam.height), gpu, types, spheres, rect, bound, lo, hi)
    rec = gpu.view(layouts.GPU_LIGHT).reshape(n)
    return PreparedLights(ids=rec["id_type"][:, 0], type=types,
                          center=spheres[:, :3], bound_radius=spheres[:, 3], rect=rect, gpu=rec,
                          bounds=bound.view(layouts.GPU_BOUND).reshape(n), depth_lo=lo, depth_hi=hi)
