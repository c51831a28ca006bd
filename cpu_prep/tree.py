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

`build` BUILD_TOPDOWN (TreeOptions.tree_build 1) builds each tree cell (L > 1 leaves) top-down
instead (cpu_prep.tree_topdown: a split per node by a surface-area-like cost over depth, at
most the same L leaves, the same node layout, depth-first directly, not a complete tree);
a one-leaf cell (a list) is unchanged.

One kernel builds every cell (`_build_range`), in one of two modes:

  given   the leaf count of each cell is known (tree: every cell a tree; build_trees());
  plan    the hybrid (cpu_prep.hybrid.plan_and_build): one pass over a cell's lights sums
          listing 2's depth overlap and takes the min/max of their depth ranges; a list
          cell (most of them, two thirds of the entries at 65,536 lights) is then written
          from that pass alone as its one leaf, and only a tree cell reads its lights a
          second time (from cache) for its leaves.  choose_trees() followed by
          build_trees() read every light of every cell twice.

On one thread the cells are built in order and each tree is written where the last one
ended; with more threads (LAB_CPU_THREADS) the threads claim chunks of cells (cpu_prep.share),
each chunk written from the most nodes the chunks before it can take (the full trees' count;
in plan mode every cell a tree), and _close_gaps moves the chunks together: one thread and
two give the same bits.
Leaf boundaries are shifts, not divisions (the leaf count is a power of two).
"""
from __future__ import annotations

from functools import lru_cache

import numba
import numpy as np

from . import layouts, parallel, share
from .arena import Arena, empty
from .layouts import NODE_BITS, NODE_FIRST_LIGHT, NODE_MAX_DEPTH, NODE_MIN_DEPTH, NODE_WORDS, node_bits
from .intrinsics import fetch_add
from .limits import LimitError, NODE_MAX_LIGHTS, NODE_MAX_SKIP
from .tree_topdown import NODE_COST, build_topdown

# The tree build (TreeOptions.tree_build): the paper's bottom-up full trees, or the top-down
# build with a split chosen per node (cpu_prep.tree_topdown).
BUILD_BOTTOMUP, BUILD_TOPDOWN = 0, 1
BUILDS = {BUILD_BOTTOMUP: "bottomup", BUILD_TOPDOWN: "topdown"}
CELL_CHUNKS = 64      # with threads: chunks of cells to claim (a late thread leaves less)


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


def _check_leaf_args(lights_per_leaf: int, max_leaves: int) -> None:
    if lights_per_leaf < 1 or max_leaves < 1 or max_leaves & (max_leaves - 1):
        raise ValueError("lights_per_leaf must be >= 1 and max_leaves a power of two")


def _check_skip(max_leaves_used: int) -> None:
    if 2 * max_leaves_used - 1 > NODE_MAX_SKIP:
        raise LimitError(f"a tree of {max_leaves_used} leaves needs a skip count past 15 bits")


def leaves_per_cell(counts, is_tree, lights_per_leaf: int, max_leaves: int) -> np.ndarray:
    """Leaf count of each cell: a power of two near count / lights_per_leaf, capped at
    max_leaves; list cells one leaf; more leaves wherever a leaf would pass 65,535 lights."""
    _check_leaf_args(lights_per_leaf, max_leaves)
    want = np.minimum(_next_pow2(-(-counts // lights_per_leaf)), max_leaves)
    leaves = np.where(is_tree, want, 1)
    leaves = np.maximum(leaves, _next_pow2(-(-counts // NODE_MAX_LIGHTS)))
    if leaves.size:
        _check_skip(int(leaves.max()))
    return np.where(counts > 0, leaves, 0)


# ---- the kernel ------------------------------------------------------------------------

@numba.njit(inline="always")
def _pow2_at_least(x):
    p = 1
    while p < x:
        p <<= 1
    return p


@numba.njit(inline="always")
def tree_leaves(n, lights_per_leaf, max_leaves):
    """Leaves of a tree cell of n > 0 lights (leaves_per_cell, is_tree True)."""
    want = min(_pow2_at_least(-(-n // lights_per_leaf)), max_leaves)
    return max(want, _pow2_at_least(-(-n // NODE_MAX_LIGHTS)))


@numba.njit(inline="always")
def list_leaves(n):
    """Leaves of a list cell of n > 0 lights: one, unless the 16-bit count overflows."""
    return _pow2_at_least(-(-n // NODE_MAX_LIGHTS))


@numba.njit(inline="always")
def _log2(x):
    k = 0
    while (1 << k) < x:
        k += 1
    return k


@numba.njit(inline="always")
def scan(o, n, entries, depth_lo, depth_hi, plan, lo_s, hi_s):
    """One pass over a cell's lights: the min and max of their depth ranges (the root's
    bounds) and, in plan mode, listing 2's sum of their depth extents clipped to the cell,
    in entry order as cpu_prep.hybrid.choose_trees sums them (the same bits)."""
    total = 0.0
    lo, hi = np.float32(np.inf), np.float32(-np.inf)
    for e in range(np.uint64(o), np.uint64(o + n)):     # unsigned: no wraparound code
        i = entries[e]
        dl, dh = depth_lo[i], depth_hi[i]
        lo = min(lo, dl)
        hi = max(hi, dh)
        if plan:
            total += max(min(float(dh), hi_s) - max(float(dl), lo_s), 0.0)
    return total, lo, hi


@numba.njit(inline="always")
def _leaves(o, n, W, entries, depth_lo, depth_hi, bf_min, bf_max, bf_first, bf_count):
    """The W-leaf tree of a cell's lights (entries o .. o+n-1) in breadth-first scratch:
    leaves are balanced runs of its depth-sorted lights, parents the min/max of their
    children, the first light of the left one and the light count of the subtree."""
    k = _log2(W)                    # W is a power of two: (j * n) // W == (j * n) >> k
    b = o
    for j in range(W):
        a, b = b, o + (((j + 1) * n) >> k)
        lo, hi = np.float32(np.inf), np.float32(-np.inf)
        for e in range(np.uint64(a), np.uint64(b)):
            i = entries[e]
            lo = min(lo, depth_lo[i])
            hi = max(hi, depth_hi[i])
        q = W - 1 + j
        bf_min[q], bf_max[q], bf_first[q], bf_count[q] = lo, hi, a, b - a
    for q in range(W - 2, -1, -1):
        bf_min[q] = min(bf_min[2 * q + 1], bf_min[2 * q + 2])
        bf_max[q] = max(bf_max[2 * q + 1], bf_max[2 * q + 2])
        bf_first[q] = bf_first[2 * q + 1]
        bf_count[q] = bf_count[2 * q + 1] + bf_count[2 * q + 2]


@numba.njit(inline="always")
def _emit(L, base, bf_min, bf_max, bf_first, bf_count, tab_order, tab_skip, tab_off,
          nodes_f, nodes_u):
    """The top 2L-1 nodes of the scratch tree (a tree of L leaves), depth-first, at base."""
    t = np.uint64(tab_off[_log2(L)])
    base = np.uint64(base)
    for q in range(np.uint64(2 * L - 1)):                 # unsigned: no wraparound code
        src, skip = np.uint64(tab_order[t + q]), tab_skip[t + q]
        leaf = 1 if skip == 1 else 0
        nodes_f[base + q, NODE_MIN_DEPTH] = bf_min[src]
        nodes_f[base + q, NODE_MAX_DEPTH] = bf_max[src]
        nodes_u[base + q, NODE_FIRST_LIGHT] = bf_first[src]
        nodes_u[base + q, NODE_BITS] = node_bits(leaf, bf_count[src] * leaf, skip)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _build_range(c_begin, c_end, offsets, entries, depth_lo, depth_hi, leaves, plan,
                 is_tree, slice_lo, slice_hi, slices, radius_scale, lights_per_leaf,
                 max_leaves, scratch, tab_order, tab_skip, tab_off, nodes_f, nodes_u,
                 ranges_u, base, topdown, node_cost, n_max):
    """Cells c_begin .. c_end-1, their trees written one after another from node `base`.
    given mode (plan False): leaves[c] is each cell's leaf count; plan mode: leaves[c] and
    is_tree[c] are written.  topdown: a cell of L > 1 leaves gets the top-down tree of at
    most L leaves (cpu_prep.tree_topdown; n_max: the most lights of a cell, for its scratch)
    instead of the full one.  Returns the node count written."""
    bf_min = np.empty(scratch, np.float32)
    bf_max = np.empty(scratch, np.float32)
    bf_first = np.empty(scratch, np.int64)
    bf_count = np.empty(scratch, np.int64)
    td = scratch + 1 if topdown else 0
    suf_lo = np.empty(n_max if topdown else 0, np.float32)
    suf_hi = np.empty(n_max if topdown else 0, np.float32)
    st_a = np.empty(td, np.int64)
    st_n = np.empty(td, np.int64)
    st_b = np.empty(td, np.int64)
    st_lo = np.empty(td, np.float32)
    st_hi = np.empty(td, np.float32)
    size = np.empty(td, np.int64)
    start = base
    s = c_begin % slices            # the cell's slice: cells are tile-major (cpu_prep.grid)
    for c in range(c_begin, c_end):
        if c > c_begin:
            s = s + 1 if s + 1 < slices else 0      # (a counter, not a division a cell)
        o, n = offsets[c], offsets[c + 1] - offsets[c]
        if n == 0:
            ranges_u[c, 0], ranges_u[c, 1] = base, 0
            if plan:
                leaves[c] = 0
                is_tree[c] = False
            continue
        if plan:
            lo_s, hi_s = slice_lo[s], slice_hi[s]
            total, lo, hi = scan(o, n, entries, depth_lo, depth_hi, True, lo_s, hi_s)
            tree = total / n < 0.5 * (hi_s - lo_s) * radius_scale
            L = tree_leaves(n, lights_per_leaf, max_leaves) if tree else list_leaves(n)
            is_tree[c] = tree
            leaves[c] = L
        else:
            L = leaves[c]
            if L == 1 or topdown:
                total, lo, hi = scan(o, n, entries, depth_lo, depth_hi, False, 0.0, 0.0)
        if L == 1:
            # a list: one leaf over all the cell's lights (its bounds are the scan's)
            b = np.uint64(base)
            nodes_f[b, NODE_MIN_DEPTH], nodes_f[b, NODE_MAX_DEPTH] = lo, hi
            nodes_u[b, NODE_FIRST_LIGHT], nodes_u[b, NODE_BITS] = o, node_bits(1, n, 1)
            count = 1
        elif topdown:
            count = build_topdown(o, n, L, lo, hi, entries, depth_lo, depth_hi, lights_per_leaf,
                                  node_cost, suf_lo, suf_hi, st_a, st_n, st_b, st_lo, st_hi,
                                  size, nodes_f, nodes_u, base)
        else:
            # a tree (the lights are read again, from cache): a second pass for its leaves
            _leaves(o, n, L, entries, depth_lo, depth_hi, bf_min, bf_max, bf_first, bf_count)
            _emit(L, base, bf_min, bf_max, bf_first, bf_count, tab_order, tab_skip, tab_off,
                  nodes_f, nodes_u)
            count = 2 * L - 1
        ranges_u[c, 0], ranges_u[c, 1] = base, count
        base += count
    return base - start


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _build1(offsets, entries, depth_lo, depth_hi, leaves, plan, is_tree, slice_lo, slice_hi,
            slices, radius_scale, lights_per_leaf, max_leaves, scratch, tab_order, tab_skip,
            tab_off, nodes_f, nodes_u, ranges_u, topdown, node_cost, n_max):
    """One thread: every cell in order, trees back to back.  Returns the node count.
    (_build_range is a plain call, one compiled body for this and _build_chunks, not numba-
    inlined into each; its first cell and base node are typed zeros, np.int64(0), since a
    call's literal argument would be a specialization of its own.)"""
    return _build_range(np.int64(0), offsets.shape[0] - 1, offsets, entries, depth_lo, depth_hi, leaves,
                        plan, is_tree, slice_lo, slice_hi, slices, radius_scale,
                        lights_per_leaf, max_leaves, scratch, tab_order, tab_skip, tab_off,
                        nodes_f, nodes_u, ranges_u, np.int64(0), topdown, node_cost, n_max)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _build_chunks(claim, chunks, chunk_base, chunk_count, offsets, entries, depth_lo, depth_hi,
                  leaves, plan, is_tree, slice_lo, slice_hi, slices, radius_scale,
                  lights_per_leaf, max_leaves, scratch, tab_order, tab_skip, tab_off, nodes_f,
                  nodes_u, ranges_u, topdown, node_cost, n_max):
    """Threads (cpu_prep.share): the chunks of cells this thread claims (trees are
    independent, paper 4.1), in either mode, chunk k's trees back to back from node
    chunk_base[k] (at least the nodes of the chunks before it: the full trees' count, or
    the worst case in plan mode), its node count into chunk_count[k]; _close_gaps then
    moves the chunks together."""
    cells = offsets.shape[0] - 1
    k = fetch_add(claim, 0, 1)
    while k < chunks:
        chunk_count[k] = _build_range(
            k * cells // chunks, (k + 1) * cells // chunks, offsets, entries, depth_lo,
            depth_hi, leaves, plan, is_tree, slice_lo, slice_hi, slices, radius_scale,
            lights_per_leaf, max_leaves, scratch, tab_order, tab_skip, tab_off, nodes_f,
            nodes_u, ranges_u, chunk_base[k], topdown, node_cost, n_max)
        fetch_add(claim, 1, 1)
        k = fetch_add(claim, 0, 1)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _close_gaps(nodes_u, ranges_u, chunk_base, chunk_count):
    """_build_chunks' chunks moved down to lie back to back, in cell order, and their cells'
    first nodes with them: the nodes and ranges one thread writes.  Returns the node count."""
    cells, chunks = ranges_u.shape[0], chunk_base.shape[0]
    words = nodes_u.shape[1]
    flat = nodes_u.reshape(-1)      # one flat loop: LLVM makes it a memmove (2-3x the row loop)
    w = 0
    for k in range(chunks):
        src, n = chunk_base[k], chunk_count[k]
        if src != w:
            d, s = np.uint64(w * words), np.uint64(src * words)
            for j in range(np.uint64(n * words)):   # w < src: a forward copy is safe
                flat[d + j] = flat[s + j]
            for c in range(k * cells // chunks, (k + 1) * cells // chunks):
                ranges_u[c, 0] -= np.uint32(src - w)
        w += n
    return w


def cell_chunks(cells: int) -> int:
    """Chunks of cells a threaded step is cut into (cpu_prep.share): 1 on one thread."""
    return max(min(cells, CELL_CHUNKS), 1) if parallel() else 1


def _chunk_cells(cells: int, chunks: int) -> np.ndarray:
    """The first cell of each of _build_chunks' chunks."""
    return np.arange(chunks, dtype=np.int64) * cells // chunks


def _outputs(cells: int, nodes: int, arena: Arena | None):
    raw = empty(arena, "nodes", (nodes, NODE_WORDS), np.float32)
    ranges = empty(arena, "tree_ranges", cells, layouts.CELL_RANGE)
    return raw, ranges


def _build_given(offsets, entries, depth_lo, depth_hi, leaves, arena, lights_per_leaf=1,
                 topdown=False):
    """Trees of known leaf counts (leaves_per_cell; top-down: at most those)."""
    cells = len(leaves)
    node_counts = np.where(leaves > 0, 2 * leaves - 1, 0)
    total = int(node_counts.sum())
    raw, ranges = _outputs(cells, total, arena)
    max_l = int(max(leaves.max(initial=1), 1))
    n_max = int(np.diff(offsets).max(initial=0)) if topdown else 0
    tab_order, tab_skip, tab_off = _all_tables(max_l)
    no_slices = np.zeros(1)
    ranges_u = ranges.view(np.uint32).reshape(cells, 2)
    if parallel():
        chunks = cell_chunks(cells)
        node_start = np.zeros(cells + 1, np.int64)
        np.cumsum(node_counts, out=node_start[1:])
        base, count = node_start[_chunk_cells(cells, chunks)], np.empty(chunks, np.int64)
        share.run(_build_chunks, chunks, base, count, offsets, entries, depth_lo, depth_hi,
                  leaves, False, np.zeros(0, np.bool_), no_slices, no_slices, 1, 1.0,
                  lights_per_leaf, 1, 2 * max_l - 1, tab_order, tab_skip, tab_off, raw,
                  raw.view(np.uint32), ranges_u, bool(topdown), NODE_COST, n_max)
        total = _close_gaps(raw.view(np.uint32), ranges_u, base, count)
    else:
        total = _build1(offsets, entries, depth_lo, depth_hi, leaves, False, np.zeros(0, np.bool_),
                        no_slices, no_slices, 1, 1.0, lights_per_leaf, 1, 2 * max_l - 1,
                        tab_order, tab_skip, tab_off, raw, raw.view(np.uint32), ranges_u,
                        bool(topdown), NODE_COST, n_max)
    return ranges, raw[:total].view(layouts.TREE_NODE).reshape(-1)


def _leaves_built(ranges) -> np.ndarray:
    """Leaves of each cell's tree as built (a tree of c nodes, every inner node with two
    children, has (c + 1) / 2 leaves)."""
    return (ranges["offset_count"][:, 1].astype(np.int64) + 1) // 2


def build_trees(offsets, entries, depth_lo, depth_hi, is_tree,
                lights_per_leaf: int, max_leaves: int, arena: Arena | None = None,
                build: int = BUILD_BOTTOMUP):
    """Trees for every cell of a CSR binning.

    offsets/entries: per-cell lists (entries index the depth-sorted light arrays);
    depth_lo/hi: float32 conservative depth range of each light; is_tree: per-cell bool;
    build: BUILD_BOTTOMUP (full trees) or BUILD_TOPDOWN (cpu_prep.tree_topdown: at most the
    full tree's leaves).  Returns (cell_ranges CELL_RANGE[cells], nodes TREE_NODE[], leaves
    per cell as built)."""
    topdown = _check_build(build)
    counts = np.diff(offsets)
    leaves = leaves_per_cell(counts, is_tree, lights_per_leaf, max_leaves)
    ranges, nodes = _build_given(offsets, entries, depth_lo, depth_hi, leaves, arena,
                                 lights_per_leaf, topdown)
    return ranges, nodes, (_leaves_built(ranges) if topdown else leaves)


def _check_build(build: int) -> bool:
    if build not in BUILDS:
        raise ValueError(f"tree build must be one of {BUILDS} (got {build!r})")
    return build == BUILD_TOPDOWN


def plan_trees(offsets, entries, depth_lo, depth_hi, slice_lo, slice_hi, slices: int,
               radius_scale: float, lights_per_leaf: int, max_leaves: int,
               arena: Arena | None = None, build: int = BUILD_BOTTOMUP):
    """The hybrid's cells: listing 2's choice (slice_lo/hi: each slice's depth range as
    cpu_prep.hybrid.choose_trees clips it) and the trees, in one pass over the lights (with
    threads: chunks of cells, each from the worst case of the chunks before it, moved
    together afterwards).  Returns (cell_ranges, nodes, leaves per cell as built, is_tree)."""
    topdown = _check_build(build)
    _check_leaf_args(lights_per_leaf, max_leaves)
    cells = len(offsets) - 1
    counts = np.diff(offsets)
    n_max = int(counts.max(initial=0))
    w_max = _np_tree_leaves(n_max, lights_per_leaf, max_leaves) if n_max else 1
    # the nodes buffer holds the worst case (every non-empty cell a tree of its W leaves)
    chunks = cell_chunks(cells)
    base = np.empty(chunks + 1, np.int64)
    _node_bound(offsets, lights_per_leaf, max_leaves, _chunk_cells(cells, chunks), base)
    raw, ranges = _outputs(cells, int(base[-1]), arena)
    leaves = np.empty(cells, np.int64)
    is_tree = np.empty(cells, np.bool_)
    tab_order, tab_skip, tab_off = _all_tables(w_max)
    ranges_u = ranges.view(np.uint32).reshape(cells, 2)
    args = (offsets, entries, depth_lo, depth_hi, leaves, True, is_tree, slice_lo, slice_hi,
            slices, float(radius_scale), lights_per_leaf, max_leaves, 2 * w_max - 1, tab_order,
            tab_skip, tab_off, raw, raw.view(np.uint32), ranges_u, topdown, NODE_COST,
            n_max if topdown else 0)
    if chunks > 1:
        count = np.empty(chunks, np.int64)
        share.run(_build_chunks, chunks, base[:-1], count, *args)
        total = _close_gaps(raw.view(np.uint32), ranges_u, base[:-1], count)
    else:
        total = _build1(*args)
    if cells:
        _check_skip(int(leaves.max()))
    if topdown:
        leaves = _leaves_built(ranges)
    return ranges, raw[:total].view(layouts.TREE_NODE).reshape(-1), leaves, is_tree


def _np_tree_leaves(n: int, lights_per_leaf: int, max_leaves: int) -> int:
    """tree_leaves() in Python (a tree cell of n > 0 lights)."""
    pow2 = lambda x: 1 << max(int(x) - 1, 0).bit_length()
    return max(min(pow2(-(-n // lights_per_leaf)), max_leaves), pow2(-(-n // NODE_MAX_LIGHTS)))


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _node_bound(offsets, lights_per_leaf, max_leaves, first_cells, out):
    """The most nodes the cells before each of first_cells (ascending) can take, every non-
    empty cell a tree of its W leaves, into out[:-1]; all cells' into out[-1]."""
    total = 0
    k = 0
    for c in range(offsets.shape[0] - 1):
        while k < first_cells.shape[0] and first_cells[k] == c:
            out[k] = total
            k += 1
        n = offsets[c + 1] - offsets[c]
        if n > 0:
            total += 2 * tree_leaves(n, lights_per_leaf, max_leaves) - 1
    while k < first_cells.shape[0]:
        out[k] = total
        k += 1
    out[out.shape[0] - 1] = total
