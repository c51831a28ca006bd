"""The hybrid's per-cell choice between a list and a tree (tree paper 3.3, listing 2):

    sum of each light's depth extent clipped to the cell / light count  <  cell.radius
        -> tree, else list.

`cell.radius` is not defined in the paper; it is read here as half the cell's depth extent
times `radius_scale` (a parameter, 1.0 by default, swept in the benchmark).  Cells of the last
slice reach to infinity; their extent is clipped to the scene's max depth.

plan_and_build() is what the hybrid technique runs: the choice and the trees come out of one
pass over each cell's lights (cpu_prep.tree.plan_trees; with threads, LAB_CPU_THREADS, chunks
of cells shared among them, cpu_prep.share); choose_trees() then tree.build_trees() give the
same bits.
"""
from __future__ import annotations

import numba
import numpy as np

from . import share, tree as treemod
from .arena import Arena
from .grid import Grid
from .intrinsics import fetch_add


@numba.njit(inline="always")
def _choose_cell(c, offsets, entries, depth_lo, depth_hi, slice_lo, slice_hi, slices,
                 radius_scale, out):
    n = offsets[c + 1] - offsets[c]
    if n == 0:
        out[c] = False
        return
    s = c % slices                 # cells are tile-major (cpu_prep.grid)
    lo, hi = slice_lo[s], slice_hi[s]
    total = 0.0
    for e in range(offsets[c], offsets[c + 1]):
        i = entries[e]
        total += max(min(float(depth_hi[i]), hi) - max(float(depth_lo[i]), lo), 0.0)
    out[c] = total / n < 0.5 * (hi - lo) * radius_scale


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _choose_chunks(claim, chunks, offsets, entries, depth_lo, depth_hi, slice_lo, slice_hi,
                   slices, radius_scale, out):
    """The chunks of cells this thread claims (cpu_prep.share)."""
    cells = offsets.shape[0] - 1
    k = fetch_add(claim, 0, 1)
    while k < chunks:
        for c in range(k * cells // chunks, (k + 1) * cells // chunks):
            _choose_cell(c, offsets, entries, depth_lo, depth_hi, slice_lo, slice_hi, slices,
                         radius_scale, out)
        fetch_add(claim, 1, 1)
        k = fetch_add(claim, 0, 1)


def cell_depth_ranges(grid: Grid, max_depth: float) -> tuple[np.ndarray, np.ndarray]:
    """Each slice's depth range as listing 2 clips lights to it (the last slice's end at
    the scene's max depth)."""
    lo_s, hi_s = grid.slice_bounds()
    return lo_s, np.minimum(hi_s, max(max_depth, lo_s[-1]))


def choose_trees(grid: Grid, offsets, entries, depth_lo, depth_hi, max_depth: float,
                 radius_scale: float = 1.0) -> np.ndarray:
    lo_s, hi_s = cell_depth_ranges(grid, max_depth)
    out = np.empty(len(offsets) - 1, np.bool_)
    share.run(_choose_chunks, treemod.cell_chunks(len(out)), offsets, entries, depth_lo,
              depth_hi, lo_s, hi_s, grid.slices, float(radius_scale), out)
    return out


def plan_and_build(grid: Grid, offsets, entries, depth_lo, depth_hi, max_depth: float,
                   radius_scale: float, lights_per_leaf: int, max_leaves: int,
                   arena: Arena | None = None, build: int = treemod.BUILD_BOTTOMUP):
    """Listing 2's choice and the cells' trees (a list: a one-leaf tree; build: the tree
    cells' bottom-up or top-down build, cpu_prep.tree): (cell_ranges, nodes, leaves per cell,
    is_tree), as choose_trees() then tree.build_trees() give them."""
    lo_s, hi_s = cell_depth_ranges(grid, max_depth)
    return treemod.plan_trees(offsets, entries, depth_lo, depth_hi, lo_s, hi_s, grid.slices,
                              radius_scale, lights_per_leaf, max_leaves, arena, build)
