#version 430
// clustered (Persson 2013): the pixel's cell of the 2.5D grid, its index list.
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"

void main() {
    PixelState s = load_pixel();
    if (s.shading) {
        uvec2 r = ranges[cell_of(s)].offset_count;
        evaluate_list(s, r.x, r.y);
    }
    store_pixel(s);
    write_wave_stats(s.evaluated, 1u);
}
