#version 430
// Feature variants, step 1 (app/techniques/variants.py): per cell of the technique's
// structure, the feature bits of the lights its pixels can meet, one invocation a cell:
//   CELL_SOURCE 1  index lists: ranges[cell] = (first, count) -> entries[] -> lights[]
//                  (tiled, clustered; a tiled count of TILE_OVERFLOW shades every light)
//   CELL_SOURCE 2  hybrid's cells: ranges[cell] = (first node, node count | CELL_TREE_BIT)
//                  -> nodes[] -> each leaf's entries; adds the cell's kind by structure
//                  (one node: read as a list, more: as a tree), as shade_hybrid.comp reads it
//   CELL_SOURCE 3  bit arrays: the cell's u_words words (zbin), bit N = light N
//   (CELL_PRECOMPUTED, 4: this pass does not run, the technique's own pass writes these
//   words: fptl_lists.comp, whose packed lists with spill are no CSR scan)
// A cell whose scan would pass SCAN_BUDGET iterations takes every shape of the frame
// (u_frame_shapes) unscanned: conservative, so still exact, and clear of llvmpipe's silent
// loop limit (a truncated scan would miss a shape and shade it with a program that lacks it).
// define: CELL_SOURCE SCAN_BUDGET CELL_COUNT_MASK
#include "generated.glsl"

layout(local_size_x = 64) in;

layout(std430, binding = B_LIGHTS) readonly buffer LightBuffer { GpuLight lights[]; };
#if CELL_SOURCE == 3
layout(std430, binding = B_TILE_BITS) readonly buffer TileBits { uint tile_bits[]; };
uniform uint u_words;
#else
layout(std430, binding = B_RANGES) readonly buffer Ranges { CellRange ranges[]; };
layout(std430, binding = B_ENTRIES) readonly buffer Entries { uint entries[]; };
#endif
#if CELL_SOURCE == 2
layout(std430, binding = B_NODES) readonly buffer Nodes { TreeNode nodes[]; };
#endif
layout(std430, binding = B_CELL_FEATURES) writeonly buffer CellFeatures { uint cell_features[]; };

uniform uint u_cells;
uniform uint u_frame_shapes;  // the shape bits of every visible light

uint shape_bit(uint light) { return 1u << lights[light].id_type.y; }

#if CELL_SOURCE != 3
// The shapes of entries [first, first + count), `budget` counting down the iterations.
uint entry_shapes(uint first, uint count, inout int budget) {
    uint bits = 0u;
    budget -= int(min(count, uint(SCAN_BUDGET) + 1u));
    if (budget < 0) return u_frame_shapes;
    for (uint k = first; k < first + count; ++k) bits |= shape_bit(entries[k]);
    return bits;
}
#endif

// priced: load
void main() {
    uint cell = gl_GlobalInvocationID.x;
    if (cell >= u_cells) return;
    int budget = SCAN_BUDGET;
    uint bits = 0u;
#if CELL_SOURCE == 1
    uvec2 r = ranges[cell].offset_count;
    bits = entry_shapes(r.x, r.y, budget);
#elif CELL_SOURCE == 2
    uvec2 r = ranges[cell].offset_count;
    uint count = r.y & uint(CELL_COUNT_MASK);
    if (count == 1u) bits |= FEATURE_LIST_CELLS_BIT;
    if (count > 1u) bits |= FEATURE_TREE_CELLS_BIT;
    budget -= int(min(count, uint(SCAN_BUDGET) + 1u));
    if (budget < 0) {
        bits |= u_frame_shapes;
    } else {
        for (uint i = r.x; i < r.x + count; ++i) {
            TreeNode n = nodes[i];
            if ((n.bits & 1u) != 0u)                       // a leaf (tree.glsl node_is_leaf)
                bits |= entry_shapes(n.first_light, (n.bits >> 1) & ((1u << NODE_COUNT_BITS) - 1u), budget);
        }
    }
#else
    budget -= int(min(u_words, uint(SCAN_BUDGET) + 1u));
    for (uint w = 0u; w < u_words && budget >= 0; ++w) {
        uint word = tile_bits[cell * u_words + w];
        budget -= bitCount(word);
        while (word != 0u && budget >= 0) {
            uint b = uint(findLSB(word));
            word ^= 1u << b;
            bits |= shape_bit(32u * w + b);
        }
    }
    if (budget < 0) bits = u_frame_shapes;
#endif
    cell_features[cell] = bits;
}
