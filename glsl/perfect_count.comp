#version 430
// Perfect culler, set-up pass 1 (untimed): how many visible lights affect each pixel.  The
// decision is evaluate_light's own (common.glsl), the one every technique calls, so the
// lists built from it are exact by construction.
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "perfect_common.glsl"

layout(std430, binding = B_PERFECT_COUNTS) writeonly buffer PerfectCounts { uint perfect_counts[]; };

void main() {
    PixelState s = perfect_load_pixel();
    if (s.shading)
        for (uint i = 0u; i < u_light_count; ++i) evaluate_light(s, lights[i]);
    if (s.inside) perfect_counts[uint(s.pixel.y * u_size.x + s.pixel.x)] = s.count;
}
