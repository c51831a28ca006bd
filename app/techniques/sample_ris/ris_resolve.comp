#version 430
// sample-ris, its resolve pass, the final shading (one a round): the round's reservoir's
// estimate f(y) W added to the pixel's sum (carried over from the rounds before in the frame
// outputs), the S rounds' mean stored at the last.  f(y) is the kept f, from the evaluation that computed
// p-hat(y) at this pixel: this lab's lights cast no shadows, so the shade is the target's own
// vector and costs no evaluation (a renderer with shadows traces the kept light's ray here).
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "cells.glsl"
#include "sampling.glsl"
#include "ris.glsl"

void main() {
    PixelState s = load_pixel();
    s.cell = s.shading ? cell_of(s) : 0u;
    CELLS_ONLY_RETURN(s);
    uint i = s.inside ? pixel_index(s.pixel) : 0u;
    if (s.inside && u_reservoir > 0u) {
        s.radiance = out_color[i].rgb;
        s.evaluated = out_stats[i].evaluated;
    }
    if (s.shading) {
        Reservoir r = ris_in[i];
        s.evaluated += r.evaluated;
        if (r.light != RIS_NO_LIGHT) s.radiance += kept_contribution(r) * r.W;
    }
    if (u_reservoir + 1u == u_samples) s.radiance /= float(u_samples);
    store_estimate(s);
    write_wave_stats(s.evaluated, CASE_LIST);
}
