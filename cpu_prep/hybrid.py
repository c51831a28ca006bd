"""The hybrid's per-cell choice between a list and a tree (tree paper 3.3, listing 2):

    sum of each light's depth extent clipped to the cell / light count  <  cell.radius
        -> tree, else list.

`cell.radius` is not defined in the paper; it is read here as half the cell's depth extent
times `radius_scale` (a parameter, 1.0 by default, swept in the benchmark).  Cells of the last
slice reach to infinity; their extent is clipped to the scene's max depth.

plan_and_build() is what the hybrid technique runs: on one thread the choice and the trees
come out of one pass over each cell's lights (cpu_prep.tree.plan_trees); with more threads
(LAB_CPU_THREADS) the choice runs first, its chunks of cells shared among the threads
(cpu_prep.share), taking each cell's depth bounds in the same pass, then build_trees(),
which reads only the tree cells' lights again.  Both give the same bits.
"""
from __future__ import annotations

import numba
import numpy as np

from . import parallel, share, tree as treemod
from .arena import Arena
from .grid import Grid
from .intrinsics import fetch_add


@numba.njit(inline="always")
def _choose_cell(c, offsets, entries, depth_lo, depth_hi, slice_lo, slice_hi, slices,
                 radius_scale, out, cell_lo, cell_hi):
    """Listing 2 for cell c, and the min and max of its lights' depth ranges (the one pass
    of cpu_prep.tree's plan mode, the same bits)."""
    o, n = offsets[c], offsets[c + 1] - offsets[c]
    if n == 0:
        out[c] = False
        cell_lo[c], cell_hi[c] = np.float32(np.inf), np.float32(-np.inf)
        return
    s = c % slices                 # cells are tile-major (cpu_prep.grid)
    lo, hi = slice_lo[s], slice_hi[s]
    total, cell_lo[c], cell_hi[c] = treemod.scan(o, n, entries, depth_lo, depth_hi, True, lo, hi)
    out[c] = total / n < 0.5 * (hi - lo) * radius_scale


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _choose_chunks(claim, chunks, offsets, entries, depth_lo, depth_hi, slice_lo, slice_hi,
                   slices, radius_scale, out, cell_lo, cell_hi):
    """The chunks of cells this thread claims (cpu_prep.share)."""
    cells = offsets.shape[0] - 1
    k = fetch_add(claim, 0, 1)
    while k < chunks:
        for c in range(k * cells // chunks, (k + 1) * cells // chunks):
            _choose_cell(c, offsets, entries, depth_lo, depth_hi, slice_lo, slice_hi, slices,
                         radius_scale, out, cell_lo, cell_hi)
        fetch_add(claim, 1, 1)
        k = fetch_add(claim, 0, 1)


def cell_depth_ranges(grid: Grid, max_depth: float) -> tuple[np.ndarray, np.ndarray]:
    """Each slice's depth range as listing 2 clips lights to it (the last slice's end at
    the scene's max depth)."""
    lo_s, hi_s = grid.slice_bounds()
    return lo_s, np.minimum(hi_s, max(max_depth, lo_s[-1]))


def choose_trees(grid: Grid, offsets, entries, depth_lo, depth_hi, max_depth: float,
                 radius_scale: float = 1.0) -> np.ndarray:
    """Listing 2's choice per cell (bool)."""
    return _choose(grid, offsets, entries, depth_lo, depth_hi, max_depth, radius_scale)[0]


def _choose(grid, offsets, entries, depth_lo, depth_hi, max_depth, radius_scale):
    """(is_tree, (lo, hi)): listing 2's choice and each cell's min and max depth bound."""
    lo_s, hi_s = cell_depth_ranges(grid, max_depth)
    cells = len(offsets) - 1
    out = np.empty(cells, np.bool_)
    cell_lo, cell_hi = np.empty(cells, np.float32), np.empty(cells, np.float32)
    share.run(_choose_chunks, treemod.cell_chunks(cells), offsets, entries, depth_lo, depth_hi,
              lo_s, hi_s, grid.slices, float(radius_scale), out, cell_lo, cell_hi)
    return out, (cell_lo, cell_hi)


def plan_and_build(grid: Grid, offsets, entries, depth_lo, depth_hi, max_depth: float,
                   radius_scale: float, lights_per_leaf: int, max_leaves: int,
                   arena: Arena | None = None, build: int = treemod.BUILD_BOTTOMUP):
    """Listing 2's choice and the cells' trees (a list: a one-leaf tree; build: the tree
    cells' bottom-up or top-down build, cpu_prep.tree): (cell_ranges, nodes, leaves per cell,
    is_tree), as choose_trees() then tree.build_trees() give them."""
    if parallel():      # the choice's pass takes each cell's bounds: lists are not read again
        is_tree, bounds = _choose(grid, offsets, entries, depth_lo, depth_hi, max_depth,
                                  radius_scale)
        ranges, nodes, leaves = treemod.build_trees(offsets, entries, depth_lo, depth_hi, is_tree,
                                                    lights_per_leaf, max_leaves, arena, build,
                                                    bounds)
        return ranges, nodes, leaves, is_tree
    lo_s, hi_s = cell_depth_ranges(grid, max_depth)
    return treemod.plan_trees(offsets, entries, depth_lo, depth_hi, lo_s, hi_s, grid.slices,
                              radius_scale, lights_per_leaf, max_leaves, arena, build)
