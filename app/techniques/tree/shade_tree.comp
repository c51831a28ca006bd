#version 430
// tree (O'Donnell & Chajdas): one light tree per 2D screen tile, listing 3 traversal.
// SHARED_TREE (paper 3.4, as the hybrid's tree path): when every shading pixel of the 8x8
// group reads one tree of at most SHARED_TREE_NODES nodes, the group loads it into shared
// memory once (load_shared_tree) and traverses it from there; any other group traverses
// its pixels' trees in global memory, so the lights and nodes are the same either way.
//   TILE_ALIGNED (the tile size a multiple of 8, e.g. 48): a group lies in one tile, so its
//     tree is known without a vote: every invocation reads the group's tile record from
//     one address; one barrier (the load's) where the tree has 1..SHARED_TREE_NODES nodes.
//   otherwise a group may straddle tiles: a group vote (groupReduce, 4 barriers) says
//     whether its shading pixels share one tree, then the load's barrier where they do.
// Both decisions are uniform over the group, so the barriers are in uniform control flow.
// define: SHARED_TREE TILE_ALIGNED
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"
#include "tree.glsl"

void main() {
    PixelState s = load_pixel();
#if SHARED_TREE
    s.cell = s.shading ? cell_of(s) : 0u;
    CELLS_ONLY_RETURN(s);            // every invocation returns: no barrier is left half-met
#if TILE_ALIGNED
    // the group's tile (u_slices is 1: a cell is a tile), the same for all its pixels
    ivec2 t = ivec2(gl_WorkGroupID.xy * gl_WorkGroupSize.xy) / u_tile;
    uvec2 r = ranges[uint(t.y) * uint(u_tiles.x) + uint(t.x)].offset_count;
    uint base = r.x, count = r.y;
    bool one_tree = count - 1u < uint(SHARED_TREE_NODES);        // 1 .. SHARED_TREE_NODES
#else
    uvec2 r = s.shading ? ranges[s.cell].offset_count : uvec2(0u);
    // min and max of the shading pixels' cells; their first node and node count (max, OR:
    // exact where the cells are one)
    uvec4 v = groupReduce(s.shading ? s.cell : 0xFFFFFFFFu, s.shading ? s.cell : 0u, r.x, r.y);
    uint base = v.z, count = v.w;
    bool one_tree = v.x == v.y && count - 1u < uint(SHARED_TREE_NODES);
#endif
    if (one_tree) {
        load_shared_tree(base, count);
        if (s.shading) traverse_shared_tree(s, count);
    } else if (s.shading) {
        traverse_tree(s, r.x, r.y);
    }
    store_pixel(s);
    write_wave_stats(s.evaluated + s.nodes, CASE_TREE | (one_tree ? CASE_SHARED_TREE : 0u));
#else
    if (s.shading) {
        s.cell = cell_of(s);
        CELLS_ONLY_RETURN(s);
        uvec2 r = ranges[s.cell].offset_count;
        traverse_tree(s, r.x, r.y);
    }
    store_pixel(s);
    write_wave_stats(s.evaluated + s.nodes, CASE_TREE);
#endif
}
