#version 430
// Perfect culler, set-up pass 2 (untimed), one band: write the index of every light that
// affects the pixel into its range (from the CPU prefix sum of the count pass).  The same
// evaluate_light on the same inputs decides, so exactly `count` indices are written; the
// bound check only guards against a driver that disagrees with itself.
#include "generated.glsl"
#include "wave.glsl"
#include "pixel.glsl"
#include "perfect_common.glsl"

layout(std430, binding = B_PERFECT_RANGES) readonly buffer PerfectRanges { uvec2 perfect_ranges[]; };
layout(std430, binding = B_PERFECT_ENTRIES) writeonly buffer PerfectEntries { uint perfect_entries[]; };
// entries written so far by the earlier dispatch windows of this band (pixel.glsl)
layout(std430, binding = B_PERFECT_CURSOR) buffer PerfectCursor { uint perfect_cursor[]; };

void main() {
    PixelState s = perfect_load_pixel();
    if (!s.shading) return;
    uint b = perfect_band_index(s);
    uvec2 r = perfect_ranges[b];
    s.count = first_window() ? 0u : perfect_cursor[b];
    uvec2 w = window_part(s, u_light_count);
    for (uint i = w.x; i < w.y && s.count < r.y; ++i) {
        uint before = s.count;
        evaluate_light(s, lights[i]);
        if (s.count != before) perfect_entries[r.x + before] = i;
    }
    perfect_cursor[b] = s.count;
}
