#version 430
// hybrid (tree paper 3.3-3.4): each cell of the 2.5D grid holds a list (a one-node tree whose
// root is a leaf) or a tree.  The wave picks one of three loops: a) every lane a list,
// b) every lane a tree (from shared memory when the whole group shares one tree),
// c) mixed: the general traversal, which handles both.
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"
#include "tree.glsl"

void main() {
    PixelState s = load_pixel();
    uint cell = s.shading ? cell_of(s) : 0u;
    uvec2 r = s.shading ? ranges[cell].offset_count : uvec2(0u);
    bool is_tree = s.shading && r.y > 1u;
    bool is_list = s.shading && r.y == 1u;

    // One group vote: the cell range of tree lanes, their node count, and whether any lane
    // has a tree / any shading lane has none.  The shared-memory load needs barriers, so it
    // is decided by this group-wide vote whichever wave API is compiled.
    uvec4 v = groupReduce(is_tree ? cell : 0xFFFFFFFFu, is_tree ? cell : 0u, is_tree ? r.y : 0u,
                          (is_tree ? 1u : 0u) | (s.shading && !is_tree ? 2u : 0u));
    bool one_tree = v.w == 1u && v.x == v.y && v.z <= uint(SHARED_TREE_NODES);
#if WAVE_NATIVE
    bool all_list = waveActiveAllTrue(!is_tree);
    bool all_tree = waveActiveAllTrue(is_tree || !s.shading);
#else
    bool all_list = (v.w & 1u) == 0u;      // the emulated wave is the group: reuse its vote
    bool all_tree = (v.w & 2u) == 0u;
#endif
    // bit 0 list, bit 1 tree (both: mixed), bit 2 the group traversed one shared-memory tree
    uint case_bits = (is_list ? 1u : 0u) | (is_tree ? 2u : 0u) | (one_tree ? 4u : 0u);

    if (one_tree) {
        load_shared_tree(groupReduce(0u, is_tree ? r.x : 0u, 0u, 0u).y, v.z);
        if (s.shading) traverse_shared_tree(s, r.y);
    } else if (all_list) {
        // a) lists only: one node each, the root is the leaf (paper 3.4: "a dependent
        //    fetch and a bit test"); no loop
        if (is_list) {
            uint i = 0u;
            visit_node(s, nodes[r.x], i);
        }
    } else if (all_tree) {
        // b) trees only
        if (s.shading) traverse_tree(s, r.x, r.y);
    } else {
        // c) mixed
        if (s.shading) traverse_tree(s, r.x, r.y);
    }
    store_pixel(s);
    write_wave_stats(s.evaluated + s.nodes, case_bits);
}
