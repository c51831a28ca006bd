#version 430
// brute: every frustum-visible light at every pixel.  The reference of the exactness check.
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"

void main() {
    PixelState s = load_pixel();
    if (s.shading)
        for (uint i = 0u; i < u_light_count; ++i) evaluate_light(s, lights[i]);
    store_pixel(s);
    uint longest = groupAllMax(s.evaluated);
    if (gl_LocalInvocationIndex == 0u) wave_stats[group_index()] = uvec4(longest, 1u, 0u, 0u);
}
