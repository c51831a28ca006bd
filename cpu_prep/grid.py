"""Screen tiles and the 2.5D frustum grid: depth slices (tree paper listing 4), each light's
box of cells, and the scatter of lights into per-cell index lists (CSR).

    cell id = (slice * tiles_y + ty) * tiles_x + tx        (tx, ty from the bottom-left, GL)
    offsets[cell] .. offsets[cell+1]  ->  entries[]  (positions in the depth-sorted light list)

Lights arrive sorted by depth and the scatter walks them in that order, so every cell's list
comes out depth-sorted with no per-cell sort (tree paper 3.2).
"""
from __future__ import annotations

from dataclasses import dataclass
import math

import numba
import numpy as np

from .camera import FrameCamera
from .limits import SLICE_DEPTH_REL_MARGIN


@dataclass(frozen=True)
class Grid:
    width: int
    height: int
    tile: int
    slices: int             # 1 = plain 2D tiles
    log_min: float          # log of the near slice's far end
    log_max: float          # log of the max depth worth slicing

    @property
    def tiles_x(self) -> int:
        return -(-self.width // self.tile)

    @property
    def tiles_y(self) -> int:
        return -(-self.height // self.tile)

    @property
    def cells(self) -> int:
        return self.tiles_x * self.tiles_y * self.slices

    # Listing 4 as printed computes scale = 1 / ((logMax - logMin) * (S - 1)), which crowds
    # every depth past the near slice into slices 1-2.  The intent (slice 0 the near slice,
    # 1..S-1 exponential over [minDepth, maxDepth]) is scale = (S - 1) / (logMax - logMin).
    @property
    def slice_scale(self) -> float:
        return (self.slices - 1) / (self.log_max - self.log_min) if self.slices > 1 else 0.0

    @property
    def slice_bias(self) -> float:
        return 1.0 - self.log_min * self.slice_scale if self.slices > 1 else 0.0

    def slice_of(self, depth) -> np.ndarray:
        """Listing 4 (with the scale corrected), float64; depth <= 0 goes to slice 0."""
        depth = np.asarray(depth, np.float64)
        if self.slices == 1:
            return np.zeros(depth.shape, np.int64)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.log(np.where(depth > 0, depth, 1e-300)) * self.slice_scale + self.slice_bias
        return np.minimum(np.maximum(s, 0.0).astype(np.int64), self.slices - 1)

    def slice_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Depth range [near, far) of each slice; slice 0 starts at 0, the last ends at inf."""
        k = np.arange(self.slices, dtype=np.float64)
        lo = np.exp((k - self.slice_bias) / self.slice_scale) if self.slices > 1 else np.zeros(1)
        lo[0] = 0.0
        hi = np.append(lo[1:], np.inf)
        return lo, hi


def make_grid(cam: FrameCamera, tile: int, slices: int, max_depth: float,
              near_slice_depth: float) -> Grid:
    if tile < 1 or slices < 1:
        raise ValueError(f"tile ({tile}) and slices ({slices}) must be >= 1")
    max_depth = max(float(max_depth), cam.near * 4)
    # The near slice ends at near_slice_depth (Persson: 5 m), but never past a tenth of the
    # sliced range, so small interiors still get exponential slices.
    min_depth = min(near_slice_depth, max_depth / 10)
    return Grid(cam.width, cam.height, tile, slices, math.log(min_depth), math.log(max_depth))


def cell_boxes(grid: Grid, rect, depth_lo, depth_hi):
    """Each light's inclusive box of cells: (tx0, tx1, ty0, ty1, s0, s1) as int32 arrays,
    clamped to the grid.  Boxes of lights off the screen come out empty (tx0 > tx1 ...)."""
    x0, x1, y0, y1 = rect
    t = grid.tile
    # floor of the continuous pixel extent: pixel p (centre p + 0.5) is in tile p // t
    tx0 = np.maximum(np.floor(x0 / t), 0)
    tx1 = np.minimum(np.floor(x1 / t), grid.tiles_x - 1)
    ty0 = np.maximum(np.floor(y0 / t), 0)
    ty1 = np.minimum(np.floor(y1 / t), grid.tiles_y - 1)
    s0 = grid.slice_of(depth_lo * (1 - SLICE_DEPTH_REL_MARGIN))
    s1 = grid.slice_of(depth_hi * (1 + SLICE_DEPTH_REL_MARGIN))
    return tuple(a.astype(np.int32) for a in (tx0, tx1, ty0, ty1, s0, s1))


@numba.njit(cache=True, nogil=True)
def _scatter(tx0, tx1, ty0, ty1, s0, s1, tiles_x, tiles_y, cells):
    n = tx0.shape[0]
    offsets = np.zeros(cells + 1, np.int64)
    for i in range(n):
        for s in range(s0[i], s1[i] + 1):
            for ty in range(ty0[i], ty1[i] + 1):
                row = (s * tiles_y + ty) * tiles_x
                for tx in range(tx0[i], tx1[i] + 1):
                    offsets[row + tx + 1] += 1
    for c in range(cells):
        offsets[c + 1] += offsets[c]
    entries = np.empty(offsets[cells], np.uint32)
    cursor = offsets[:cells].copy()
    for i in range(n):
        for s in range(s0[i], s1[i] + 1):
            for ty in range(ty0[i], ty1[i] + 1):
                row = (s * tiles_y + ty) * tiles_x
                for tx in range(tx0[i], tx1[i] + 1):
                    entries[cursor[row + tx]] = i
                    cursor[row + tx] += 1
    return offsets, entries


def scatter(grid: Grid, boxes) -> tuple[np.ndarray, np.ndarray]:
    """CSR (offsets int64 of length cells+1, entries uint32) of lights per cell; `boxes`
    from cell_boxes() for lights in depth order, so each cell's entries are depth-sorted."""
    return _scatter(*boxes, grid.tiles_x, grid.tiles_y, grid.cells)
