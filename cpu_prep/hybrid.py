"""The hybrid's per-cell choice between a list and a tree (tree paper 3.3, listing 2):

    sum of each light's depth extent clipped to the cell / light count  <  cell.radius
        -> tree, else list.

`cell.radius` is not defined in the paper; it is read here as half the cell's depth extent
times `radius_scale` (a parameter, 1.0 by default, swept in the benchmark).  Cells of the last
slice reach to infinity; their extent is clipped to the scene's max depth.
"""
from __future__ import annotations

import numpy as np

from .grid import Grid


def choose_trees(grid: Grid, offsets, entries, depth_lo, depth_hi, max_depth: float,
                 radius_scale: float = 1.0) -> np.ndarray:
    counts = np.diff(offsets)
    per_slice = grid.tiles_x * grid.tiles_y
    lo_s, hi_s = grid.slice_bounds()
    hi_s = np.minimum(hi_s, max(max_depth, lo_s[-1]))
    cell_slice = np.repeat(np.arange(grid.slices), per_slice)
    entry_cell = np.repeat(np.arange(grid.cells), counts)
    c_lo = lo_s[cell_slice][entry_cell]
    c_hi = hi_s[cell_slice][entry_cell]
    clipped = np.minimum(depth_hi[entries], c_hi) - np.maximum(depth_lo[entries], c_lo)
    sums = np.bincount(entry_cell, weights=np.maximum(clipped, 0.0), minlength=grid.cells)
    radius = 0.5 * (hi_s - lo_s)[cell_slice] * radius_scale
    with np.errstate(invalid="ignore", divide="ignore"):
        return (counts > 0) & (sums / np.maximum(counts, 1) < radius)
