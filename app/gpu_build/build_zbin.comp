#version 430
// zbin's structures on the GPU, cpu_prep/zbin.py's bit for bit (app/gpu_build/zbins.py):
//   ZBIN_STEP 0  each visible light's bin range (zbin.light_bins: its float32 depth range in
//                float64, times the scale and the margins, floored and clamped) marked on a
//                segment tree over the bins: the range's O(log bins) canonical nodes take the
//                light's id, the smallest as atomicMax(~id), the largest as atomicMax(id + 1)
//                (0 in both: no light), so every node holds the min and max of its lights
//   ZBIN_STEP 1  each bin's min and max id over the nodes from its leaf to the root: exactly
//                the ids of the lights whose range holds it, as zbin._paint finds them; the LUT
//                entry as zbin.pack_lut writes it (narrow min | max << 16, wide (min, max);
//                empty MAX | 0)
//   ZBIN_STEP 2  each (tile, light) entry of the lights' tile boxes (build_bin.comp BIN_STEP 0
//                on a grid of one slice, and its scan): the light's bit in the tile's words
//                (zbin._fill_bits; atomicOr, so any order gives the same words)
// define: ZBIN_STEP ZBIN_WIDE ZBIN_EMPTY_MIN
#include "build_common.glsl"
#include "build_counters.glsl"

uniform uint u_capacity;          // scene lights: the per-light buffers' length
uniform uint u_size;              // the segment tree's leaves: the bins rounded up to 2^k

#if ZBIN_STEP == 0
layout(std430, binding = B_COUNTERS) readonly buffer Counters { uint counters[]; };
layout(std430, binding = B_LIGHT_DEPTH) readonly buffer Depths { vec2 light_depth[]; };
layout(std430, binding = B_ZMIN) buffer ZMin { uint zmin[]; };      // 2 u_size nodes, root 1
layout(std430, binding = B_ZMAX) buffer ZMax { uint zmax[]; };

uniform double u_scale;                   // float(zbin.bin_scale): the float32 scale, widened
uniform double u_lo_scale, u_hi_scale;    // 1 -+ ZBIN_DEPTH_REL_MARGIN
uniform int u_bins;

void mark(uint node, uint id) {
    atomicMax(zmin[node], ~id);
    atomicMax(zmax[node], id + 1u);
}

void main() {
    uint j = element_index();
    if (j >= u_capacity || j >= counters[COUNTER_VISIBLE]) return;
    vec2 d = light_depth[j];
    precise double lo = double(d.x) * u_scale * u_lo_scale;
    precise double hi = double(d.y) * u_scale * u_hi_scale;
    double last = double(u_bins - 1);
    int b0 = int(clamp(floor(min(lo, last)), 0.0lf, last));
    int b1 = int(clamp(floor(min(hi, last)), -1.0lf, last));   // -1: behind the eye
    if (b0 > b1) return;
    // the canonical nodes of the leaves [b0, b1] (bottom-up, half-open [l, r))
    for (uint l = uint(b0) + u_size, r = uint(b1) + 1u + u_size; l < r; l >>= 1, r >>= 1) {
        if ((l & 1u) != 0u) mark(l++, j);
        if ((r & 1u) != 0u) mark(--r, j);
    }
}
#elif ZBIN_STEP == 1
layout(std430, binding = B_ZMIN) readonly buffer ZMin { uint zmin[]; };
layout(std430, binding = B_ZMAX) readonly buffer ZMax { uint zmax[]; };
layout(std430, binding = B_ZBINS) buffer ZBins { uint zbins[]; };

uniform uint u_bins;

void main() {
    uint b = element_index();
    if (b >= u_bins) return;
    uint mn = 0u, mx = 0u;
    for (uint v = b + u_size; v >= 1u; v >>= 1) {
        mn = max(mn, zmin[v]);
        mx = max(mx, zmax[v]);
    }
    bool empty = mx == 0u;
    uint lo = ~mn, hi = mx - 1u;
#if ZBIN_WIDE
    zbins[2u * b] = empty ? uint(ZBIN_EMPTY_MIN) : lo;
    zbins[2u * b + 1u] = empty ? 0u : hi;
#else
    zbins[b] = empty ? uint(ZBIN_EMPTY_MIN) : lo | (hi << 16);
#endif
}
#else
layout(std430, binding = B_COUNTERS) readonly buffer Counters { uint counters[]; };
layout(std430, binding = B_BOXES) readonly buffer Boxes { ivec2 boxes[]; };
layout(std430, binding = B_LIGHT_FIRST) readonly buffer First { uint light_first[]; };
layout(std430, binding = B_TILE_BITS) buffer Bits { uint tile_bits[]; };

uniform ivec2 u_tiles;
uniform int u_slices;             // 1: the cells are the tiles
uniform uint u_words;             // words of one tile's bit array
#include "build_entries.glsl"

void main() {
    uint e = element_index();
    if (e >= counters[COUNTER_ENTRIES]) return;
    uint light = entry_light(e);
    uint tile = entry_cell(light, e - light_first[light]);
    atomicOr(tile_bits[tile * u_words + (light >> 5)], 1u << (light & 31u));
}
#endif
