"""The hybrid's per-cell choice between a list and a tree (tree paper 3.3, listing 2):

    sum of each light's depth extent clipped to the cell / light count  <  cell.radius
        -> tree, else list.

`cell.radius` is not defined in the paper; it is read here as half the cell's depth extent
times `radius_scale` (a parameter, 1.0 by default, swept in the benchmark).  Cells of the last
slice reach to infinity; their extent is clipped to the scene's max depth.
"""
from __future__ import annotations

import numba
import numpy as np

from .grid import Grid


@numba.njit(cache=True, nogil=True, parallel=True)
def _choose(offsets, entries, depth_lo, depth_hi, slice_lo, slice_hi, slices, radius_scale):
    cells = offsets.shape[0] - 1
    out = np.zeros(cells, np.bool_)
    for c in numba.prange(cells):
        n = offsets[c + 1] - offsets[c]
        if n == 0:
            continue
        s = c % slices                 # cells are tile-major (cpu_prep.grid)
        lo, hi = slice_lo[s], slice_hi[s]
        total = 0.0
        for e in range(offsets[c], offsets[c + 1]):
            i = entries[e]
            total += max(min(float(depth_hi[i]), hi) - max(float(depth_lo[i]), lo), 0.0)
        out[c] = total / n < 0.5 * (hi - lo) * radius_scale
    return out


def choose_trees(grid: Grid, offsets, entries, depth_lo, depth_hi, max_depth: float,
                 radius_scale: float = 1.0) -> np.ndarray:
    lo_s, hi_s = grid.slice_bounds()
    hi_s = np.minimum(hi_s, max(max_depth, lo_s[-1]))
    return _choose(offsets, entries, depth_lo, depth_hi, lo_s, hi_s,
                   grid.slices, float(radius_scale))
