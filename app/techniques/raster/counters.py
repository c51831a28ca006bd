"""raster's untimed twin of the culling passes, read back after the frame (meta stats):
fragments, atomics and marks, and the lights occlusion removed."""
from __future__ import annotations

import numpy as np

from ..blocks import tile_boxes


def raster_counters(build, got):
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
    occluded = kept_by_tile_depth(boxes[unmarked], pl.depth_lo[unmarked], pl.depth_hi[unmarked],
                                   covered, lo, hi)
    build.stats.update(
        raster_fragments=int(c[0]), raster_atomics=int(c[1]), raster_marks=int(per_light.sum()),
        rect_marks=int(rect_tiles.sum()), unmarked_lights=int(len(unmarked)),
        occluded_lights=int(occluded), raster_pixel_marks=int(c[2]))
    return {}, []


def kept_by_tile_depth(boxes, depth_lo, depth_hi, covered, lo, hi,
                        pairs_per_step: int = 1 << 22) -> int:
    """How many of these lights a tile depth-bounds test (tiled's) would keep: some covered
    tile of the light's rectangle (boxes: x0, x1, y0, y1 inclusive) whose depth range meets
    the light's.  Every (light, tile) pair at once, in steps of at most `pairs_per_step`
    pairs (one light's rectangle may be the whole screen)."""
    w = (boxes[:, 1] - boxes[:, 0] + 1).astype(np.int64)
    h = (boxes[:, 3] - boxes[:, 2] + 1).astype(np.int64)
    n = w * h
    ends = np.cumsum(n)
    kept, first = 0, 0
    while first < len(n):
        last = max(first + 1, int(np.searchsorted(ends, ends[first] - n[first] + pairs_per_step, "right")))
        own = np.repeat(np.arange(first, last), n[first:last])
        starts = ends[first:last] - n[first:last]
        k = np.arange(len(own)) + starts[0] - np.repeat(starts, n[first:last])   # tile of its box
        tx = boxes[own, 0] + k % w[own]
        ty = boxes[own, 2] + k // w[own]
        keep = covered[ty, tx] & (lo[ty, tx] <= depth_hi[own]) & (hi[ty, tx] >= depth_lo[own])
        kept += len(np.unique(own[keep]))
        first = last
    return kept
