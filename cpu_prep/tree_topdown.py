"""Top-down light trees: the alternative build the tree paper names in 3.2 ("build the tree
top-down ... O(n log n) ... may allow an optimal choice of split location and will directly
produce a depth-first tree"), selected by `--tree-build 1` (cpu_prep.tree.BUILD_TOPDOWN).

The same node layout as the bottom-up build (listing 1: isLeaf:1 | lightCount:16 |
skipCount:15 through layouts.node_bits; depth-first; a leaf's lights a contiguous run of the
cell's depth-sorted entries; an inner node's first light that of its left child, its light
count 0), but the tree is no longer complete.  Each node of a run of m depth-sorted lights
is split at the position k (left: its first k lights, right: the other m - k) that
minimises the greedy surface-area cost over depth:

    C(k) = ext(left) * k + ext(right) * (m - k)        (ext: max depth_hi - min depth_lo)

It is ext(node) times the expected number of lights a pixel evaluates below the node when
both children are leaves, with the pixel's depth uniform over the node's depth extent: a
child is hit with probability ext(child) / ext(node) (the 1D analogue of the SAH's area
ratio) and a hit leaf evaluates all its lights.  The node is split when that, plus the two
child node visits every pixel that hits the node pays (NODE_COST each, in units of a light
evaluated), is less than evaluating its m lights as one leaf:

    C(k) + 2 * NODE_COST * ext(node) < m * ext(node)

so a run whose lights all span the node (nothing to cull) stays a leaf instead of paying
node visits that cull nothing.  Ties go to the most balanced k.  NODE_COST = 0.25: a node
visit is one 16-byte fetch and two compares, a light evaluation an index, a 96-byte light
and its shape test (and shading when it affects).

The limits map onto the bottom-up build's: a node of at most lights_per_leaf lights is a
leaf; a cell's tree has at most the bottom-up tree's leaf count L (min(next power of two of
ceil(n / lights_per_leaf), max_leaves), more where a leaf would pass 65,535 lights), so at
most its 2L - 1 nodes: the node buffer's bound, the 15-bit skip count check and the shared-
memory tree's 128 nodes hold as they do for the bottom-up tree.  A node's leaf budget B is
shared between its children in proportion to their lights (each keeps at least one leaf and
enough for 65,535 lights a leaf); a node with a budget of one leaf is a leaf.  A node of
more than 65,535 lights is always split (at its best split that leaves both sides within
their budgets' 16-bit counts).

The tree is full (every inner node has two children) but neither complete nor balanced:
leaves sit at different depths and their count is not a power of two.  Listing 3's
stackless traversal (glsl/tree.glsl traverse_tree) needs only the depth-first (pre-order)
layout and each node's skip count = the size of its subtree: a hit inner node continues at
i + 1, its left child; a miss jumps past its subtree to the next node in pre-order (its
right sibling or an ancestor's); after a leaf, i + 1 is that same next node.  So every node
is still visited at most once, in memory order, forward only, on any tree shape.

Built depth-first directly (no breadth-first scratch, no conversion tables): an explicit
stack of runs (right child pushed first, so the left one is written next), each node
written at the next position; the skip counts are the subtree sizes, filled in afterwards in
one pass over the nodes in reverse order.  Each split reads its run's lights twice (a
suffix pass for the right sides' bounds, a prefix pass that evaluates every k): O(m) a node,
O(n log n) a tree when its splits are balanced, O(n L) at worst.
"""
from __future__ import annotations

import numba
import numpy as np

from .layouts import NODE_BITS, NODE_FIRST_LIGHT, NODE_MAX_DEPTH, NODE_MIN_DEPTH, node_bits
from .limits import NODE_MAX_LIGHTS

NODE_COST = 0.25      # a node visit, in lights evaluated (module doc)


@numba.njit(inline="always")
def _need(m):
    """Leaves a run of m lights needs for the 16-bit light count of a leaf."""
    return max(1, -(-m // NODE_MAX_LIGHTS))


@numba.njit(inline="always")
def _best_split(a, m, budget, entries, depth_lo, depth_hi, suf_lo, suf_hi):
    """The split of the run entries[a .. a+m-1] (m >= 2) with the least C(k) (module doc):
    (k, C(k), left bounds, right bounds); k = 0 when no split fits the budget."""
    lo, hi = np.float32(np.inf), np.float32(-np.inf)
    for t in range(m - 1, 0, -1):              # suf[t]: bounds of the run's lights t .. m-1
        i = entries[a + t]
        lo = min(lo, depth_lo[i])
        hi = max(hi, depth_hi[i])
        suf_lo[t], suf_hi[t] = lo, hi
    big = m > NODE_MAX_LIGHTS                  # only then can a side pass its budget's count
    best, bk, bd = np.inf, 0, m + 1
    l_lo, l_hi = np.float32(0.0), np.float32(0.0)
    lo, hi = np.float32(np.inf), np.float32(-np.inf)
    for k in range(1, m):                      # left: the run's lights 0 .. k-1
        i = entries[a + k - 1]
        lo = min(lo, depth_lo[i])
        hi = max(hi, depth_hi[i])
        if big and _need(k) + _need(m - k) > budget:
            continue
        cost = (float(hi) - float(lo)) * k + (float(suf_hi[k]) - float(suf_lo[k])) * (m - k)
        d = abs(2 * k - m)
        if cost < best or (cost == best and d < bd):
            best, bk, bd, l_lo, l_hi = cost, k, d, lo, hi
    if bk == 0:
        return 0, best, l_lo, l_hi, l_lo, l_hi
    return bk, best, l_lo, l_hi, suf_lo[bk], suf_hi[bk]


@numba.njit(inline="always")
def build_topdown(o, n, budget, lo0, hi0, entries, depth_lo, depth_hi, lights_per_leaf,
                  node_cost, suf_lo, suf_hi, st_a, st_n, st_b, st_lo, st_hi, size,
                  nodes_f, nodes_u, base):
    """The top-down tree of a cell's n > 0 lights (entries o .. o+n-1, bounds lo0 .. hi0)
    with at most `budget` leaves, written depth-first from node `base`; returns its node
    count.  Scratch: suf_* >= n, st_* >= budget + 1, size >= 2 * budget - 1."""
    st_a[0], st_n[0], st_b[0], st_lo[0], st_hi[0] = o, n, budget, lo0, hi0
    top, p = 1, 0
    base = np.uint64(base)
    while top > 0:
        top -= 1
        a, m, b, lo, hi = st_a[top], st_n[top], st_b[top], st_lo[top], st_hi[top]
        q = base + np.uint64(p)
        nodes_f[q, NODE_MIN_DEPTH], nodes_f[q, NODE_MAX_DEPTH] = lo, hi
        nodes_u[q, NODE_FIRST_LIGHT] = a
        k = 0
        if b > 1 and (m > lights_per_leaf or m > NODE_MAX_LIGHTS):
            k, cost, l_lo, l_hi, r_lo, r_hi = _best_split(a, m, b, entries, depth_lo,
                                                          depth_hi, suf_lo, suf_hi)
            ext = float(hi) - float(lo)
            if k > 0 and m <= NODE_MAX_LIGHTS and not cost + 2.0 * node_cost * ext < m * ext:
                k = 0                          # the split saves less than its two visits
        if k == 0:
            size[p] = 1                        # a leaf: its light count kept until the bits
            nodes_u[q, NODE_BITS] = m
        else:
            size[p] = 0
            bl = min(max((b * k + m // 2) // m, _need(k)), b - _need(m - k))
            st_a[top], st_n[top], st_b[top], st_lo[top], st_hi[top] = a + k, m - k, b - bl, r_lo, r_hi
            st_a[top + 1], st_n[top + 1], st_b[top + 1] = a, k, bl
            st_lo[top + 1], st_hi[top + 1] = l_lo, l_hi
            top += 2
        p += 1
    for j in range(p - 1, -1, -1):             # subtree sizes: the left child at j + 1
        if size[j] == 0:
            left = size[j + 1]
            size[j] = 1 + left + size[j + 1 + left]
    for j in range(p):
        q = base + np.uint64(j)
        if size[j] == 1:
            nodes_u[q, NODE_BITS] = node_bits(1, nodes_u[q, NODE_BITS], 1)
        else:
            nodes_u[q, NODE_BITS] = node_bits(0, 0, size[j])
    return p
