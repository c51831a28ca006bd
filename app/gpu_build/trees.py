"""tree's and hybrid's cells built on the GPU (--build gpu): per cell a light tree with skip
counts (tree paper 3.1-3.2) or, in the hybrid, listing 2's choice of a list or a tree (3.3),
as compute passes over the cells' index lists (app/gpu_build/build_tree.comp), each buffer bit for
bit cpu_prep/tree.py's and hybrid.py's (tests/app/gpu_build/test_trees.py).

    (lists.py: the cells' lists -> entries[E], gb_list_ranges[cell], the longest list)
    build_tree  the entries' depth bounds by blocks of 256 and of 65,536 entries
                [hybrid] listing 2's float64 sum per cell, in entry order, one dispatch a
                window of DISPATCH_WINDOW entries where the driver has a loop limit
                each cell's leaves L and 2 L - 1 nodes --scan--> gb_node_first, the node
                count -> counters[NODES]
                (host step: the nodes, the most leaves of a cell, the trees and lists read
                 back: the 15-bit skip count checked, the nodes buffer sized by the count)
                ranges[cell] = (first node, node count | the hybrid's tree bit)
                nodes[]: each node on its own, depth-first through the paper's precomputed
                tables, its bounds over its entries by those blocks

The CPU builds a cell's tree bottom-up (leaves, then each parent from its two children, in
one thread a cell); here every node is one invocation that finds its leaves' entries and
takes the min and max of their depth ranges directly: the same values, the same first of
equal ones (build_tree.comp), with no order between the nodes and every loop bounded (a
cell of a million entries is read as 256-entry and 65,536-entry blocks).  Only the paper's
bottom-up full trees are built here (--tree-build topdown stays on the CPU).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from cpu_prep import layouts, limits, tree as treemod

from ..pipeline.passes import Build, Buffer, Pass
from . import steps
from .prepare import (CHOSEN_TREES, COUNTER_FILES, COUNTERS, LISTS, LISTS_AS_TREES, MAX_LEAVES,
                      NODES, TREES, check_items, counters, host)

LIST_RANGES = "gb_list_ranges"     # the cells' index lists; `ranges` is the trees'
TABLES = "gb_tree_tables"
SLICE_DEPTHS = "gb_slice_depths"
BLOCK = 256                        # build_tree.comp: entries a block, blocks a super block


def most_leaves(max_leaves: int, capacity: int) -> int:
    """The most leaves a cell of at most `capacity` lights can get (tree.tree_leaves), up to
    the 15-bit skip count's 16,384 (past it the build refuses, as the CPU's)."""
    split = 1 << max(-(-int(capacity) // limits.NODE_MAX_LIGHTS) - 1, 0).bit_length()
    return min(max(int(max_leaves), split), (limits.NODE_MAX_SKIP + 1) // 2)


@lru_cache(maxsize=16)
def tables(leaves: int) -> tuple[np.ndarray, int, int]:
    """The depth-first tables of every power of two up to `leaves` (tree._all_tables: the
    breadth-first index of each position, its skip count, each size's first position) as
    one uint32 array, and where the skips and the offsets start in it."""
    order, skip, offsets = treemod._all_tables(leaves)
    words = np.concatenate([order, skip, offsets]).astype(np.uint32)
    words.flags.writeable = False
    return words, len(order), 2 * len(order)


def cell_pass(step: int, cells: int, reads, writes, uniforms, defines=None) -> Pass:
    """One invocation a cell (a TREE_STEP of build_tree.comp), its buffers by their names."""
    return Pass("build_tree", "build_tree.comp", reads=tuple(reads), writes=writes,
                groups=steps.groups(steps.blocks(cells)), defines=dict(defines or {}, TREE_STEP=step),
                uniforms=dict(uniforms, u_cells=cells), virtual=COUNTER_FILES,
                sources=sources_of(tuple(reads) + tuple(writes)))


# the build's buffers behind build_tree.comp's slots
SOURCES = {"counters": COUNTERS, "list_ranges": LIST_RANGES, "sums": "gb_plan_sums",
           "slice_depths": SLICE_DEPTHS, "node_counts": "gb_node_counts", "node_first": "gb_node_first",
           "cell_leaves": "gb_cell_leaves", "blocks": "gb_entry_blocks", "super": "gb_entry_super",
           "tables": TABLES}


def sources_of(slots) -> dict:
    return {s: SOURCES[s] for s in slots if s in SOURCES}


def block_passes(entries: int) -> list[Pass]:
    nb = steps.blocks(entries, BLOCK)
    ns = steps.blocks(nb, BLOCK)
    return [Pass("build_tree", "build_tree.comp", reads=("counters", "entries", "light_depth"),
                 writes={"blocks": Buffer(8 * nb)}, groups=steps.groups(steps.blocks(nb)),
                 defines={"TREE_STEP": 0}, virtual=COUNTER_FILES,
                 sources=sources_of(("counters", "blocks"))),
            Pass("build_tree", "build_tree.comp", reads=("counters", "blocks"),
                 writes={"super": Buffer(8 * ns)}, groups=steps.groups(steps.blocks(ns)),
                 defines={"TREE_STEP": 1}, virtual=COUNTER_FILES,
                 sources=sources_of(("counters", "blocks", "super")))]


def plan_passes(b: Build, windows) -> list[Pass]:
    """Listing 2's sums, one pass a window of the longest list's entries (`windows`: the
    technique's dispatch windows, base.windows)."""
    g = b.grid
    return [cell_pass(2, g.cells, ("counters", "list_ranges", "entries", "light_depth", "slice_depths"),
                      {"sums": Buffer(8 * g.cells)}, {"u_slices": g.slices, "u_entries_window": w})
            for w in windows(b.longest_list)]


def tree_passes(b: Build, opts, table_leaves: int, tree_bit: int | None, windows, then) -> list:
    """The cells' trees (tree_bit: the hybrid's CELL_TREE_BIT, its choice first; None: every
    cell a tree) into `ranges` and `nodes`, then the host step that sizes the nodes and hands
    over to `then()`: the technique's steps.  table_leaves: the most leaves a tree holds
    (the tables upload_tables put in the build)."""
    g, entries = b.grid, b.stats["list_entries"]
    plan = tree_bit is not None
    choice = {"u_slices": g.slices, "u_radius_scale": float(opts.radius_scale)} if plan else {}
    leaves = cell_pass(3, g.cells, ("list_ranges",) + (("slice_depths", "sums") if plan else ()),
                       {"counters": counters(), "node_counts": steps.words(g.cells),
                        "cell_leaves": steps.words(g.cells)},
                       dict(choice, u_lights_per_leaf=opts.lights_per_leaf, u_max_leaves=opts.max_leaves),
                       defines={"TREE_PLAN": int(plan)})
    sums = plan_passes(b, windows) if plan else []

    def sized(read):
        c = read[COUNTERS]
        nodes = int(c[NODES])
        if g.cells:
            treemod._check_skip(int(c[MAX_LEAVES]))       # the CPU build's refusal, same words
        check_items(b.frame, "the tree nodes", layouts.TREE_NODE.itemsize, nodes, "nodes")
        b.stats.update(nodes=nodes, trees=int(c[TREES]), lists=int(c[LISTS]))
        if plan:
            used = int(c[TREES]) + int(c[LISTS])
            b.stats.update(trees=int(c[CHOSEN_TREES]), lists=used - int(c[CHOSEN_TREES]),
                           lists_stored_as_trees=int(c[LISTS_AS_TREES]))
        return {}, node_passes(b, table_leaves, int(tree_bit or 0), nodes) + list(then())
    return (block_passes(entries) + sums + [leaves]
            + steps.scan("build_tree", "gb_node_counts", "gb_node_first", g.cells, COUNTERS, NODES)
            + [host("build_tree_nodes", (COUNTERS,), sized)])


def node_passes(b: Build, leaves: int, tree_bit: int, nodes: int) -> list[Pass]:
    """Each cell's range (tree_bit: the hybrid's CELL_TREE_BIT, else 0) and each node (the
    tables uploaded with the build for trees of up to `leaves` leaves)."""
    g = b.grid
    _, skip_at, offsets_at = tables(leaves)
    ranges = cell_pass(4, g.cells, ("node_first", "node_counts", "cell_leaves"),
                       {"ranges": Buffer(g.cells * layouts.CELL_RANGE.itemsize, layouts.CELL_RANGE)},
                       {"u_tree_bit": tree_bit})
    fill = Pass("build_tree", "build_tree.comp",
                reads=("counters", "entries", "light_depth", "list_ranges", "blocks", "super",
                       "node_first", "cell_leaves", "tables"),
                writes={"nodes": Buffer(max(nodes, 1) * layouts.TREE_NODE.itemsize, layouts.TREE_NODE)},
                groups=steps.groups(steps.blocks(nodes)), defines={"TREE_STEP": 5},
                uniforms={"u_cells": g.cells, "u_table_skip": skip_at, "u_table_offsets": offsets_at},
                virtual=COUNTER_FILES, sources=sources_of(("counters", "list_ranges", "blocks", "super",
                                                          "node_first", "cell_leaves", "tables")))
    return [ranges, fill]


def frame_leaves(frame, opts) -> int:
    """The most leaves a tree of this frame can hold (tree_passes' `table_leaves`)."""
    return most_leaves(opts.max_leaves, len(frame.lights))


def upload_tables(b: Build, leaves: int) -> None:
    """The depth-first tables for every tree of up to `leaves` leaves, uploaded with the build."""
    b.buffers[TABLES] = tables(leaves)[0]


def tree_readback(b: Build) -> dict:
    """The trees' buffers for lists.readback_step, as the CPU build's arrays."""
    return {"ranges": (layouts.CELL_RANGE, (), b.grid.cells),
            "nodes": (layouts.TREE_NODE, (), b.stats["nodes"]),
            "entries": (np.uint32, (), b.stats["list_entries"])}
