"""Light trees (O'Donnell & Chajdas 2017, 3.1-3.2): per cell, a full binary 1D bounding-
interval tree over depth, several lights per leaf, built bottom-up in O(n) on depth-sorted
lights, converted from breadth-first to depth-first with precomputed tables, skip counts
for the stackless traversal of listing 3, packed into the 16-byte node of listing 1.

    CellRange[cell] = (first node, node count) -> TreeNode[] (depth-first, one tree per cell)
    TreeNode leaf: (minDepth, maxDepth, firstLightIndex, isLeaf | count | skip)
                                           -> entries[firstLightIndex ..+count] -> GpuLight[]

A cell stored as a list is a one-node tree whose root is a leaf (paper 3.4).  Fallback for
the 16-bit light count: a cell whose lights would overflow one leaf gets more leaves
(ceil(n / 65535), rounded to a power of two), so a "list" of 70,000 lights is a two-leaf tree.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from . import layouts
from .limits import LimitError, NODE_MAX_LIGHTS, NODE_MAX_SKIP


def _next_pow2(x: np.ndarray) -> np.ndarray:
    x = np.maximum(np.asarray(x, np.int64), 1)
    return (1 << np.ceil(np.log2(x)).astype(np.int64)).astype(np.int64)


@lru_cache(maxsize=None)
def depth_first_tables(leaves: int):
    """For a full binary tree of `leaves` leaves in breadth-first numbering (root 0, children
    2i+1, 2i+2): the breadth-first index of each depth-first position, each position's skip
    count (its subtree size: listing 3 jumps past the subtree on a miss) and leaf flag."""
    order, skip = [], []

    def visit(i, size):
        order.append(i)
        skip.append(size)
        if size > 1:
            visit(2 * i + 1, size // 2)
            visit(2 * i + 2, size // 2)

    visit(0, 2 * leaves - 1)
    order = np.array(order, np.int64)
    skip = np.array(skip, np.int64)
    return order, skip, skip == 1


def leaves_per_cell(counts, is_tree, lights_per_leaf: int, max_leaves: int) -> np.ndarray:
    """Leaf count of each cell: a power of two near count / lights_per_leaf, capped at
    max_leaves; list cells one leaf; more leaves wherever a leaf would pass 65,535 lights."""
    if lights_per_leaf < 1 or max_leaves < 1 or max_leaves & (max_leaves - 1):
        raise ValueError("lights_per_leaf must be >= 1 and max_leaves a power of two")
    want = np.minimum(_next_pow2(-(-counts // lights_per_leaf)), max_leaves)
    leaves = np.where(is_tree, want, 1)
    leaves = np.maximum(leaves, _next_pow2(-(-counts // NODE_MAX_LIGHTS)))
    if leaves.size and 2 * leaves.max() - 1 > NODE_MAX_SKIP:
        raise LimitError(f"a tree of {leaves.max()} leaves needs a skip count past 15 bits")
    return np.where(counts > 0, leaves, 0)


def build_trees(offsets, entries, depth_lo, depth_hi, is_tree,
                lights_per_leaf: int, max_leaves: int):
    """Trees for every cell of a CSR binning.

    offsets/entries: per-cell lists (entries index the depth-sorted light arrays);
    depth_lo/hi: float32 conservative depth range of each light; is_tree: per-cell bool.
    Returns (cell_ranges CELL_RANGE[cells], nodes TREE_NODE[], leaves per cell)."""
    counts = np.diff(offsets)
    leaves = leaves_per_cell(counts, is_tree, lights_per_leaf, max_leaves)
    node_counts = np.where(leaves > 0, 2 * leaves - 1, 0)
    node_start = np.concatenate([[0], np.cumsum(node_counts)])
    nodes = np.zeros(int(node_start[-1]), layouts.TREE_NODE)

    # Leaves of all cells at once: leaf j of cell c holds entries [start, end), balanced.
    leaf_cell = np.repeat(np.arange(len(counts)), leaves)
    first_leaf = np.concatenate([[0], np.cumsum(leaves)])[:-1]
    j = np.arange(len(leaf_cell)) - first_leaf[leaf_cell]
    n_c, l_c, o_c = counts[leaf_cell], leaves[leaf_cell], offsets[:-1][leaf_cell]
    start = o_c + (j * n_c) // l_c
    end = o_c + ((j + 1) * n_c) // l_c
    lo_e = depth_lo[entries]
    hi_e = depth_hi[entries]
    leaf_min = _segment_reduce(np.minimum, lo_e, start, end, np.float32(np.inf))
    leaf_max = _segment_reduce(np.maximum, hi_e, start, end, np.float32(-np.inf))

    for L in np.unique(leaves[leaves > 0]).tolist():
        cells = np.flatnonzero(leaves == L)
        sel = np.flatnonzero(np.isin(leaf_cell, cells))   # leaves of these cells, in order
        shape = (len(cells), L)
        bf_min = _breadth_first(leaf_min[sel].reshape(shape), np.minimum)
        bf_max = _breadth_first(leaf_max[sel].reshape(shape), np.maximum)
        bf_first = _breadth_first(start[sel].reshape(shape), np.minimum)
        bf_count = np.zeros_like(bf_first)
        bf_count[:, L - 1:] = (end - start)[sel].reshape(shape)
        order, skip, is_leaf = depth_first_tables(L)
        dst = node_start[cells][:, None] + np.arange(2 * L - 1)[None, :]
        nodes["min_depth"][dst] = bf_min[:, order]
        nodes["max_depth"][dst] = bf_max[:, order]
        nodes["first_light"][dst] = bf_first[:, order]
        nodes["bits"][dst] = layouts.pack_node_bits(
            np.broadcast_to(is_leaf, dst.shape), bf_count[:, order], np.broadcast_to(skip, dst.shape))

    ranges = np.zeros(len(counts), layouts.CELL_RANGE)
    ranges["offset_count"][:, 0] = node_start[:-1]
    ranges["offset_count"][:, 1] = node_counts
    return ranges, nodes, leaves


def _segment_reduce(op, values, start, end, empty):
    """op.reduceat over [start, end) segments; empty segments give `empty`."""
    out = np.full(len(start), empty, values.dtype)
    ok = end > start
    if ok.any():
        out[ok] = _reduceat(op, values, start[ok], end[ok])
    return out


def _reduceat(op, values, start, end):
    # reduceat reduces [start[i], start[i+1]); segments here are contiguous except across
    # empty ones, so reduce on the boundaries and keep each segment's own result.
    bounds = np.empty(2 * len(start), np.int64)
    bounds[0::2], bounds[1::2] = start, end
    valid = bounds < len(values)
    r = op.reduceat(values, bounds[valid])
    full = np.empty(len(bounds), values.dtype)
    full[valid] = r
    return full[0::2]


def _breadth_first(leaf_values: np.ndarray, op) -> np.ndarray:
    """(cells, L) leaf values -> (cells, 2L-1) breadth-first tree, parents = op(children),
    one vectorised step per level."""
    cells, L = leaf_values.shape
    bf = np.empty((cells, 2 * L - 1), leaf_values.dtype)
    bf[:, L - 1:] = leaf_values
    width = L
    while width > 1:
        first_child = width - 1
        kids = bf[:, first_child:first_child + width].reshape(cells, width // 2, 2)
        bf[:, width // 2 - 1:width - 1] = op(kids[:, :, 0], kids[:, :, 1])
        width //= 2
    return bf
