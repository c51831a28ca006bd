#version 430
// Perfect culler, the timed pass: the shading loop over exactly the lights that affect the
// pixel (its culling waste is 1.0 by construction).  Its time is the floor every technique's
// shading pass is measured against.
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "perfect_common.glsl"

layout(std430, binding = B_PERFECT_RANGES) readonly buffer PerfectRanges { uvec2 perfect_ranges[]; };
layout(std430, binding = B_PERFECT_ENTRIES) readonly buffer PerfectEntries { uint perfect_entries[]; };

void main() {
    PixelState s = resume_pixel(perfect_load_pixel());
    CELLS_ONLY_RETURN(s);
    if (s.shading) {
        uvec2 r = perfect_ranges[perfect_band_index(s)];
        uvec2 w = window_part(s, r.y);
        // priced: light
        for (uint k = r.x + w.x; k < r.x + w.y; ++k) evaluate_light(s, lights[perfect_entries[k]]);
    }
    store_pixel(s);
    uint longest = groupAllMax(s.evaluated);
    if (gl_LocalInvocationIndex == 0u) {   // a plain store: every band writes only its groups
        wave_stats[perfect_group_index()].iterations = longest;
        wave_stats[perfect_group_index()].case_bits = CASE_LIST;
    }
}
