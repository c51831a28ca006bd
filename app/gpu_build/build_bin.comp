#version 430
// clustered's binning on the GPU, cpu_prep/grid.py's bin_rects bit for bit:
//   BIN_STEP 0  each visible light's box of cells (grid._box: tile_of's corrected floor,
//               slice_from_table's search of the depths where listing 4 steps) and its cell
//               count (0 past the visible lights; scanned next: each light's first entry)
//   BIN_STEP 1  each entry (cell, light): a light's entries in its box's order; stable-sorted
//               by cell next (build_sort.comp), so every cell's list keeps the depth order,
//               as the CPU's fill, which walks the lights in that order
//   BIN_STEP 2  each cell's range (first entry, count) by binary search of the sorted cells,
//               the longest list into counters[COUNTER_LONGEST]
// define: BIN_STEP
#include "generated.glsl"
#include "build_common.glsl"
#include "build_counters.glsl"

uniform uint u_capacity;          // scene lights: the per-light buffers' length
uniform ivec2 u_tiles;
uniform int u_slices;

#if BIN_STEP == 2
layout(std430, binding = B_COUNTERS) buffer Counters { uint counters[]; };
#else
layout(std430, binding = B_COUNTERS) readonly buffer Counters { uint counters[]; };
#endif

#if BIN_STEP == 0
layout(std430, binding = B_LIGHT_RECT) readonly buffer Rects { dvec4 light_rect[]; };
layout(std430, binding = B_LIGHT_DEPTH) readonly buffer Depths { vec2 light_depth[]; };
layout(std430, binding = B_SLICE_TABLE) readonly buffer Table { double slice_table[]; };
layout(std430, binding = B_BOXES) buffer Boxes { ivec2 boxes[]; };     // 3 a light: x, y, slice ranges
layout(std430, binding = B_CELL_COUNTS) buffer Counts { uint cell_counts[]; };

uniform double u_tile, u_inv_tile;
uniform double u_depth_lo_scale, u_depth_hi_scale;   // 1 -+ SLICE_DEPTH_REL_MARGIN
uniform int u_table_size;         // 2^k - 1 steps, NaN-padded (grid._table_for)

// grid.tile_of: floor(x / tile) from the reciprocal, corrected by one either way
double tile_of(double x) {
    precise double q = floor(x * u_inv_tile);
    if (q * u_tile > x) q = q - 1.0lf;
    precise double q1 = q + 1.0lf;
    return q1 * u_tile <= x ? q1 : q;
}

// grid.slice_from_table: how many of the table's steps are at or below the depth
int slice_from_table(double depth) {
    int s = 0;
    for (int step = (u_table_size + 1) >> 1; step > 0; step >>= 1)
        s += depth >= slice_table[s + step - 1] ? step : 0;
    return s;
}

void main() {
    uint j = element_index();
    if (j >= u_capacity) return;
    ivec2 x = ivec2(1, 0), y = ivec2(1, 0), sl = ivec2(1, 0);
    if (j < counters[COUNTER_VISIBLE]) {
        dvec4 r = light_rect[j];
        vec2 d = light_depth[j];
        if (r.x <= r.y && r.z <= r.w && d.x <= d.y) {
            x = ivec2(int(max(tile_of(r.x), 0.0lf)), int(min(tile_of(r.y), double(u_tiles.x) - 1.0lf)));
            y = ivec2(int(max(tile_of(r.z), 0.0lf)), int(min(tile_of(r.w), double(u_tiles.y) - 1.0lf)));
            precise double lo = double(d.x) * u_depth_lo_scale, hi = double(d.y) * u_depth_hi_scale;
            sl = ivec2(slice_from_table(lo), slice_from_table(hi));
        }
    }
    boxes[3u * j] = x;
    boxes[3u * j + 1u] = y;
    boxes[3u * j + 2u] = sl;
    bool empty = x.x > x.y || y.x > y.y || sl.x > sl.y;
    cell_counts[j] = empty ? 0u : uint((x.y - x.x + 1) * (y.y - y.x + 1) * (sl.y - sl.x + 1));
}
#elif BIN_STEP == 1
layout(std430, binding = B_BOXES) readonly buffer Boxes { ivec2 boxes[]; };
layout(std430, binding = B_LIGHT_FIRST) readonly buffer First { uint light_first[]; };
layout(std430, binding = B_ENTRY_CELLS) buffer Cells { uint entry_cells[]; };
layout(std430, binding = B_ENTRY_LIGHTS) buffer Lights { uint entry_lights[]; };
#include "build_entries.glsl"

void main() {
    uint e = element_index();
    if (e >= counters[COUNTER_ENTRIES]) return;
    uint light = entry_light(e);
    entry_cells[e] = entry_cell(light, e - light_first[light]);
    entry_lights[e] = light;
}
#else
layout(std430, binding = B_SORTED_CELLS) readonly buffer Cells { uint sorted_cells[]; };
layout(std430, binding = B_RANGES) buffer Ranges { CellRange ranges[]; };

uniform uint u_cells;

// the first sorted entry whose cell is at or past c
uint lower_bound(uint c, uint n) {
    uint lo = 0u, hi = n;
    while (lo < hi) {
        uint mid = (lo + hi) >> 1;
        if (sorted_cells[mid] < c) lo = mid + 1u; else hi = mid;
    }
    return lo;
}

void main() {
    uint c = element_index();
    if (c >= u_cells) return;
    uint n = counters[COUNTER_ENTRIES];
    uint first = lower_bound(c, n), count = lower_bound(c + 1u, n) - first;
    ranges[c].offset_count = uvec2(first, count);
    atomicMax(counters[COUNTER_LONGEST], count);
}
#endif
