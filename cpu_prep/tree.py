"""Light trees (O'Donnell & Chajdas 2017, 3.1-3.2): per cell, a full binary 1D bounding-
interval tree over depth, several lights per leaf, built bottom-up in O(n) on depth-sorted
lights, converted from breadth-first to depth-first with precomputed tables, skip counts
for the stackless traversal of listing 3, packed into the 16-byte node of listing 1.

    CellRange[cell] = (first node, node count) -> TreeNode[] (depth-first, one tree per cell)
    TreeNode: (minDepth, maxDepth, firstLightIndex, isLeaf | lightCount | skipCount)
    leaf -> entries[firstLightIndex .. +lightCount] -> GpuLight[]
    64 leaves = 127 nodes = 2 KiB a tree

A cell stored as a list is a one-node tree whose root is a leaf (paper 3.4).  Fallback for
the 16-bit light count: a cell whose lights would overflow one leaf gets more leaves
(ceil(n / 65535), rounded to a power of two), so a "list" of 70,000 lights is a two-leaf tree.
"""
from __future__ import annotations

from functools import lru_cache

import numba
import numpy as np

from . import layouts
from .arena import Arena, empty
from .layouts import NODE_BITS, NODE_FIRST_LIGHT, NODE_MAX_DEPTH, NODE_MIN_DEPTH, NODE_WORDS, node_bits
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


@lru_cache(maxsize=None)
def _all_tables(max_leaves: int):
    """Tables of every power of two up to max_leaves, concatenated; offsets by log2(L)."""
    sizes = [1 << k for k in range(max_leaves.bit_length())]
    offs = np.concatenate([[0], np.cumsum([2 * L - 1 for L in sizes])]).astype(np.int64)
    order = np.concatenate([depth_first_tables(L)[0] for L in sizes])
    skip = np.concatenate([depth_first_tables(L)[1] for L in sizes])
    return order, skip, offs


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


@numba.njit(cache=True, nogil=True, parallel=True)
def _build(offsets, entries, depth_lo, depth_hi, leaves, node_start,
           tab_order, tab_skip, tab_off, nodes_f, nodes_u, chunks):
    # Trees are independent (paper 4.1: built in parallel); chunks of cells share scratch.
    for chunk in numba.prange(chunks):
        _build_cells(offsets, entries, depth_lo, depth_hi, leaves, node_start, tab_order,
                     tab_skip, tab_off, nodes_f, nodes_u,
                     chunk * leaves.shape[0] // chunks, (chunk + 1) * leaves.shape[0] // chunks)


@numba.njit(nogil=True)
def _build_cells(offsets, entries, depth_lo, depth_hi, leaves, node_start,
                 tab_order, tab_skip, tab_off, nodes_f, nodes_u, c_begin, c_end):
    max_l = max(leaves.max(), 1)
    bf_min = np.empty(2 * max_l - 1, np.float32)
    bf_max = np.empty(2 * max_l - 1, np.float32)
    bf_first = np.empty(2 * max_l - 1, np.int64)
    bf_count = np.empty(2 * max_l - 1, np.int64)
    for c in range(c_begin, c_end):
        L = leaves[c]
        if L == 0:
            continue
        o, n = offsets[c], offsets[c + 1] - offsets[c]
        # leaves: balanced runs of the cell's depth-sorted lights
        for j in range(L):
            a, b = o + (j * n) // L, o + ((j + 1) * n) // L
            lo, hi = np.float32(np.inf), np.float32(-np.inf)
            for e in range(a, b):
                lo = min(lo, depth_lo[entries[e]])
                hi = max(hi, depth_hi[entries[e]])
            q = L - 1 + j
            bf_min[q], bf_max[q], bf_first[q], bf_count[q] = lo, hi, a, b - a
        # parents bottom-up, breadth-first numbering
        for q in range(L - 2, -1, -1):
            bf_min[q] = min(bf_min[2 * q + 1], bf_min[2 * q + 2])
            bf_max[q] = max(bf_max[2 * q + 1], bf_max[2 * q + 2])
            bf_first[q], bf_count[q] = bf_first[2 * q + 1], 0
        # breadth-first -> depth-first through the table of this L
        t = tab_off[int(np.log2(L))]
        base = node_start[c]
        for q in range(2 * L - 1):
            src, skip = tab_order[t + q], tab_skip[t + q]
            nodes_f[base + q, NODE_MIN_DEPTH] = bf_min[src]
            nodes_f[base + q, NODE_MAX_DEPTH] = bf_max[src]
            nodes_u[base + q, NODE_FIRST_LIGHT] = bf_first[src]
            nodes_u[base + q, NODE_BITS] = node_bits(1 if skip == 1 else 0, bf_count[src], skip)


def build_trees(offsets, entries, depth_lo, depth_hi, is_tree,
                lights_per_leaf: int, max_leaves: int, arena: Arena | None = None):
    """Trees for every cell of a CSR binning.

    offsets/entries: per-cell lists (entries index the depth-sorted light arrays);
    depth_lo/hi: float32 conservative depth range of each light; is_tree: per-cell bool.
    Returns (cell_ranges CELL_RANGE[cells], nodes TREE_NODE[], leaves per cell)."""
    counts = np.diff(offsets)
    leaves = leaves_per_cell(counts, is_tree, lights_per_leaf, max_leaves)
    node_counts = np.where(leaves > 0, 2 * leaves - 1, 0)
    node_start = np.zeros(len(counts) + 1, np.int64)
    np.cumsum(node_counts, out=node_start[1:])
    raw = empty(arena, "nodes", (int(node_start[-1]), NODE_WORDS), np.float32)   # all written
    tab_order, tab_skip, tab_off = _all_tables(int(max(leaves.max(initial=1), 1)))
    _build(offsets, entries, depth_lo, depth_hi, leaves, node_start, tab_order, tab_skip,
           tab_off, raw, raw.view(np.uint32), 8 * numba.get_num_threads())
    ranges = np.zeros(len(counts), layouts.CELL_RANGE)
    ranges["offset_count"][:, 0] = node_start[:-1]
    ranges["offset_count"][:, 1] = node_counts
    return ranges, raw.view(layouts.TREE_NODE).reshape(-1), leaves
