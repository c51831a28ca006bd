#version 430
// The support of sample-list and sample-ris: every light of the pixel's cell list whose mass
// is nonzero, evaluated, their affecting set's count and hash stored (glsl/sampling.glsl).
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"
#include "sampling.glsl"

layout(std430, binding = B_SAMPLE_CDF) readonly buffer SampleCdf { uint sample_cdf[]; };

void main() {
#if defined(CELLS_ONLY) && CELLS_ONLY
    return;                       // a modelled frame: no light loop runs, no support to count
#endif
    PixelState s = load_pixel();
    if (s.shading) {
        uvec2 r = ranges[cell_of(s)].offset_count;
        uvec2 w = window_part(s, r.y);
        for (uint k = r.x + w.x; k < r.x + w.y; ++k) {
            uint before = k > r.x ? sample_cdf[k - 1u] : 0u;
            if (sample_cdf[k] > before) evaluate_light(s, lights[entries[k]]);
        }
    }
    store_support(s);
}
