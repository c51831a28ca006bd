#version 430
// clustered (Persson 2013): the pixel's cell of the 2.5D grid, its index list; with
// SCALARIZED, the wave walks its distinct cells one at a time (Drobot 2017's hierarchical
// container scalarization, lists.glsl).
// define: SCALARIZED
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"

void main() {
    PixelState s = load_pixel();
    uint cell = s.shading ? cell_of(s) : 0u;
    s.cell = cell;
    CELLS_ONLY_RETURN(s);
#if SCALARIZED
    uint iterations = evaluate_cells_scalarized(s, cell, s.shading);
#else
    if (s.shading) {
        uvec2 r = ranges[cell].offset_count;
        evaluate_list(s, r.x, r.y);
    }
    uint iterations = s.evaluated;
#endif
    store_pixel(s);
    write_wave_stats(iterations, CASE_LIST);
}
