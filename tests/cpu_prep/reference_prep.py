"""The CPU stage written plainly: the reference the optimized kernels of cpu_prep are held
to (tests/cpu_prep/test_prep_equivalence.py).  It is the stage as it was before it was
profiled: one kernel for the cull that writes every visible light's GPU row,
sphere and shape bounds in scene order, a numpy stable sort, numpy gathers for the pack,
listing 4's logarithm for the slices, a division for the tiles, and Python loops for the
scatter, listing 2 and the trees.  Slow; for test-sized frames only.

The shape bounds themselves are cpu_prep.bounds' (tests/cpu_prep/test_bounds.py holds
them to sampled volumes, and project_axis' fast path to listing 1's general form), and a light
in view space (its stored position, direction, box axis and culling sphere) is the cull
kernel's (cpu_prep.lights._view_light): what the reference re-derives is what profiling
changed, the cull's order, the sort, the pack, the binning and the builds.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from cpu_prep import layouts
from cpu_prep.bounds import shape_bounds
from cpu_prep.lights import _view_light as view_light     # the cull kernel's, margins and all
from cpu_prep.layouts import (LIGHT_COLOR_COS_INNER as COLOR, LIGHT_DIR_COS_OUTER as DIR,
                              LIGHT_EXTENT_LENGTH as EXT, LIGHT_ID_TYPE as ID_TYPE,
                              LIGHT_POS_RADIUS as POS, LIGHT_RIGHT as RIGHT, LIGHT_WORDS,
                              NODE_BITS, NODE_FIRST_LIGHT, NODE_MAX_DEPTH, NODE_MIN_DEPTH,
                              NODE_WORDS)
from cpu_prep.limits import (NODE_COUNT_BITS, NODE_MAX_LIGHTS, PIXEL_MARGIN,
                             RADIUS_REL_MARGIN, SLICE_DEPTH_REL_MARGIN)
from cpu_prep.tree import depth_first_tables


@numba.njit(cache=True)
def _view_cull(lights, m, near, far, tan_x, tan_y, tan_rx, tan_ry, width, height,
               rows, rows_u, sphere, shape):
    n = lights.shape[0]
    norm_x, norm_y = math.sqrt(1.0 + tan_x * tan_x), math.sqrt(1.0 + tan_y * tan_y)
    k = 0
    for i in range(n):
        li = lights[i]
        px, py, pz, dx, dy, dz, rx, ry, rz, cx, cy, cz, r = view_light(li, m)
        depth = -cz
        if depth + r < near * (1 - RADIUS_REL_MARGIN) or depth - r > far * (1 + RADIUS_REL_MARGIN):
            continue
        if (cx + tan_x * depth) / norm_x < -r or (-cx + tan_x * depth) / norm_x < -r:
            continue
        if (cy + tan_y * depth) / norm_y < -r or (-cy + tan_y * depth) / norm_y < -r:
            continue
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
        shape[k] = shape_bounds(li.type, float(px), float(py), float(pz), float(dx), float(dy), float(dz),
                                float(rx), float(ry), float(rz), float(li.radius),
                                float(li.cos_outer), float(li.length), float(li.extent[0]),
                                float(li.extent[1]), float(li.extent[2]), cx, cy, cz, r,
                                near, tan_rx, tan_ry, width, height)
        k += 1
    return k


def sort_order(depth: np.ndarray, buckets: int = 0) -> np.ndarray:
    """Stable order by float32(depth), ties by position; buckets > 0: equal depth buckets."""
    if buckets > 0 and len(depth):
        lo, hi = depth.min(), depth.max()
        scale = buckets / max(hi - lo, 1e-30)
        key = np.minimum(((depth - lo) * scale).astype(np.int64), buckets - 1)
        return np.argsort(key, kind="stable")
    return np.argsort(depth.astype(np.float32), kind="stable")


def prepare(lights: np.ndarray, cam, buckets: int = 0) -> dict:
    """Every PreparedLights field of a frame, as arrays."""
    tx = cam.tan_half_x * (1.0 + 2.0 * PIXEL_MARGIN / cam.width)
    ty = cam.tan_half_y * (1.0 + 2.0 * PIXEL_MARGIN / cam.height)
    n = len(lights)
    rows = np.empty((n, LIGHT_WORDS), np.float32)
    sphere = np.empty((n, 4))
    shape = np.empty((n, 6))
    k = _view_cull(lights, cam.view_from_world, cam.near, cam.far, tx, ty, cam.tan_half_x,
                   cam.tan_half_y, float(cam.width), float(cam.height), rows,
                   rows.view(np.uint32), sphere, shape)
    rows, sphere, shape = rows[:k], sphere[:k], shape[:k]
    order = sort_order(-sphere[:, 2], buckets)
    gpu = rows[order].view(layouts.GPU_LIGHT).reshape(k)
    sph, shp = sphere[order], shape[order]
    bounds = sph.astype(np.float32)
    bounds[:, 3] = np.nextafter(sph[:, 3].astype(np.float32), np.float32(np.inf))
    return dict(ids=gpu["id_type"][:, 0], type=gpu["id_type"][:, 1].astype(np.uint8),
                center=sph[:, :3], bound_radius=sph[:, 3], rect=shp[:, :4], gpu=gpu,
                bounds=bounds.view(layouts.GPU_BOUND).reshape(k),
                depth_lo=np.nextafter(shp[:, 4].astype(np.float32), np.float32(-np.inf)),
                depth_hi=np.nextafter(shp[:, 5].astype(np.float32), np.float32(np.inf)))


def boxes(grid, rect, depth_lo, depth_hi) -> np.ndarray:
    """Each light's cell box: floor(x / tile) clamped, listing 4's slice (a logarithm) of
    the depth range widened by SLICE_DEPTH_REL_MARGIN; (1, 0, 1, 0, 1, 0) when empty."""
    rect = np.asarray(rect, np.float64)
    lo, hi = np.asarray(depth_lo, np.float64), np.asarray(depth_hi, np.float64)
    out = np.empty((len(rect), 6), np.int64)
    with np.errstate(invalid="ignore"):
        ok = (rect[:, 0] <= rect[:, 1]) & (rect[:, 2] <= rect[:, 3]) & (lo <= hi)
        x0 = np.clip(np.floor(rect[:, 0] / grid.tile), 0, None)
        x1 = np.clip(np.floor(rect[:, 1] / grid.tile), None, grid.tiles_x - 1)
        y0 = np.clip(np.floor(rect[:, 2] / grid.tile), 0, None)
        y1 = np.clip(np.floor(rect[:, 3] / grid.tile), None, grid.tiles_y - 1)
    out[:, 0], out[:, 1], out[:, 2], out[:, 3] = (np.where(ok, v, 0).astype(np.int64) for v in (x0, x1, y0, y1))
    out[:, 4] = grid.slice_of(np.where(ok, lo, 0.0) * (1.0 - SLICE_DEPTH_REL_MARGIN))
    out[:, 5] = grid.slice_of(np.where(ok, hi, 0.0) * (1.0 + SLICE_DEPTH_REL_MARGIN))
    out[~ok] = (1, 0, 1, 0, 1, 0)
    return out


def scatter(grid, box) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists of the boxes' lights, each cell's in light order (tile-major cells)."""
    lists = [[] for _ in range(grid.cells)]
    for i, (x0, x1, y0, y1, s0, s1) in enumerate(box.tolist()):
        for ty in range(y0, y1 + 1):
            for tx in range(x0, x1 + 1):
                for s in range(s0, s1 + 1):
                    lists[(ty * grid.tiles_x + tx) * grid.slices + s].append(i)
    offsets = np.zeros(grid.cells + 1, np.int64)
    offsets[1:] = np.cumsum([len(l) for l in lists])
    return offsets, np.array([i for l in lists for i in l], np.uint32)


def choose(grid, offsets, entries, depth_lo, depth_hi, max_depth, radius_scale=1.0):
    """Listing 2: mean clipped depth extent < cell radius -> tree (float64, entry order)."""
    lo_s, hi_s = grid.slice_bounds()
    hi_s = np.minimum(hi_s, max(max_depth, lo_s[-1]))
    # every cell's float64 sum in its own entry order, all cells a step at a time (step j
    # adds each cell's j-th entry): the order of a plain loop per cell, at numpy speed
    offsets = np.asarray(offsets, np.int64)
    n = offsets[1:] - offsets[:-1]
    s = np.arange(len(n)) % grid.slices
    lo, hi = lo_s[s], hi_s[s]
    total = np.zeros(len(n))
    for j in range(int(n.max(initial=0))):
        c = np.nonzero(n > j)[0]
        i = entries[offsets[c] + j]
        total[c] += np.maximum(np.minimum(depth_hi[i].astype(np.float64), hi[c])
                               - np.maximum(depth_lo[i].astype(np.float64), lo[c]), 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (n > 0) & (total / n < 0.5 * (hi - lo) * radius_scale)


def trees(offsets, entries, depth_lo, depth_hi, is_tree, lights_per_leaf, max_leaves):
    """(ranges, nodes, leaves): per cell a full tree of balanced leaf runs, bottom-up,
    breadth-first to depth-first, skip counts (tree paper 3.1-3.2, listing 1)."""
    cells = len(offsets) - 1
    ranges = np.zeros(cells, layouts.CELL_RANGE)
    leaves = np.zeros(cells, np.int64)
    out = []
    pow2 = lambda x: 1 << max(int(x) - 1, 0).bit_length()
    for c in range(cells):
        o, n = int(offsets[c]), int(offsets[c + 1] - offsets[c])
        ranges["offset_count"][c] = (len(out), 0)
        if n == 0:
            continue
        L = min(pow2(-(-n // lights_per_leaf)), max_leaves) if is_tree[c] else 1
        L = max(L, pow2(-(-n // NODE_MAX_LIGHTS)))
        leaves[c] = L
        size = 2 * L - 1
        bf = [None] * size
        for j in range(L):
            a, b = o + (j * n) // L, o + ((j + 1) * n) // L
            lo = min((depth_lo[entries[e]] for e in range(a, b)), default=np.float32(np.inf))
            hi = max((depth_hi[entries[e]] for e in range(a, b)), default=np.float32(-np.inf))
            bf[L - 1 + j] = (np.float32(lo), np.float32(hi), a, b - a)
        for q in range(L - 2, -1, -1):
            l, r = bf[2 * q + 1], bf[2 * q + 2]
            bf[q] = (min(l[0], r[0]), max(l[1], r[1]), l[2], 0)
        order, skip, is_leaf = depth_first_tables(L)
        for q in range(size):
            lo, hi, first, count = bf[order[q]]
            bits = int(is_leaf[q]) | (count << 1) | (int(skip[q]) << (1 + NODE_COUNT_BITS))
            out.append((lo, hi, first, bits))
        ranges["offset_count"][c, 1] = size
    raw = np.zeros((len(out), NODE_WORDS), np.float32)
    raw_u = raw.view(np.uint32)
    for k, (lo, hi, first, bits) in enumerate(out):
        raw[k, NODE_MIN_DEPTH], raw[k, NODE_MAX_DEPTH] = lo, hi
        raw_u[k, NODE_FIRST_LIGHT], raw_u[k, NODE_BITS] = first, bits
    return ranges, raw.view(layouts.TREE_NODE).reshape(-1), leaves
