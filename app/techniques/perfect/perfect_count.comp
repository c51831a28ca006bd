#version 430
// Perfect culler, set-up pass 1 (untimed): how many visible lights affect each pixel.  The
// decision is evaluate_light's own (common.glsl), the one every technique calls, so the
// lists built from it are exact by construction.
#include "generated.glsl"
#include "wave.glsl"
#include "pixel.glsl"
#include "perfect_common.glsl"

layout(std430, binding = B_PERFECT_COUNTS) buffer PerfectCounts { uint perfect_counts[]; };

void main() {
    PixelState s = perfect_load_pixel();
    if (s.shading) evaluate_all_lights(s);        // this dispatch window's lights
    if (s.inside) {
        uint i = uint(s.pixel.y * u_size.x + s.pixel.x);
        perfect_counts[i] = (first_window() ? 0u : perfect_counts[i]) + s.count;
    }
}
