#version 430
// tree's and hybrid's cells on the GPU, cpu_prep/tree.py's and hybrid.py's bit for bit
// (app/gpu_build/trees.py), over the cells' index lists (build_bin.comp):
//   TREE_STEP 0  each block of 256 entries: the min and max of its lights' depth ranges
//   TREE_STEP 1  each block of 256 such blocks: their min and max (a node's range of entries
//                is then read as at most 255 entries, 255 blocks, its 65,536-entry blocks,
//                255 blocks, 255 entries at each end: bounded loops, in entry order)
//   TREE_STEP 2  listing 2's sum (hybrid): each cell's lights' depth extents clipped to its
//                slice, in entry order, float64, over the entries of one dispatch window
//                [u_entries_window) of the cell, carried in sums[] from window to window
//   TREE_STEP 3  each cell's leaves (tree.tree_leaves / list_leaves; TREE_PLAN, the hybrid:
//                listing 2's choice, tree.py _build_range's test) and node count 2 L - 1 (0: empty),
//                scanned next: each cell's first node; the counts of trees and lists
//   TREE_STEP 4  each cell's range (first node, node count | the hybrid's tree bit)
//   TREE_STEP 5  each node: its cell (binary search of the first nodes), its breadth-first
//                index and skip count from the precomputed depth-first tables (the paper's
//                conversion, tree.depth_first_tables), its entries (the balanced split of
//                the cell's depth-sorted lights into L leaves), their bounds, the packed node
// The min and max keep the first of equal values, as numba's min / max over the entries in
// order (and a node's bounds as its children's: the same value, the same first one).
// define: TREE_STEP TREE_PLAN
#include "generated.glsl"
#include "build_common.glsl"
#include "build_counters.glsl"

const uint BLOCK = 256u;

#if TREE_STEP == 0 || TREE_STEP == 2 || TREE_STEP == 5
layout(std430, binding = B_ENTRIES) readonly buffer Entries { uint entries[]; };
layout(std430, binding = B_LIGHT_DEPTH) readonly buffer Depths { vec2 light_depth[]; };
#endif
#if TREE_STEP >= 2 && TREE_STEP != 4
layout(std430, binding = B_LIST_RANGES) readonly buffer ListRanges { CellRange list_ranges[]; };
#endif
#if TREE_STEP == 3
layout(std430, binding = B_COUNTERS) buffer Counters { uint counters[]; };
#else
layout(std430, binding = B_COUNTERS) readonly buffer Counters { uint counters[]; };
#endif

const float F_INF = uintBitsToFloat(0x7F800000u);

// numba's min(lo, v) and max(hi, v) (Python's: the first of equal values stays)
void take(inout vec2 acc, vec2 v) {
    acc.x = v.x < acc.x ? v.x : acc.x;
    acc.y = v.y > acc.y ? v.y : acc.y;
}

#if TREE_STEP == 0
layout(std430, binding = B_BLOCKS) buffer Blocks { vec2 blocks[]; };

void main() {
    uint k = element_index(), n = counters[COUNTER_ENTRIES];
    if (k * BLOCK >= n) return;
    vec2 acc = vec2(F_INF, -F_INF);
    for (uint e = k * BLOCK, end = min(n, (k + 1u) * BLOCK); e < end; ++e)
        take(acc, light_depth[entries[e]]);
    blocks[k] = acc;
}
#elif TREE_STEP == 1
layout(std430, binding = B_BLOCKS) readonly buffer Blocks { vec2 blocks[]; };
layout(std430, binding = B_SUPER) buffer Super { vec2 super_blocks[]; };

void main() {
    uint k = element_index(), nb = (counters[COUNTER_ENTRIES] + BLOCK - 1u) / BLOCK;
    if (k * BLOCK >= nb) return;
    vec2 acc = vec2(F_INF, -F_INF);
    for (uint i = k * BLOCK, end = min(nb, (k + 1u) * BLOCK); i < end; ++i)
        take(acc, blocks[i]);
    super_blocks[k] = acc;
}
#elif TREE_STEP == 2
layout(std430, binding = B_SLICE_DEPTHS) readonly buffer SliceDepths { dvec2 slice_depths[]; };
layout(std430, binding = B_SUMS) buffer Sums { double sums[]; };

uniform uint u_cells;
uniform uint u_slices;
uniform uvec2 u_entries_window;   // the entries [x, y) of each cell this dispatch sums

void main() {
    uint c = element_index();
    if (c >= u_cells) return;
    uvec2 r = list_ranges[c].offset_count;
    dvec2 s = slice_depths[c % u_slices];          // listing 2's clip (hybrid.cell_depth_ranges)
    precise double total = u_entries_window.x == 0u ? 0.0lf : sums[c];
    for (uint e = r.x + min(r.y, u_entries_window.x), end = r.x + min(r.y, u_entries_window.y);
         e < end; ++e) {
        vec2 d = light_depth[entries[e]];
        double dl = double(d.x), dh = double(d.y);
        precise double top = s.y < dh ? s.y : dh;      // min(dh, hi_s)
        precise double bot = s.x > dl ? s.x : dl;      // max(dl, lo_s)
        precise double ext = top - bot;
        total += 0.0lf > ext ? 0.0lf : ext;            // max(ext, 0.0)
    }
    sums[c] = total;
}
#elif TREE_STEP == 3
#if TREE_PLAN
layout(std430, binding = B_SLICE_DEPTHS) readonly buffer SliceDepths { dvec2 slice_depths[]; };
layout(std430, binding = B_SUMS) readonly buffer Sums { double sums[]; };
uniform double u_radius_scale;
uniform uint u_slices;
#endif
layout(std430, binding = B_NODE_COUNTS) buffer NodeCounts { uint node_counts[]; };
layout(std430, binding = B_CELL_LEAVES) buffer CellLeaves { uint cell_leaves[]; };

uniform uint u_cells;
uniform uint u_lights_per_leaf, u_max_leaves;

uint pow2_at_least(uint x) { return x <= 1u ? 1u : 1u << uint(findMSB(x - 1u) + 1); }

void main() {
    uint c = element_index();
    if (c >= u_cells) return;
    uint n = list_ranges[c].offset_count.y;
    if (n == 0u) {
        node_counts[c] = 0u;
        cell_leaves[c] = 0u;
        return;
    }
#if TREE_PLAN
    // listing 2: the mean clipped extent against the cell's radius (hybrid.py's reading)
    dvec2 s = slice_depths[c % u_slices];
    precise double mean = sums[c] / double(n);
    precise double radius = 0.5lf * (s.y - s.x) * u_radius_scale;
    bool tree = mean < radius;
#else
    bool tree = true;                 // tree: every cell a tree
#endif
    const uint max_lights = (1u << NODE_COUNT_BITS) - 1u;                        // a leaf's 16-bit count
    uint split = pow2_at_least((n + max_lights - 1u) / max_lights);
    uint leaves = tree ? max(min(pow2_at_least((n + u_lights_per_leaf - 1u) / u_lights_per_leaf),
                                 u_max_leaves), split) : split;
    node_counts[c] = 2u * leaves - 1u;
    cell_leaves[c] = leaves | (tree ? 0x80000000u : 0u);
    atomicMax(counters[COUNTER_MAX_LEAVES], leaves);
    atomicAdd(counters[leaves > 1u ? COUNTER_TREES : COUNTER_LISTS], 1u);
    if (tree) atomicAdd(counters[COUNTER_CHOSEN_TREES], 1u);
    else if (leaves > 1u) atomicAdd(counters[COUNTER_LISTS_AS_TREES], 1u);
}
#elif TREE_STEP == 4
layout(std430, binding = B_NODE_FIRST) readonly buffer NodeFirst { uint node_first[]; };
layout(std430, binding = B_NODE_COUNTS) readonly buffer NodeCounts { uint node_counts[]; };
layout(std430, binding = B_CELL_LEAVES) readonly buffer CellLeaves { uint cell_leaves[]; };
layout(std430, binding = B_RANGES) buffer Ranges { CellRange ranges[]; };

uniform uint u_cells;
uniform uint u_tree_bit;          // the hybrid's CELL_TREE_BIT where listing 2 chose a tree; tree: 0

void main() {
    uint c = element_index();
    if (c >= u_cells) return;
    bool tree = (cell_leaves[c] & 0x80000000u) != 0u;
    ranges[c].offset_count = uvec2(node_first[c], node_counts[c] | (tree ? u_tree_bit : 0u));
}
#else
layout(std430, binding = B_BLOCKS) readonly buffer Blocks { vec2 blocks[]; };
layout(std430, binding = B_SUPER) readonly buffer Super { vec2 super_blocks[]; };
layout(std430, binding = B_NODE_FIRST) readonly buffer NodeFirst { uint node_first[]; };
layout(std430, binding = B_CELL_LEAVES) readonly buffer CellLeaves { uint cell_leaves[]; };
layout(std430, binding = B_TABLES) readonly buffer Tables { uint tables[]; };
layout(std430, binding = B_NODES) buffer Nodes { TreeNode nodes[]; };

uniform uint u_cells;
uniform uint u_table_skip;        // tables[]: the breadth-first indices, then (here) the skips
uniform uint u_table_offsets;     // ... then each power of two's first position

// The last cell whose first node is at or before g (the cells between hold none).
uint node_cell(uint g) {
    uint lo = 0u, hi = u_cells;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) >> 1;
        if (node_first[mid] <= g) lo = mid; else hi = mid;
    }
    return lo;
}

// (j * n) >> k for j <= 2^k <= 2^14 without a 64-bit product (tree._leaves' leaf bounds)
uint split_at(uint j, uint n, uint k) {
    return j * (n >> k) + ((j * (n & ((1u << k) - 1u))) >> k);
}

// The min and max of the depth ranges of entries [a, b), in entry order, by whole blocks
// where they fit (the order of the values taken is the entries' order).
vec2 range_bounds(uint a, uint b) {
    vec2 acc = vec2(F_INF, -F_INF);
    uint e = a;
    for (; e < b && (e & (BLOCK - 1u)) != 0u; ++e) take(acc, light_depth[entries[e]]);
    for (; e + BLOCK <= b && ((e / BLOCK) & (BLOCK - 1u)) != 0u; e += BLOCK) take(acc, blocks[e / BLOCK]);
    for (; e + BLOCK * BLOCK <= b; e += BLOCK * BLOCK) take(acc, super_blocks[e / (BLOCK * BLOCK)]);
    for (; e + BLOCK <= b; e += BLOCK) take(acc, blocks[e / BLOCK]);
    for (; e < b; ++e) take(acc, light_depth[entries[e]]);
    return acc;
}

void main() {
    uint g = element_index();
    if (g >= counters[COUNTER_NODES]) return;
    uint c = node_cell(g);
    uint q = g - node_first[c];
    uint leaves = cell_leaves[c] & 0x7FFFFFFFu;
    uint k = uint(findMSB(leaves));
    uint t = tables[u_table_offsets + k] + q;
    uint src = tables[t], skip = tables[u_table_skip + t];
    uint d = uint(findMSB(src + 1u)), p = src + 1u - (1u << d);     // src's depth and place
    uvec2 r = list_ranges[c].offset_count;
    uint a = r.x + split_at(p << (k - d), r.y, k), b = r.x + split_at((p + 1u) << (k - d), r.y, k);
    uint leaf = skip == 1u ? 1u : 0u;
    vec2 bounds = range_bounds(a, b);
    nodes[g].min_depth = bounds.x;
    nodes[g].max_depth = bounds.y;
    nodes[g].first_light = a;
    nodes[g].bits = leaf | ((b - a) * leaf << 1) | (skip << (1u + NODE_COUNT_BITS));
}
#endif
