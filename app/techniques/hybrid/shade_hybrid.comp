#version 430
// hybrid (tree paper 3.3-3.4): each cell of the 2.5D grid holds a list (a one-node tree whose
// root is a leaf) or a tree; listing 2 chose which (the top bit of the cell's node count,
// CELL_TREE_BIT, keeps that choice for the statistics: a chosen list of more than 65,535
// lights is stored as a small tree of lists).  With SPECIALISED the wave takes one of the
// paper's three paths:
//   a) every lane a list: one node each, the root is the leaf ("a dependent fetch and a
//      bit test"), no loop; with SCALARIZED the wave walks its distinct list cells one at a
//      time from a wave-uniform node address (Drobot 2017's container scalarization);
//   b) every lane a tree: the stackless traversal (listing 3), from shared memory when the
//      whole group traverses one tree (paper 3.4: "loads the tree into local memory");
//   c) mixed: list lanes visit their one node, tree lanes traverse.
// Without SPECIALISED every lane runs the general traversal (the unspecialised loop the
// report compares against).
// With feature variants (app/techniques/variants.py) CELL_KINDS says which cells the tile's
// pixels read, by structure: 1 lists only, 2 trees only, 3 both (the general program), 0
// none; a kind the tile lacks folds to false, so its loop is not compiled.
// define: SPECIALISED SCALARIZED CELL_KINDS
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"
#include "tree.glsl"
#include "hybrid_cells.glsl"        // CELL_TREE_BIT, from app/techniques/hybrid.py
#ifndef CELL_KINDS
#define CELL_KINDS 3
#endif

// a) scalarized: the wave's distinct list cells, one per round (lists.glsl's
// next_wave_cell), each its one node; returns the wave's scalar iterations (rounds + lights).
uint walk_list_cells(inout PixelState s, uint cell, bool pending) {
    uint iterations = 0u, c;
    while (next_wave_cell(pending, cell, c)) {
        TreeNode n = nodes[ranges[c].offset_count.x];          // a wave-uniform address
        iterations += 1u + node_light_count(n.bits);
        if (pending && c == cell) {
            uint i = 0u;
            visit_node(s, n, i);
            pending = false;
        }
    }
    return iterations;
}

void main() {
    PixelState s = load_pixel();
    uint cell = s.shading ? cell_of(s) : 0u;
    s.cell = cell;
    CELLS_ONLY_RETURN(s);
    uvec2 r = s.shading ? ranges[cell].offset_count : uvec2(0u);
    uint count = r.y & ~CELL_TREE_BIT;
    bool is_tree = (CELL_KINDS & 2) != 0 && s.shading && count > 1u;   // by structure: which loop can read it
    bool is_list = (CELL_KINDS & 1) != 0 && s.shading && count == 1u;
    // listing 2's choice, list or tree (both in one wave: CASE_MIXED)
    uint case_bits = s.shading ? ((r.y & CELL_TREE_BIT) != 0u ? CASE_TREE : CASE_LIST) : 0u;
    uint iterations = 0u;
#if SPECIALISED
    // One group vote: the cell range of tree lanes, their node count, and whether any lane
    // has a tree / any shading lane has none.  The shared-memory load needs barriers, so it
    // is decided by this group-wide vote whichever wave API is compiled.
    uvec4 v = groupReduce(is_tree ? cell : 0xFFFFFFFFu, is_tree ? cell : 0u, is_tree ? count : 0u,
                          (is_tree ? 1u : 0u) | (s.shading && !is_tree ? 2u : 0u));
    bool one_tree = v.w == 1u && v.x == v.y && v.z <= uint(SHARED_TREE_NODES);
#if WAVE_NATIVE
    bool all_list = waveActiveAllTrue(!is_tree);
    bool all_tree = waveActiveAllTrue(is_tree || !s.shading);
#else
    bool all_list = (v.w & 1u) == 0u;      // the emulated wave is the group: reuse its vote
    bool all_tree = (v.w & 2u) == 0u;
#endif
    if (one_tree) case_bits |= CASE_SHARED_TREE;     // the group read one tree from shared memory

    if (one_tree) {
        load_shared_tree(groupReduce(0u, is_tree ? r.x : 0u, 0u, 0u).y, v.z);
        if (s.shading) traverse_shared_tree(s, count);
    } else if (all_list) {
#if SCALARIZED
        iterations = walk_list_cells(s, cell, is_list);
#else
        if (is_list) {
            uint i = 0u;
            visit_node(s, nodes[r.x], i);
        }
#endif
    } else if (all_tree) {
        if (s.shading) traverse_tree(s, r.x, count);
    } else if (is_list) {
        uint i = 0u;
        visit_node(s, nodes[r.x], i);
    } else if (is_tree) {
        traverse_tree(s, r.x, count);
    }
#else
    if (is_tree || is_list) traverse_tree(s, r.x, count);
#endif
    store_pixel(s);
    write_wave_stats(iterations != 0u ? iterations : s.evaluated + s.nodes, case_bits);
}
