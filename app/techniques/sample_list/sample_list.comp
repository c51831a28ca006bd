#version 430
// sample-list: S lights drawn from the pixel's cluster list, p = mass / 2^31 from the cell's
// cumulative words (cpu_prep.sampling), each weighted 1 / (S p).
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"
#include "sampling.glsl"
#include "sample_cdf.glsl"

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
