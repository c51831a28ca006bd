#version 430
// sample-list: S lights drawn from the pixel's cluster list, p = mass / 2^31 from the cell's
// cumulative words (cpu_prep.sampling), each weighted 1 / (S p).
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"
#include "sampling.glsl"

layout(std430, binding = B_SAMPLE_CDF) readonly buffer SampleCdf { uint sample_cdf[]; };

// The first entry k of [first, first + n) with u < sample_cdf[k] (the last holds 2^31 > u);
// its probability from its own word and the one before.
uint draw_entry(uint first, uint n, uint u, out float p) {
    uint lo = first, hi = first + n - 1u;
    // priced: word
    while (lo < hi) {
        uint mid = (lo + hi) >> 1u;
        if (u < sample_cdf[mid]) hi = mid; else lo = mid + 1u;
    }
    p = mass_probability(sample_cdf[lo] - (lo > first ? sample_cdf[lo - 1u] : 0u));
    return lo;
}

void main() {
    PixelState s = load_pixel();
    uint cell = s.shading ? cell_of(s) : 0u;
    s.cell = cell;
    CELLS_ONLY_RETURN(s);
    uvec2 r = s.shading ? ranges[cell].offset_count : uvec2(0u);
    if (r.y > 0u) {
        uint stream = pixel_stream(s);
        vec3 sum = vec3(0.0);
        // priced: light
        for (uint k = 0u; k < u_samples; ++k) {
            float p;
            uint e = draw_entry(r.x, r.y, next_mass(stream), p);
            GpuLight L = lights[entries[e]];
            sum += weighted(light_contribution(s, L, L.id_type.y), p);
        }
        s.radiance = sum / float(u_samples);
    }
    store_estimate(s);
    write_wave_stats(s.evaluated, CASE_LIST);
}
