#version 430
// brute: every frustum-visible light at every pixel.  The reference of the exactness check.
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"

void main() {
    PixelState s = load_pixel();
    CELLS_ONLY_RETURN(s);
    if (s.shading) evaluate_all_lights(s);
    store_pixel(s);
    write_wave_stats(s.evaluated, CASE_LIST);
}
