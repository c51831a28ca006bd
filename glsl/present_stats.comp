#version 430
// Frame sums for the window (the view_stats pass, app/window/passes.py), over the pixels
// geometry covers:
//   view_stats (ViewStats, cpu_prep/layouts.py VIEW_STATS): covered pixel count, lights
//     evaluated, exact lights (64-bit sums as lo/hi words: each add detects its own carry
//     from the returned old value), max evaluated per pixel (the heat scale);
//   view_extra (uint words, app/window/passes.py EXTRA_HEAD): lit pixels, max exact lights,
//     (reserved), pixels whose light set differs from the reference's (REF = 1, every pixel),
//     and the log2 luminance histogram of the lit pixels (automatic exposure, app/images.py).
// Both are cleared before the pass.  One 8x8 group covers 32x32 pixels, each invocation 4x4
// of them (interleaved) summed in registers: a software rasterizer pays for every atomic.
// define: REF HIST_BINS HIST_LOG2_MIN HIST_LOG2_MAX HEAT_ZERO HEAT_OVERLAY_ALPHA REF_UNIT
#include "generated.glsl"
#include "present_common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = G_POSITION_UNIT) uniform sampler2D g_position;
#if REF
layout(binding = REF_UNIT) uniform usampler2D u_ref_stats;   // the reference's PixelStats
#endif
layout(std430, binding = B_OUT_COLOR) readonly buffer OutColor { vec4 out_color[]; };
layout(std430, binding = B_OUT_STATS) readonly buffer OutStats { PixelStats out_stats[]; };
layout(std430, binding = B_VIEW_STATS) buffer ViewStatsBuffer { ViewStats view_stats; };
layout(std430, binding = B_VIEW_EXTRA) buffer ViewExtra {
    uint lit; uint max_exact; uint reserved; uint differ; uint hist[HIST_BINS];
};
uniform ivec2 u_size;

shared uint s_covered, s_ev_lo, s_ev_hi, s_ex_lo, s_ex_hi, s_max, s_lit, s_max_exact, s_differ;
shared uint s_hist[HIST_BINS];

// a 64-bit sum as lo/hi words: the add detects its carry from the returned old value
void add64_shared(uint v, bool exact) {
    if (v == 0u) return;
    if (exact) { uint old = atomicAdd(s_ex_lo, v); if (old > 0xFFFFFFFFu - v) atomicAdd(s_ex_hi, 1u); }
    else       { uint old = atomicAdd(s_ev_lo, v); if (old > 0xFFFFFFFFu - v) atomicAdd(s_ev_hi, 1u); }
}

void main() {
    uint li = gl_LocalInvocationIndex;
    if (li == 0u) {
        s_covered = 0u; s_ev_lo = 0u; s_ev_hi = 0u; s_ex_lo = 0u; s_ex_hi = 0u; s_max = 0u;
        s_lit = 0u; s_max_exact = 0u; s_differ = 0u;
    }
    for (uint b = li; b < uint(HIST_BINS); b += 64u) s_hist[b] = 0u;
    barrier();
    // 16 pixels per invocation: at most 16 x 2^22 lights, no 32-bit overflow in registers
    uint covered = 0u, ev = 0u, ex = 0u, mx = 0u, mx_exact = 0u, n_lit = 0u, n_differ = 0u;
    ivec2 base = ivec2(gl_WorkGroupID.xy) * 32 + ivec2(gl_LocalInvocationID.xy);
    for (int j = 0; j < 4; ++j) {
        for (int k = 0; k < 4; ++k) {
            ivec2 p = base + ivec2(k, j) * 8;
            if (any(greaterThanEqual(p, u_size))) continue;
            uint i = uint(p.y * u_size.x + p.x);
            PixelStats st = out_stats[i];
#if REF
            // every pixel, sky included: the exactness check of the dump contract
            uvec4 r = texelFetch(u_ref_stats, p, 0);
            if (r.y != st.contrib_count || r.z != st.contrib_hash) n_differ++;
#endif
            if (texelFetch(g_position, p, 0).w > 0.0) {
                covered++;
                ev += st.evaluated;
                ex += st.contrib_count;
                mx = max(mx, st.evaluated);
                mx_exact = max(mx_exact, st.contrib_count);
                float y = dot(max(out_color[i].rgb, vec3(0.0)), LUMA);
                if (y > 0.0) {
                    n_lit++;
                    atomicAdd(s_hist[hist_bin(y)], 1u);
                }
            }
        }
    }
    if (covered > 0u) {
        atomicAdd(s_covered, covered);
        add64_shared(ev, false);
        add64_shared(ex, true);
        atomicMax(s_max, mx);
        atomicMax(s_max_exact, mx_exact);
        if (n_lit > 0u) atomicAdd(s_lit, n_lit);
    }
    if (n_differ > 0u) atomicAdd(s_differ, n_differ);
    barrier();
    for (uint b = li; b < uint(HIST_BINS); b += 64u)
        if (s_hist[b] > 0u) atomicAdd(hist[b], s_hist[b]);
    if (li == 0u) {
        atomicAdd(view_stats.covered, s_covered);
        uint old = atomicAdd(view_stats.evaluated_lo, s_ev_lo);
        atomicAdd(view_stats.evaluated_hi, s_ev_hi + (old > 0xFFFFFFFFu - s_ev_lo ? 1u : 0u));
        old = atomicAdd(view_stats.exact_lo, s_ex_lo);
        atomicAdd(view_stats.exact_hi, s_ex_hi + (old > 0xFFFFFFFFu - s_ex_lo ? 1u : 0u));
        atomicMax(view_stats.max_evaluated, s_max);
        atomicAdd(lit, s_lit);
        atomicMax(max_exact, s_max_exact);
        atomicAdd(differ, s_differ);
    }
}
