#version 430
// sample-ris, its first pass ("shade": it evaluates the lights): the round's reservoir of
// each shading pixel, by resampled importance sampling (Talbot et al. 2005, "Importance resampling for global illumination";
// Bitterli et al. 2020, Algorithm 3): M candidates drawn from the pixel's cluster list by
// the source pdf p (the cell's integer CDF, cpu_prep.sampling), each weighted
// w = p-hat / p, one kept by weighted reservoir sampling; W = (1 / p-hat(y)) (1 / M) sum w.
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"
#include "sampling.glsl"
#include "sample_cdf.glsl"
#include "ris.glsl"

uniform uint u_candidates;     // M

// Algorithm 3 over the cell's entries [first, first + n): M target evaluations.
Reservoir resample(inout PixelState s, uint first, uint n) {
    Reservoir r = empty_reservoir();
    uint stream = round_stream(s, 0u);
    float wsum = 0.0;
    // priced: light
    for (uint k = 0u; k < u_candidates; ++k) {
        float p;
        uint light = entries[draw_entry(first, n, next_mass(stream), p)];
        GpuLight L = lights[light];
        vec3 f = target_contribution(s, L);
        // p-hat / p: the luminance of f / p (SAMPLE_FAULT's faulty weights go through here)
        if (accept(wsum, luminance(weighted(f, p)), stream)) keep(r, light, f);
    }
    r.M = u_candidates;
    r.W = contribution_weight(wsum, float(r.M), r.p_hat);
    return r;
}

void main() {
#if defined(CELLS_ONLY) && CELLS_ONLY
    return;                       // a modelled frame records cells only (ris_resolve.comp)
#endif
    PixelState s = load_pixel();
    uvec2 range = s.shading ? ranges[cell_of(s)].offset_count : uvec2(0u);
    Reservoir r = range.y > 0u ? resample(s, range.x, range.y) : empty_reservoir();
    r.evaluated = s.evaluated;
    if (s.inside) ris_out[pixel_index(s.pixel)] = r;
}
