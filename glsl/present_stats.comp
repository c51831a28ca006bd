#version 430
// Frame sums for the window's HUD and heat scale (the view_stats pass, app/window/passes.py),
// over pixels covered by geometry: covered pixel count, lights evaluated, exact lights, max
// evaluated per pixel (ViewStats, cpu_prep/layouts.py VIEW_STATS; view_stats cleared first).
// 64-bit sums as lo/hi words: each add detects its own carry from the returned old value.
#include "generated.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform sampler2D g_position;
layout(std430, binding = B_OUT_STATS) readonly buffer OutStats { PixelStats out_stats[]; };
layout(std430, binding = B_VIEW_STATS) buffer ViewStatsBuffer { ViewStats view_stats; };
uniform ivec2 u_size;

shared uint s_covered, s_evaluated, s_exact, s_max;

void main() {
    if (gl_LocalInvocationIndex == 0u) { s_covered = 0u; s_evaluated = 0u; s_exact = 0u; s_max = 0u; }
    barrier();
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (all(lessThan(p, u_size)) && texelFetch(g_position, p, 0).w > 0.0) {
        PixelStats st = out_stats[p.y * u_size.x + p.x];
        atomicAdd(s_covered, 1u);
        atomicAdd(s_evaluated, st.evaluated);   // a group: 64 x at most 2^22 lights < 2^32
        atomicAdd(s_exact, st.contrib_count);
        atomicMax(s_max, st.evaluated);
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u && s_covered > 0u) {
        atomicAdd(view_stats.covered, s_covered);
        uint old = atomicAdd(view_stats.evaluated_lo, s_evaluated);
        if (old > 0xFFFFFFFFu - s_evaluated) atomicAdd(view_stats.evaluated_hi, 1u);
        old = atomicAdd(view_stats.exact_lo, s_exact);
        if (old > 0xFFFFFFFFu - s_exact) atomicAdd(view_stats.exact_hi, 1u);
        atomicMax(view_stats.max_evaluated, s_max);
    }
}
